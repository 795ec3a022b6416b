#!/usr/bin/env bash
# Prints each GoogleTest test's time in the last ctest run, read from what the tests printed
# ("[       OK ] Suite.Test (358 ms)"), as tests/ctest-costs.txt keeps them (name, runs,
# seconds): the times tests/cmake/GroupTests.cmake reads to give a long test a ctest entry of
# its own. After adding slow tests and running the suite:
#   scripts/test-costs.sh > tests/ctest-costs.txt
set -euo pipefail
log="${1:-build-fuzz/Testing/Temporary/LastTest.log}"
if [[ ! -f "$log" ]]; then
  echo "test-costs.sh: no ctest log at $log (run ctest first)" >&2
  exit 2
fi
grep -aoE '^\[ +(OK|FAILED) +\] [^ ]+ \([0-9]+ ms\)' "$log" |
  awk '{ name = $(NF - 2); ms = substr($(NF - 1), 2); print name, 1, ms / 1000.0 }' |
  sort -u -k1,1
