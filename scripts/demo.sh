#!/usr/bin/env bash
# README command 1: install what is missing, build the program, run the main job.
# Only the program is built (the tests and benchmarks are the test command's), optimised and
# without debug information, with clang (the compiler CI checks; it builds faster than gcc):
# 4 min 15 s on two cores from a clean clone, apt check included (README, "Two commands").
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
if [[ ! -f build/CMakeCache.txt ]]; then
  CXX=clang++ cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" -DARMSIG_BUILD_TESTS=OFF \
    -DARMSIG_BUILD_BENCH=OFF >/dev/null
fi
# The manual page and the bash completion too (0.1 s), so that `cmake --install build` finds
# every file it installs.
cmake --build build --target armsig armsig_docs --parallel "$(nproc)"
exec build/armsig demo "$@"
