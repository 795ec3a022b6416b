# Per-target instrumentation of the sanitizer tree (ARMSIG_SANITIZE, ARMSIG_FUZZ).

# armsig_fuzzed(TARGET): libFuzzer's coverage instrumentation for a library whose parsers the
# fuzzers in fuzz/ drive (core, io, instruments, acquisition). The others need no coverage
# feedback: instrumenting them cost an eighth of the tree's compile time for nothing.
function(armsig_fuzzed target)
  if(ARMSIG_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# armsig_pointers_by_asan(TARGET): a target whose pointer accesses AddressSanitizer checks
# alone: it keeps ASan and UBSan's arithmetic, conversion, enum, bool, vptr, return and bounds
# checks but leaves out UBSan's pointer checks (null, alignment, object-size,
# pointer-overflow), which on Eigen's expression templates and GoogleTest's macros double a
# source's compile time (calibration/residual_map.cc: 34 s → 19 s; tests/workflows/
# report_test.cc 82 s → 58 s, clang -O1) and slow the tests, while ASan's shadow memory
# already catches an access outside an object and a null access faults. Used for the dense
# linear algebra (calibration, reduction) and the test programs; the byte-level code they
# test (protocols, files, the database) keeps all of them in its own libraries.
function(armsig_pointers_by_asan target)
  if(ARMSIG_SANITIZE)
    target_compile_options(${target} PRIVATE
                           -fno-sanitize=pointer-overflow,alignment,null,object-size)
  endif()
endfunction()

# armsig_optimized(TARGET): a numerical library the tests spend their time in (the fits, the
# network adjustment, the inverse kinematics) keeps -O1 in the sanitizer tree, where everything
# else is built at -O0 for the compile time.
function(armsig_optimized target)
  if(ARMSIG_SANITIZE)
    target_compile_options(${target} PRIVATE -O1)
  endif()
endfunction()

# armsig_numerics_first(TARGET): in the sanitizer tree, where all but the numerical libraries
# are built at -O0, a program links the numerical libraries' objects before its own, so that
# the out-of-line copies of the templates both instantiate (Eigen's matrix product kernels
# above all) are theirs, built at -O1: the linker keeps the first copy of a template it meets,
# and a test program's own -O0 copy of Eigen's product kernel made the real UR10 fits ten
# times slower (Ur10Split: 15 s → 170 s). The core library comes last: it carries libFuzzer's
# coverage instrumentation (armsig_fuzzed), which in its copy of a product kernel tripled the
# same test's time.
function(armsig_numerics_first target)
  if(ARMSIG_SANITIZE)
    target_link_options(${target} PRIVATE
      "SHELL:-Wl,--whole-archive $<TARGET_FILE:armsig_calibration> $<TARGET_FILE:armsig_reduction> $<TARGET_FILE:armsig_programs> $<TARGET_FILE:armsig_core> -Wl,--no-whole-archive")
  endif()
endfunction()
