#!/usr/bin/env bash
# Configures and builds twill in BUILD_DIR (default ./build, or $TWILL_BUILD_DIR) as BUILD_TYPE
# (default Release; scripts/test-sanitize.sh uses Sanitize). The type is fixed when the folder
# is first configured.
# Usage: scripts/build.sh [BUILD_DIR [BUILD_TYPE]]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-${TWILL_BUILD_DIR:-$root/build}}"
type="${2:-Release}"
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE="$type"
else
  cmake -S "$root" -B "$build" >/dev/null
fi
cmake --build "$build" -j "$(nproc)"
