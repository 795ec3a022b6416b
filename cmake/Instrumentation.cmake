# Per-target instrumentation of the sanitizer tree (ARMSIG_SANITIZE, ARMSIG_FUZZ).

# armsig_fuzzed(TARGET): libFuzzer's coverage instrumentation for a library whose parsers the
# fuzzers in fuzz/ drive (core, io, instruments, acquisition). The others need no coverage
# feedback: instrumenting them cost an eighth of the tree's compile time for nothing.
function(armsig_fuzzed target)
  if(ARMSIG_FUZZ)
    target_compile_options(${target} PRIVATE -fsanitize=fuzzer-no-link)
  endif()
endfunction()

# armsig_numeric(TARGET): a target of dense linear algebra on Eigen's own storage (calibration,
# reduction and their tests) keeps AddressSanitizer and UBSan's arithmetic, conversion, enum,
# bool, vptr, return and bounds checks but leaves out UBSan's pointer checks (null, alignment,
# object-size, pointer-overflow): on Eigen's expression templates they double a source's
# compile time (calibration/residual_map.cc: 34 s → 19 s, clang -O1) and a test's run time,
# while ASan's shadow memory already catches an access outside an object and a null access
# faults. Byte-level code (protocols, files, the database) keeps all of them.
function(armsig_numeric target)
  if(ARMSIG_SANITIZE)
    target_compile_options(${target} PRIVATE
                           -fno-sanitize=pointer-overflow,alignment,null,object-size)
  endif()
endfunction()
