#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang into build-fuzz/ and runs each for
# SECONDS (default 20; CI uses 5, a real campaign hours: scripts/fuzz.sh 3600). Seeds:
# fuzz/seeds, the real files in tests/data (cut to MAX_LEN bytes at a line end) and every
# kept fault input in tests/data/faults/ of the target's format, chosen by its name's prefix
# (model-*.yaml seeds model_yaml_fuzz, orient-*.csv observations_fuzz and csv_fuzz, …). New
# inputs that reach new code go to build-fuzz/corpus/<target>; a crash is kept as
# build-fuzz/crashes/<target>-… and makes this script fail (turn it into a regression test
# under tests/data/faults/, named with its target's prefix).
#
#   scripts/fuzz.sh [SECONDS]      build and run every target
#   scripts/fuzz.sh --check-seeds  (no build) fail when a file in tests/data/faults/ seeds no
#                                  target: its prefix is not in the table below
set -euo pipefail
cd "$(dirname "$0")/.."

targets=(csv_fuzz poses_fuzz observations_fuzz model_yaml_fuzz stations_yaml_fuzz lab_yaml_fuzz
  gsi_fuzz geocom_fuzz robot_where_fuzz emscon_fuzz ur_fuzz rws_fuzz kuka_fuzz urscript_fuzz
  krl_fuzz rapid_fuzz)
# The longest input a target is given. libFuzzer otherwise takes the longest seed (a 120 kB
# real GSI file made gsi_fuzz mutate 120 kB inputs at ~90 executions/s); parsers are linear,
# and what a long file adds is more of the same lines.
max_len=8192

fault_prefixes() {  # target → the name prefixes of the fault inputs in its format
  case "$1" in
    csv_fuzz) echo "poses orient observations control csv" ;;
    poses_fuzz) echo "poses" ;;
    observations_fuzz) echo "orient observations control" ;;
    model_yaml_fuzz) echo "model" ;;
    stations_yaml_fuzz) echo "stations" ;;
    lab_yaml_fuzz) echo "lab" ;;
    gsi_fuzz) echo "gsi" ;;
    geocom_fuzz) echo "geocom" ;;
    robot_where_fuzz) echo "robot" ;;
    emscon_fuzz) echo "emscon" ;;
    ur_fuzz) echo "ur" ;;
    rws_fuzz) echo "rws" ;;
    urscript_fuzz) echo "urscript" ;;
    krl_fuzz) echo "krl" ;;
    rapid_fuzz) echo "rapid" ;;
    kuka_fuzz) echo "kuka" ;;
  esac
}

faults() {  # target → its fault inputs
  local prefix
  for prefix in $(fault_prefixes "$1"); do
    find tests/data/faults -maxdepth 1 -type f -name "$prefix-*"
  done
}

seeds() {  # target → seed files
  case "$1" in
    csv_fuzz) find tests/data fuzz/seeds/poses -name '*.csv' -size -64k ;;
    poses_fuzz) find fuzz/seeds/poses -type f ;;
    observations_fuzz) find tests/data/networks -name '*.csv' -size -64k ;;
    model_yaml_fuzz) find models -name '*.yaml' ;;
    stations_yaml_fuzz) find tests/data/networks -name 'stations.yaml' ;;
    lab_yaml_fuzz) find fuzz/seeds/lab -type f ;;
    gsi_fuzz) find tests/data/gsi -name '*.gsi' ;;
    geocom_fuzz) find fuzz/seeds/geocom -type f ;;
    robot_where_fuzz) find fuzz/seeds/robot -type f ;;
    emscon_fuzz) find fuzz/seeds/emscon -type f ;;
    ur_fuzz) find fuzz/seeds/ur -type f ;;
    rws_fuzz) find fuzz/seeds/rws -type f ;;
    urscript_fuzz) find tests/data/programs/urscript fuzz/seeds/programs -name '*.script' -o -name '*.urscript' ;;
    krl_fuzz) find tests/data/programs/krl fuzz/seeds/programs -name '*.src' -o -name '*.dat' ;;
    rapid_fuzz) find tests/data/programs/rapid fuzz/seeds/programs -name '*.mod' -o -name '*.sys' ;;
    kuka_fuzz) find fuzz/seeds/kuka controllers/kuka -type f ;;
  esac
  faults "$1"
}

