#!/bin/bash
# The transfer study (papers/transfer/README.md): fit the bundled canvas example on each
# discretisation, then evaluate each fit's parameters on the other discretisations and
# resolutions (study.yaml). From the repository root:
#
#   papers/transfer/run.sh [build/app/twill]
#
# Outputs: out/transfer/fit-<discretisation>/ (the two fits), out/transfer/sweep/ (the
# evaluations, results.sqlite) and out/transfer/sweep/report/report.md. Re-running skips what is
# done (a fit whose params.yaml exists; the sweep's done runs).
set -euo pipefail
twill=${1:-build/app/twill}
fit() {  # fit NAME [--set ...]
  local out=out/transfer/fit-$1
  shift
  [ -f "$out/params.yaml" ] || "$twill" fit examples/canvas -o "$out" --quiet --no-plots "$@"
}
fit catmull-clark
fit triangle --set discretization.name=triangle-shell
"$twill" sweep papers/transfer/study.yaml -o out/transfer/sweep --quiet
"$twill" report out/transfer/sweep --quiet
