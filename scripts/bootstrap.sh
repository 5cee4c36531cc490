#!/usr/bin/env bash
# README command 1: dependencies, Release build, and the main job on the bundled example.
set -euo pipefail
# Small sparse systems: one BLAS/OpenMP thread is fastest (threads oversubscribe 2 cores).
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-1}" OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/scripts/install-deps.sh"
"$root/scripts/build.sh"
build="${TWILL_BUILD_DIR:-$root/build}"
mkdir -p "$root/out"
"$build/app/twill" inspect "$root/examples/canvas" --plot "$root/out/canvas-raw-curves.png"
# The main job: the paper's fitting protocol on the bundled example (README: "Fitting").
# Extra arguments go to twill fit, e.g. `scripts/bootstrap.sh --quiet --set resolution.levels=2`.
"$build/app/twill" fit "$root/examples/canvas" -o "$root/out/fit-canvas" "$@"
echo "bootstrap: done; raw curves in out/canvas-raw-curves.png, the fit in out/fit-canvas/ (report.md, params.yaml)"
