#!/usr/bin/env python3
"""The cost of each effect on a tensile curve (issue #15, "measured, not asserted").

    scripts/bench_effects.py TWILL [--params P.yaml] [--resolution 16x24] [--repeat 3]

Times `twill simulate` of one bias strip (45°, 24 points: loading to 12 mm and back to 1 mm,
at 300 mm/min) with the params as given (no effect) and with each registered effect that
changes predictions on at a typical amplitude, interleaved (none, e1, e2, …, none, e1, …) so
that a noisy shared machine affects all alike; prints the best wall time of each and its ratio
to no effect. The process's whole run is timed (mesh, solves, hooks, output): what a user
waits for.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_PARAMS = os.path.join(ROOT, "..", "shared", "data", "reference", "poplin", "params.yaml")
# A typical amplitude of each effect (docs/effects/*.md): a few % of a strip's force.
TYPICAL = {
    "hysteresis": {"warp_friction_N_m": 150, "weft_friction_N_m": 100, "shear_friction_N_m": 20,
                   "saturation_strain": 0.01},
    "rate-dependence": {"viscous_ratio": 0.1, "relaxation_s": 10},
    "poisson": {"coupling_ratio": 0.3},
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("--params", default=DEFAULT_PARAMS)
    parser.add_argument("--resolution", default="16x24")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    with open(args.params) as f:
        base = yaml.safe_load(f)
    base.pop("effects", None)
    schedule = [0.5 * i for i in range(1, 25)] + [0.5 * i for i in range(23, 1, -1)]
    extensions = ",".join(f"{x:g}" for x in schedule)
    with tempfile.TemporaryDirectory() as tmp:
        variants = {"none": base}
        for name, values in TYPICAL.items():
            variants[name] = dict(base, effects={name: values})
        paths = {}
        for name, params in variants.items():
            paths[name] = os.path.join(tmp, name + ".yaml")
            with open(paths[name], "w") as f:
                yaml.safe_dump(params, f, sort_keys=False)
        best = {name: float("inf") for name in variants}
        for _ in range(args.repeat):
            for name, path in paths.items():
                start = time.perf_counter()
                subprocess.run([args.twill, "simulate", "--params", path, "--test", "tensile", "--angle-deg", "45",
                                "--extensions-mm", extensions, "--rate-mm-min", "300", "--resolution", args.resolution],
                               check=True, capture_output=True)
                best[name] = min(best[name], time.perf_counter() - start)
    print(f"bias strip {args.resolution}, {len(schedule)} points (up to 12 mm and back), best of {args.repeat}:")
    for name, t in best.items():
        print(f"  {name:16s} {t:7.3f} s  x{t / best['none']:.3f}")


if __name__ == "__main__":
    sys.exit(main())
