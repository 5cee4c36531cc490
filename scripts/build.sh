#!/usr/bin/env bash
# Configures and builds twill (Release) in ./build (or $TWILL_BUILD_DIR).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${TWILL_BUILD_DIR:-$root/build}"
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
if [ ! -f "$build/CMakeCache.txt" ]; then
  cmake -S "$root" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release
else
  cmake -S "$root" -B "$build" >/dev/null
fi
cmake --build "$build" -j "$(nproc)"
