#!/bin/bash
# Runs the README's quick start from the README text itself, against the built program, so
# the README cannot fall behind the program. The quick start is the ```sh block that
# follows the line <!-- quickstart -->; it runs in a temporary folder with the built armsig
# first on PATH. Every command must exit 0, or the code a trailing "# exit N" states; the
# first that does not fails the test, named with its README line.
#
# Usage: quickstart_test.sh ARMSIG README.md
set -u
armsig=$(realpath "$1")
readme=$(realpath "$2")
name=$(basename "$readme")

# The block: its first line's number, then its lines up to the closing fence.
start=$(awk '/^<!-- quickstart -->$/ { marked = 1; next }
             marked && /^```sh$/ { print NR + 1; exit }
             marked && NF { exit }' "$readme")
if [ -z "$start" ]; then
  echo "$name: no quick start: expected a \`\`\`sh block right after a line <!-- quickstart -->"
  exit 1
fi
block=$(awk -v start="$start" 'NR >= start { if (/^```$/) exit; print }' "$readme")
if [ -z "$block" ]; then
  echo "$name:$start: the quick start block is empty"
  exit 1
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/armsig-quickstart-XXXXXX")
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/bin" "$work/tmp" "$work/run"
ln -s "$armsig" "$work/bin/armsig"

# A line that ends in "# exit N" (N not 0) must exit N: it is run as a condition, so that
# errexit does not end the script, and its code compared. One script line per README line,
# so that LINENO names the README line.
expect='^(.*[^[:space:]])[[:space:]]+#[[:space:]]*exit[[:space:]]+([0-9]+)[[:space:]]*$'
script="$work/quickstart.sh"
{
  echo 'set -e -o pipefail'
  echo "export PATH='$work/bin':\"\$PATH\" TMPDIR='$work/tmp'"
  echo "trap 'kill \$(jobs -p) 2>/dev/null || true; wait' EXIT"
  echo "trap 'exit 143' TERM"
  echo "trap 'echo \"$name:\$((LINENO + $start - 7)): exit \$?: \$BASH_COMMAND\" >&2' ERR"
  echo "quickstart_expect() { echo \"$name:\$((\$1 + $start - 7)): exit \$2, expected \$3\" >&2; exit 1; }"
  while IFS= read -r line; do
    if [[ "$line" =~ $expect ]]; then
      echo "if ${BASH_REMATCH[1]}; then rc=0; else rc=\$?; fi; [ \$rc = ${BASH_REMATCH[2]} ] || quickstart_expect \$LINENO \$rc ${BASH_REMATCH[2]}"
    else
      printf '%s\n' "$line"
    fi
  done <<<"$block"
} >"$script"

cd "$work/run"
timeout -k 10 "${ARMSIG_QUICKSTART_TIMEOUT:-300}" bash "$script" </dev/null
code=$?
if [ $code -ne 0 ]; then
  [ $code -eq 124 ] && echo "$name:$start: the quick start did not finish in ${ARMSIG_QUICKSTART_TIMEOUT:-300} s"
  echo "$name: the quick start failed (exit $code); the README's commands no longer work as written"
  exit 1
fi
echo "$name: the quick start's $(grep -c . <<<"$block") lines ran as written"
