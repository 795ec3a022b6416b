#!/usr/bin/env bash
# README command 2: install what is missing, build one clang tree instrumented for
# AddressSanitizer + UndefinedBehaviorSanitizer and libFuzzer (ARMSIG_FUZZ implies
# ARMSIG_SANITIZE; warnings are errors), run the whole test suite in it through ctest (the
# real-data figures included), then every parser under libFuzzer for a short run from the
# same objects (scripts/fuzz.sh 3600 is the long campaign).
set -euo pipefail
cd "$(dirname "$0")/.."
# Each phase's wall time, printed last (also when a phase fails): what a CI run's log needs to
# tell where its minutes went.
# The free disk space after each phase too: a CI run once failed mid-suite on a full disk
# ("No space left on device" from the test PostgreSQL server and SQLite).
free_mb() { df -Pm . | awk 'NR == 2 { print $4 }'; }
phases=() phase_start=$SECONDS
phase() { phases+=("$1 $((SECONDS - phase_start)) s [$(free_mb) MB free]"); phase_start=$SECONDS; }
start_free="$(free_mb)"
trap 'echo "scripts/test.sh phases: ${phases[*]:-none finished} (${SECONDS} s in all; ${start_free} MB free at the start)"' EXIT
scripts/setup.sh --tests
phase setup
jobs="$(nproc)"
CXX=clang++ scripts/build.sh build-fuzz -DARMSIG_WERROR=ON -DARMSIG_FUZZ=ON \
  -DARMSIG_BUILD_TESTS=ON -DARMSIG_BUILD_BENCH=OFF
phase build
# ctest starts the longest entries first: each entry's COST is its tests' times measured in
# this configuration (tests/ctest-costs.txt; tests/cmake/GroupTests.cmake), so a long test
# does not start last. Two entries per core: many tests wait on a pty, a socket, a server or
# a deadline (860 tests on two cores: 321 s with three at a time, 278 s with four).
ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-fuzz --output-on-failure --parallel "$((jobs * 2))"
phase tests
scripts/fuzz.sh "${ARMSIG_FUZZ_SECONDS:-5}"
phase fuzz
