#!/usr/bin/env bash
# README command 2: install what is missing, build (warnings are errors), run the whole
# test suite through ctest, then again under AddressSanitizer + UndefinedBehaviorSanitizer
# (clang), then every parser under libFuzzer for a short run.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
jobs="$(nproc)"
# The test tree carries no debug information: it costs a third of the build on CI's two
# cores and a failing test names its file and line without it.
scripts/build.sh build -DARMSIG_WERROR=ON -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -DNDEBUG"
ctest --test-dir build --output-on-failure --parallel "$jobs"
# One clang tree instrumented for AddressSanitizer + UndefinedBehaviorSanitizer and for
# libFuzzer (ARMSIG_FUZZ implies ARMSIG_SANITIZE): the suite under the sanitizers,
# then every parser under libFuzzer for a short run (scripts/fuzz.sh 3600 is the long
# campaign) from the same objects.
CXX=clang++ scripts/build.sh build-fuzz -DARMSIG_WERROR=ON -DARMSIG_FUZZ=ON \
  -DARMSIG_BUILD_TESTS=ON -DARMSIG_BUILD_BENCH=OFF
# The real-data figures (the UR10's 2,773 poses through Ceres, a minute or more each under
# ASan, half the sanitizer pass) ran above in the gcc suite; under the sanitizers the same
# code paths run on the smaller data of every other test.
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-fuzz --output-on-failure --parallel "$jobs" \
  --exclude-regex "${ARMSIG_SANITIZE_SKIP:-RealUr10|Ur10Split|ResidualMapIsStoredAppliedExportedAndReported|ServerRoles}"
scripts/fuzz.sh "${ARMSIG_FUZZ_SECONDS:-10}"
