#!/usr/bin/env bash
# Builds the libFuzzer targets (fuzz/) with clang into build-fuzz/ and runs each for
# SECONDS (default 20; CI uses 20, a real campaign hours: scripts/fuzz.sh 3600). Seeds:
# fuzz/seeds and the real files in tests/data. New inputs that reach new code go to
# build-fuzz/corpus/<target>; a crash is kept as build-fuzz/crashes/<target>-… and makes
# this script fail (turn it into a regression test under tests/data/faults/).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-20}"
scripts/setup.sh
# A tree that exists (scripts/test.sh builds it with the tests, to run them under the
# sanitizers) is used as configured; a new one gets the fuzzers only.
if [[ ! -f build-fuzz/CMakeCache.txt ]]; then
  CXX=clang++ cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DARMSIG_FUZZ=ON \
    -DARMSIG_BUILD_TESTS=OFF -DARMSIG_BUILD_BENCH=OFF >/dev/null
fi
cmake --build build-fuzz --target armsig_fuzzers --parallel "$(nproc)"

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
  esac
  if [[ -d "tests/data/faults/${1%_fuzz}" ]]; then find "tests/data/faults/${1%_fuzz}" -type f; fi
}

mkdir -p build-fuzz/crashes
fuzz_dir="$(mktemp -d)"  # the targets' input files (readers that take a path)
trap 'rm -rf "$fuzz_dir"' EXIT
export ARMSIG_FUZZ_DIR="$fuzz_dir"
failed=0 total=0
printf '%-20s %12s %10s %8s\n' target executions exec/s crashes
for fuzzer in build-fuzz/fuzz/*_fuzz; do
  name="$(basename "$fuzzer")"
  corpus="build-fuzz/corpus/$name" seed_dir="build-fuzz/seeds/$name"
  mkdir -p "$corpus" "$seed_dir"
  seeds "$name" | while read -r f; do cp "$f" "$seed_dir/"; done
  log="build-fuzz/$name.log"
  if "$fuzzer" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix="build-fuzz/crashes/$name-" "$corpus" "$seed_dir" >"$log" 2>&1; then
    crashes=0
  else
    crashes=1 failed=1
  fi
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
