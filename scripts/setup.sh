#!/usr/bin/env bash
# Installs what armsig needs from Debian 12's packages (with --tests: what its test suite
# needs too). Checks first, so a second run costs nothing. Run as root or with sudo available.
set -euo pipefail

# What the program needs to build and run (scripts/demo.sh).
PACKAGES=(
  build-essential clang lld cmake ninja-build pkg-config
  libeigen3-dev libceres-dev
  libboost-dev libboost-system-dev
  libsqlite3-dev sqlite3 libsqlitecpp-dev
  libopencv-core-dev libopencv-imgproc-dev libpng-dev
  libopencv-imgcodecs-dev  # the tests read figures back; armsig itself writes PNGs with libpng
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev
  libspdlog-dev libfmt-dev
  libpq-dev  # the PostgreSQL backend
  libssl-dev  # TLS for Robot Web Services 2.0 (ABB OmniCore) and the digests of RWS 1.0
)
# What the test suite needs besides (scripts/setup.sh --tests, from scripts/test.sh).
if [[ "${1:-}" == "--tests" ]]; then
  PACKAGES+=(
    libgtest-dev libgmock-dev libbenchmark-dev
    chromium  # report rendering test (headless)
    dpkg-dev file groff-base  # the .deb (cpack, dpkg-shlibdeps) and the manual page check
    postgresql  # the tests start a server of their own
  )
fi

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
