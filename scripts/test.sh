#!/usr/bin/env bash
# README command 2: install what is missing, build (warnings are errors), run the whole
# test suite through ctest, then again under AddressSanitizer + UndefinedBehaviorSanitizer.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
jobs="$(nproc)"
scripts/build.sh build -DARMSIG_WERROR=ON
ctest --test-dir build --output-on-failure --parallel "$jobs"
scripts/build.sh build-asan -DARMSIG_WERROR=ON -DARMSIG_SANITIZE=ON -DARMSIG_BUILD_BENCH=OFF
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure --parallel "$jobs"
