#!/usr/bin/env python3
"""Optimiser comparison on the parameter-recovery problem (issue #5; fitting/recovery_study.hpp).

For each test (warp: a11 + eta1; bias: G12 + eta4), each true curve degree (1, 2, 3) and each
registered optimiser, runs `twill recover --json` and writes a Markdown table with iterations,
objective evaluations, equilibrium solves, wall time, the stiffness error and the curve error.

Usage: run.py TWILL_BINARY PARAMS.yaml OUTPUT.md [--resolution 4x6] [--optimizers bfgs,...]

PARAMS.yaml is the base material (the study uses ../shared/data/reference/canvas/params.yaml).
Run with OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 on an otherwise idle machine for timings.
"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import twill_cli  # noqa: E402  (scripts/twill_cli.py: what the binary is asked)


def registered_names(twill: str, category: str) -> str:
    """The registered names of a category, comma-separated (`twill list --names`)."""
    return ",".join(twill_cli.registered_names(twill, category))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("twill")
    parser.add_argument("params")
    parser.add_argument("output")
    parser.add_argument("--resolution", default="4x6")
    parser.add_argument("--optimizers", default=None,
                        help="comma-separated names (default: every registered optimiser, `twill list --names optimizer`)")
    parser.add_argument("--budget", default="max_iterations=300,max_evaluations=600",
                        help="optimiser options applied to every run (comma separated)")
    args = parser.parse_args()
    if args.optimizers is None:
        args.optimizers = registered_names(args.twill, "optimizer")

    rows = []
    for test in ("warp", "bias"):
        for degree in (1, 2, 3):
            for optimizer in args.optimizers.split(","):
                cmd = [args.twill, "recover", "--params", args.params, "--test", test,
                       "--degree", str(degree), "--optimizer", optimizer,
                       "--resolution", args.resolution, "--json"]
                for setting in args.budget.split(","):
                    cmd += ["--set", setting]
                out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
                r = json.loads(out.strip().splitlines()[-1])
                rows.append(r)
                print(f"{test} deg {degree} {optimizer}: {r['status']}, {r['iterations']} its, "
                      f"{r['wall_time_s']:.2f} s, stiffness {r['stiffness_error']:+.1e}, "
                      f"curve {r['curve_error']:.1e}", file=sys.stderr)

    with open(args.output, "w", encoding="utf-8") as f:
        f.write(f"Parameter recovery at {args.resolution} (`{' '.join(sys.argv)}`)\n\n")
        f.write("| test | degree | optimiser | status | iterations | evaluations | solves | "
                "time | stiffness error | curve error |\n|---|---|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            f.write(f"| {r['test']} | {r['degree']} | {r['optimizer']} | {r['status']} | "
                    f"{r['iterations']} | {r['evaluations']} | {r['equilibrium_solves']} | "
                    f"{r['wall_time_s']:.2f} s | {r['stiffness_error']:+.1e} | {r['curve_error']:.1e} |\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
