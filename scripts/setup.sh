#!/usr/bin/env bash
# Installs what armsig needs from Debian 12's packages. Checks first, so a second
# run costs nothing. Run as root or with sudo available.
set -euo pipefail

PACKAGES=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libceres-dev
  libboost-dev libboost-system-dev
  libsqlite3-dev sqlite3 libsqlitecpp-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev
  libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  chromium  # report rendering test (headless)
  dpkg-dev file groff-base  # the .deb (cpack, dpkg-shlibdeps) and the manual page check
  clang  # libFuzzer targets (fuzz/)
  libpq-dev postgresql  # the PostgreSQL backend; the tests start a server of their own
)

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]} == 0)); then
  exit 0
fi

echo "armsig setup: installing ${missing[*]}" >&2
SUDO=""
if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
