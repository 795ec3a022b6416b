#!/bin/bash
# The command reference in docs/ is what the program generates from its own command line,
# and it documents every command `armsig --help` lists: a command or option changed without
# regenerating the reference fails here, naming the command that regenerates it.
#
# Usage: command_reference_test.sh ARMSIG docs/reference/commands.md
set -u
armsig=$1
reference=$2
generated=$(mktemp "${TMPDIR:-/tmp}/armsig-commands-XXXXXX.md")
trap 'rm -f "$generated"' EXIT

if ! "$armsig" generate markdown >"$generated"; then
  echo "armsig generate markdown failed"
  exit 1
fi
# Every command of the program's own help has its section.
missing=0
for command in $("$armsig" --help | awk '/^Subcommands:/ { on = 1; next } on && NF { print $1 }'); do
  if ! grep -q "^## armsig $command\$" "$generated"; then
    echo "the generated reference has no section for armsig $command"
    missing=1
  fi
done
[ $missing -eq 0 ] || exit 1
if ! diff -u "$reference" "$generated"; then
  echo
  echo "$reference is not what the program generates. From the repository root, after building:"
  echo "  build/armsig generate markdown > docs/reference/commands.md"
  exit 1
fi
echo "$reference is the program's own command reference"
