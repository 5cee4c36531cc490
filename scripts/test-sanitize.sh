#!/usr/bin/env bash
# The sanitiser job (CI runs it after scripts/test.sh): builds the tests and the `twill` program
# with AddressSanitizer + UBSan at -O1, asserts compiled in (build type Sanitize, CMakeLists.txt)
# in ./build-sanitize (or $TWILL_SANITIZE_BUILD_DIR), then runs the fast part of the suite: every
# test without the label `slow` or `timing` (tests/CMakeLists.txt says which and why).
# Extra arguments go to ctest, e.g. `-R FitCommand`.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${TWILL_SANITIZE_BUILD_DIR:-$root/build-sanitize}"
"$root/scripts/build.sh" "$build" Sanitize

# Any report fails the test: halt at the first error, with a stack trace, under an exit status
# (23) that no twill command uses, so a test expecting status 1 or 2 cannot mistake it. Leaks are
# checked too (LeakSanitizer at exit): OpenBLAS, OpenMP, CHOLMOD, Ipopt and TBB reported nothing,
# so no suppressions are needed; a third-party report would get a suppressions file with a reason
# per entry, never one for twill's own code. Extra *_OPTIONS from the caller come last and win.
export ASAN_OPTIONS="halt_on_error=1:exitcode=23:detect_leaks=1:print_stacktrace=1:strict_string_checks=1:detect_stack_use_after_return=1:check_initialization_order=1${ASAN_OPTIONS:+:$ASAN_OPTIONS}"
export UBSAN_OPTIONS="halt_on_error=1:exitcode=23:print_stacktrace=1${UBSAN_OPTIONS:+:$UBSAN_OPTIONS}"
cd "$build"
ctest --output-on-failure -j "$(nproc)" --timeout 1200 -LE "^(slow|timing)$" "$@"
