#!/usr/bin/env bash
# Measurement script for docs/extending.md, not part of CI (nothing runs it automatically).
#
# Applies the worked examples docs/extending/examples/<kind>.patch (discretization, optimizer,
# experiment, effect, stage) one at a time to a temporary worktree of COMMIT (default HEAD), printing
# what each adds (`git status --short` and `git diff --stat`); then builds once, prints
# `twill list --names <category>` and runs the registry-driven tests filtered to the new parts.
# The worktree and its build are removed at the end. JOBS (default 2) build jobs; the tests
# read TWILL_SHARED_DIR (default: the shared/ folder beside this checkout).
# Usage: scripts/check_extending.sh [COMMIT]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
commit="${1:-HEAD}"
kinds=(discretization optimizer experiment effect stage)
scratch="$(mktemp -d "${TMPDIR:-/tmp}/twill-extending.XXXXXX")"
src="$scratch/src"
build="$scratch/build"
cleanup() {
  git -C "$root" worktree remove --force "$src" 2>/dev/null || true
  rm -rf "$scratch"
}
trap cleanup EXIT

git -C "$root" worktree add --detach --quiet "$src" "$commit"
git_src() { git -C "$src" -c user.name=check_extending -c user.email=check_extending@localhost "$@"; }
for kind in "${kinds[@]}"; do
  echo "==== $kind: git apply docs/extending/examples/$kind.patch"
  git_src apply "$root/docs/extending/examples/$kind.patch"
  echo "\$ git status --short"
  git_src status --short
  git_src add --all
  echo "\$ git diff --stat=120"
  git_src diff --cached --stat=120
  echo "\$ git diff -U0 app/program_registry.cpp | grep '^+ '"
  git_src diff --cached -U0 -- app/program_registry.cpp | grep '^+ '
  git_src commit --quiet -m "worked example: $kind"
done

echo "==== build (Release, $build)"
generator=()
command -v ninja >/dev/null && generator=(-G Ninja)
# The tests read ../shared beside the checkout; the temporary worktree has none beside it.
shared="${TWILL_SHARED_DIR:-$(cd "$root/.." && pwd)/shared}"
cmake -S "$src" -B "$build" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release -DTWILL_SHARED_DIR="$shared" >/dev/null
cmake --build "$build" -j "${JOBS:-2}" --target twill twill_discretizations_tests twill_optimizers_tests \
  twill_experiments_tests twill_effects_tests twill_fitting_tests >/dev/null

for kind in "${kinds[@]}"; do
  echo "\$ twill list --names $kind"
  "$build/app/twill" list --names "$kind"
done

# The registry-driven tests: every registered discretisation, experiment and effect makes cases
# of its own (run here filtered to the new names); the optimiser tests loop over every
# registered optimiser inside each test, so they run whole (the lbfgs rows of the matrix shown).
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1
new_parts='*triangle_shell_cross*:*tensile_per_width*:*weft_skew*:*joint_refit*'
status=0
run() {  # test binary, gtest filter
  echo "\$ tests/$(basename "$1") --gtest_filter='$2'"
  local log="$scratch/$(basename "$1").log"
  "$1" "--gtest_filter=$2" >"$log" 2>&1 || status=1
  grep -E '^\[  (PASSED|FAILED|SKIPPED) |^\| lbfgs |^\[measured\]' "$log" || true
}
run "$build/tests/twill_discretizations_tests" "$new_parts"
run "$build/tests/twill_experiments_tests" "$new_parts"
run "$build/tests/twill_effects_tests" "$new_parts"
run "$build/tests/twill_fitting_tests" "$new_parts"
run "$build/tests/twill_optimizers_tests" 'OptimizerMatrix.*:Failures.*:OptimizerRegistry.*'
exit "$status"