if [[ "${1:-}" == "--check-seeds" ]]; then
  missing=0
  while read -r f; do
    found=0
    for t in "${targets[@]}"; do
      if faults "$t" | grep -qxF "$f"; then found=1; fi
    done
    if ((!found)); then
      echo "$f seeds no fuzz target (name it <prefix>-…; prefixes in scripts/fuzz.sh)" >&2
      missing=1
    fi
  done < <(find tests/data/faults -type f | sort)
  exit "$missing"
fi

seconds="${1:-20}"
scripts/setup.sh
# A tree that exists (scripts/test.sh builds it with the tests, to run them under the
# sanitizers) is used as configured; a new one gets the fuzzers only.
if [[ ! -f build-fuzz/CMakeCache.txt ]]; then
  CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DARMSIG_FUZZ=ON \
    -DARMSIG_BUILD_TESTS=OFF -DARMSIG_BUILD_BENCH=OFF >/dev/null
fi
cmake --build build-fuzz --target armsig_fuzzers --parallel "$(nproc)"

mkdir -p build-fuzz/crashes
# The targets' input files (readers that take a path) on tmpfs when there is one: rewriting
# a file on a disk busy with other writes (a build, a database test) can block in the
# kernel for milliseconds, which once cut poses_fuzz and observations_fuzz to 276 exec/s.
if [[ -d /dev/shm && -w /dev/shm ]]; then fuzz_dir="$(mktemp -d -p /dev/shm)"; else fuzz_dir="$(mktemp -d)"; fi
trap 'rm -rf "$fuzz_dir"' EXIT
export ARMSIG_FUZZ_DIR="$fuzz_dir"
# One target per core at a time: the same run per target, in half the wall time on two.
fuzz_one() {  # target → build-fuzz/<target>.log; exit status: 0, or 1 for a crash
  local name="$1" f
  local fuzzer="build-fuzz/fuzz/$name"
  local corpus="build-fuzz/corpus/$name" seed_dir="build-fuzz/seeds/$name"
  rm -rf "$seed_dir"
  mkdir -p "$corpus" "$seed_dir"
  # A seed longer than max_len is cut after its last whole line within max_len.
  seeds "$name" | while read -r f; do
    if (($(stat -c %s "$f") <= max_len)); then
      cp "$f" "$seed_dir/"
    else
      LC_ALL=C awk -v max="$max_len" '{ n += length($0) + 1; if (n > max) exit; print }' "$f" \
        >"$seed_dir/$(basename "$f")"
    fi
  done
  "$fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -max_len="$max_len" \
    -print_final_stats=1 -artifact_prefix="build-fuzz/crashes/$name-" "$corpus" "$seed_dir" \
    >"build-fuzz/$name.log" 2>&1
}
declare -A status
running=()
for name in "${targets[@]}"; do
  fuzz_one "$name" &
  running+=("$!:$name")
  if ((${#running[@]} >= $(nproc))); then
    entry="${running[0]}"
    running=("${running[@]:1}")
    if wait "${entry%%:*}"; then status[${entry#*:}]=0; else status[${entry#*:}]=1; fi
  fi
done
for entry in "${running[@]}"; do
  if wait "${entry%%:*}"; then status[${entry#*:}]=0; else status[${entry#*:}]=1; fi
done

failed=0 total=0
printf '%-20s %12s %10s %8s\n' target executions exec/s crashes
for name in "${targets[@]}"; do
  log="build-fuzz/$name.log"
  crashes="${status[$name]}"
  ((crashes)) && failed=1
  runs="$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)"
  rate="$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)"
  total=$((total + ${runs:-0}))
  printf '%-20s %12s %10s %8s\n' "$name" "${runs:-?}" "${rate:-?}" "$crashes"
  if ((crashes)); then
    echo "--- $name found a crash (log: $log):" >&2
    grep -E 'ERROR|SUMMARY|threw|Test unit written' "$log" | head -20 >&2
  fi
done
printf '%-20s %12s\n' total "$total"
exit "$failed"
