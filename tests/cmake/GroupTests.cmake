# Lists a GoogleTest program's tests and writes the ctest entries that run them (cmake -P,
# after each link of the program). Every test process costs about 0.3 CPU-s before its first
# test under the sanitizers (a 250 MB program's pages, its globals registered, its leaks
# scanned at exit): io_test's 128 tests took 23.5 CPU-s as 128 processes and 6.5 as one. So a
# test that is long on its own (HEAVY seconds or more in tests/ctest-costs.txt) is an entry of
# its own, and a suite's other tests run together, in entries of at most CHUNK seconds, named
# after the suite ("Suite" or "Suite.part2"); the failing test is named in the entry's output.
# Each entry's COST (the sum of its tests') lets ctest start the long ones first.
#
# In: BINARY, OUT (the ctest file to write), COSTS (name runs seconds per line), HEAVY, CHUNK,
# TIMEOUT, LABEL (the program's name: `ctest -L io_test`), PROPERTIES (more test properties,
# `|`-separated name|value pairs), WORKDIR.
cmake_minimum_required(VERSION 3.25)

execute_process(COMMAND "${BINARY}" --gtest_list_tests
                WORKING_DIRECTORY "${WORKDIR}"
                OUTPUT_VARIABLE listing ERROR_VARIABLE listing_err RESULT_VARIABLE rc
                TIMEOUT 60)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${BINARY} --gtest_list_tests failed (${rc}): ${listing_err}")
endif()

# What each test cost when it last ran, in milliseconds (a test not listed there, a new one:
# a second).
set(cost_of_default 1000)
if(EXISTS "${COSTS}")
  file(STRINGS "${COSTS}" cost_lines)
  foreach(line IN LISTS cost_lines)
    if(line MATCHES "^([^ ]+) [0-9]+ ([0-9]+)(\\.([0-9]*))?$")
      set(name "${CMAKE_MATCH_1}")
      set(whole "${CMAKE_MATCH_2}")
      string(SUBSTRING "${CMAKE_MATCH_4}000" 0 3 milli)
      string(REGEX REPLACE "^0+([0-9])" "\\1" milli "${milli}")
      math(EXPR ms "${whole} * 1000 + ${milli}")
      set("cost_of_${name}" "${ms}")
    elseif(line MATCHES "^([^ ]+) [0-9]+ [0-9.]+e-")
      set("cost_of_${CMAKE_MATCH_1}" 0)
    endif()
  endforeach()
endif()
math(EXPR heavy_ms "${HEAVY} * 1000")
math(EXPR chunk_ms "${CHUNK} * 1000")

set(script "# Written by tests/cmake/GroupTests.cmake from ${BINARY}: do not edit.\n")
set(extra "")
if(PROPERTIES)
  string(REPLACE "|" ";" extra_list "${PROPERTIES}")
  foreach(item IN LISTS extra_list)
    string(APPEND extra " [==[${item}]==]")
  endforeach()
endif()

function(emit name filter cost_ms)
  math(EXPR whole "${cost_ms} / 1000")
  math(EXPR milli "${cost_ms} % 1000 + 1000")
  string(SUBSTRING "${milli}" 1 3 milli)
  set(cost "${whole}.${milli}")
  string(APPEND script
         "add_test([==[${name}]==] [==[${BINARY}]==] [==[--gtest_filter=${filter}]==])\n"
         "set_tests_properties([==[${name}]==] PROPERTIES WORKING_DIRECTORY [==[${WORKDIR}]==]"
         " TIMEOUT ${TIMEOUT} COST ${cost} LABELS [==[${LABEL}]==] SKIP_REGULAR_EXPRESSION [==[\\[  SKIPPED \\]]==]${extra})\n")
  set(script "${script}" PARENT_SCOPE)
endfunction()

# The suites in the order listed, each with its cheap tests in chunks.
string(REPLACE "\n" ";" lines "${listing}")
set(suites "")
foreach(line IN LISTS lines)
  if(line MATCHES "^([^ #][^ ]*)\\.( .*)?$")
    set(suite "${CMAKE_MATCH_1}")
    list(APPEND suites "${suite}")
    set("tests_of_${suite}" "")
  elseif(line MATCHES "^  ([^ ]+)")
    list(APPEND "tests_of_${suite}" "${CMAKE_MATCH_1}")
  endif()
endforeach()

set(count 0)
foreach(suite IN LISTS suites)
  set(chunk "")
  set(chunk_cost 0)
  set(part 0)
  set(chunks "")
  foreach(test IN LISTS "tests_of_${suite}")
    set(full "${suite}.${test}")
    set(cost "${cost_of_default}")
    if(DEFINED "cost_of_${full}")
      set(cost "${cost_of_${full}}")
    endif()
    math(EXPR count "${count} + 1")
    if(cost GREATER_EQUAL heavy_ms)
      emit("${full}" "${full}" "${cost}")
      continue()
    endif()
    # A chunk ends before the test that would take it past CHUNK seconds.
    math(EXPR after "${chunk_cost} + ${cost}")
    if(after GREATER chunk_ms AND chunk)
      list(APPEND chunks "${chunk_cost}=${chunk}")
      set(chunk "")
      set(chunk_cost 0)
    endif()
    if(chunk)
      string(APPEND chunk ":")
    endif()
    string(APPEND chunk "${full}")
    math(EXPR chunk_cost "${chunk_cost} + ${cost}")
  endforeach()
  if(chunk)
    list(APPEND chunks "${chunk_cost}=${chunk}")
  endif()
  list(LENGTH chunks n)
  foreach(entry IN LISTS chunks)
    math(EXPR part "${part} + 1")
    string(FIND "${entry}" "=" eq)
    string(SUBSTRING "${entry}" 0 ${eq} cost)
    math(EXPR from "${eq} + 1")
    string(SUBSTRING "${entry}" ${from} -1 filter)
    set(name "${suite}")
    if(n GREATER 1)
      set(name "${suite}.part${part}")
    endif()
    emit("${name}" "${filter}" "${cost}")
  endforeach()
endforeach()
if(count EQUAL 0)
  message(FATAL_ERROR "${BINARY} lists no test")
endif()
file(WRITE "${OUT}" "${script}")
