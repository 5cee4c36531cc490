#!/usr/bin/env python3
"""Held-out specimens predicted from a fit with an effect (issue #15: "the unloading branch
predicted from parameters fitted on loading cycles of other specimens").

    predict_heldout.py TWILL FIT_DIR [FIT_DIR ...] [--resolution 8x12]

A fit (run.py's `<effect>-<seed>-hidden-fit`) used one repeat per test; the other repeats are
specimens it never saw. Each is simulated with `twill simulate` from the fit's params.yaml
(its effects on) and with the same params without effects (the paper's model with the curves
the joint fit left), at the fit's resolution, and compared with its measured rows: the average
relative error Σ|p̂ − p̆| / Σ|p̆| (model.md §8) over the unloading rows (after the peak) and over
all rows. Prints one line per fit and the mean.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

import yaml


def rows(path):
    with open(path) as f:
        data = [(float(r["extension_mm"]), float(r["force_N"])) for r in csv.DictReader(f)]
    return [x for x, _ in data], [f for _, f in data]


def simulate(twill, params, angle, extensions, rate, resolution):
    out = subprocess.run([twill, "simulate", "--params", params, "--test", "tensile", "--angle-deg", str(angle),
                          "--extensions-mm", ",".join(f"{x:.6g}" for x in extensions), "--rate-mm-min", str(rate),
                          "--resolution", resolution], check=True, capture_output=True, text=True).stdout.splitlines()
    header = out[0].split(",")
    return [float(line.split(",")[header.index("force_N")]) for line in out[1:]]


def error(predicted, measured):
    return sum(abs(p - m) for p, m in zip(predicted, measured)) / sum(abs(m) for m in measured)


def scaled_error(predicted, measured):
    """error() after the run's own best scale s (argmin Σ|s p − m|: the weighted median of m/p
    with weights |p|): what is left when a specimen's 10-20 % scale (paper §6.4) is taken out,
    i.e. how well the curve's shape is predicted."""
    pairs = sorted((m / p, abs(p)) for p, m in zip(predicted, measured) if p != 0)
    half, below = 0.5 * sum(w for _, w in pairs), 0.0
    for ratio, w in pairs:
        below += w
        if below >= half:
            return error([ratio * p for p in predicted], measured)
    return error(predicted, measured)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("fits", nargs="+")
    parser.add_argument("--resolution", default="8x12")
    args = parser.parse_args()
    totals = []
    for fit in args.fits:
        with open(os.path.join(fit, "report.json")) as f:
            report = json.load(f)
        data = report["dataset_folder"]
        with open(os.path.join(data, "fabric.yaml")) as f:
            fabric = yaml.safe_load(f)
        with open(os.path.join(fit, "params.yaml")) as f:
            params = yaml.safe_load(f)
        used = {c["run"] for c in report["fit"]}
        with tempfile.TemporaryDirectory() as tmp:
            with_effect, without = os.path.join(tmp, "with.yaml"), os.path.join(tmp, "without.yaml")
            with open(with_effect, "w") as f:
                yaml.safe_dump(params, f, sort_keys=False)
            with open(without, "w") as f:
                yaml.safe_dump({k: v for k, v in params.items() if k != "effects"}, f, sort_keys=False)
            errors = {"unloading with": [], "unloading without": [], "all with": [], "all without": []}
            for test in fabric["tensile"]:
                for run in test["runs"]:
                    if os.path.splitext(os.path.basename(run))[0] in used:
                        continue
                    x, measured = rows(os.path.join(data, run))
                    peak = x.index(max(x))
                    for tag, p in (("with", with_effect), ("without", without)):
                        predicted = simulate(args.twill, p, test["angle_deg"], x, test.get("rate_mm_min", 300),
                                             args.resolution)
                        errors["unloading " + tag].append(error(predicted[peak + 1:], measured[peak + 1:]))
                        errors["all " + tag].append(error(predicted, measured))
        mean = {k: sum(v) / len(v) for k, v in errors.items()}
        totals.append(mean)
        print(f"{os.path.basename(fit)}: {len(errors['all with'])} held-out runs; unloading rows "
              f"{100 * mean['unloading with']:.2f} % with the effect, {100 * mean['unloading without']:.2f} % without; "
              f"all rows {100 * mean['all with']:.2f} % / {100 * mean['all without']:.2f} %")
    if len(totals) > 1:
        avg = {k: sum(t[k] for t in totals) / len(totals) for k in totals[0]}
        print(f"mean over {len(totals)} fits: unloading {100 * avg['unloading with']:.2f} % with, "
              f"{100 * avg['unloading without']:.2f} % without; all rows {100 * avg['all with']:.2f} % / "
              f"{100 * avg['all without']:.2f} %")


if __name__ == "__main__":
    sys.exit(main())
