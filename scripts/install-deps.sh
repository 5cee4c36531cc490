#!/usr/bin/env bash
# Installs twill's dependencies from Debian 12's packages. Idempotent: when every package is
# already installed it returns at once without touching apt.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libosd-dev libopenmesh-dev coinor-libipopt-dev libnlopt-cxx-dev libopenmpi-dev openmpi-bin
  libsuitesparse-dev libopenblas0-pthread libgtest-dev libyaml-cpp-dev libcli11-dev
  libspdlog-dev libfmt-dev libtbb-dev libsqlite3-dev nlohmann-json3-dev
  python3 python3-matplotlib python3-numpy python3-yaml
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

echo "install-deps: installing ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root or sudo to install: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -q
$SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
