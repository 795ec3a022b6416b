#!/bin/bash
# The quick-start runner itself can fail: a command that fails is named with its README line,
# a stated exit code is held to, a missing block is refused, and a block that works passes.
# Usage: quickstart_selftest.sh ARMSIG
set -u
runner="$(dirname "$0")/quickstart_test.sh"
armsig=$1
dir=$(mktemp -d "${TMPDIR:-/tmp}/armsig-quickstart-selftest-XXXXXX")
trap 'rm -rf "$dir"' EXIT
failures=0

# check NAME EXPECTED_EXIT (0 or 1) MESSAGE_PATTERN README_TEXT
check() {
  printf '%s\n' "$4" >"$dir/README.md"
  out=$(bash "$runner" "$armsig" "$dir/README.md" 2>&1)
  code=$?
  if [ "$code" != "$2" ] || ! grep -Eq -- "$3" <<<"$out"; then
    echo "FAILED: $1: exit $code (expected $2), output:"
    echo "$out"
    failures=$((failures + 1))
  fi
}

check "a block that works passes" 0 "3 lines ran" '# A README
<!-- quickstart -->
```sh
armsig --version
armsig db init
armsig --db missing.db db info   # exit 2
```'
check "a failing command is named with its line" 1 "README.md:5: exit 2: armsig --db missing.db db info" '# A README

<!-- quickstart -->
```sh
armsig --db missing.db db info
armsig --version
```'
check "a command that exits 0 where 3 is stated fails" 1 "README.md:4: exit 0, expected 3" '<!-- quickstart -->
```sh
armsig --version
armsig --version   # exit 3
```'
check "a line inside a continued command" 1 "exit 2" '<!-- quickstart -->
```sh
armsig db init
armsig --db missing.db \
    db info
```'
check "no marked block is refused" 1 "no quick start" '# A README
```sh
armsig --version
```'
check "a background command is stopped at the end" 0 "2 lines ran" '<!-- quickstart -->
```sh
sleep 1000 &
armsig --version
```'
[ $failures -eq 0 ] && echo "the quick-start runner fails where it must and passes where it must"
exit $((failures > 0))
