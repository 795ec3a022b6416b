#!/usr/bin/env bash
# README command 2: install what is missing, build one clang tree instrumented for
# AddressSanitizer + UndefinedBehaviorSanitizer and libFuzzer (ARMSIG_FUZZ implies
# ARMSIG_SANITIZE; warnings are errors), run the whole test suite in it through ctest (the
# real-data figures included), then every parser under libFuzzer for a short run from the
# same objects (scripts/fuzz.sh 3600 is the long campaign).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh --tests
jobs="$(nproc)"
CXX=clang++ scripts/build.sh build-fuzz -DARMSIG_WERROR=ON -DARMSIG_FUZZ=ON \
  -DARMSIG_BUILD_TESTS=ON -DARMSIG_BUILD_BENCH=OFF
# ctest starts the longest tests first when it knows their times; a new tree gets the times
# measured in this configuration (tests/ctest-costs.txt), so a four-minute test does not
# start last. One test more than cores: many of them wait on a pty, a socket or a server.
costs=build-fuzz/Testing/Temporary/CTestCostData.txt
if [[ ! -f "$costs" ]]; then
  mkdir -p "$(dirname "$costs")"
  cp tests/ctest-costs.txt "$costs"
fi
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-fuzz --output-on-failure --parallel "$((jobs + 1))"
scripts/fuzz.sh "${ARMSIG_FUZZ_SECONDS:-10}"
