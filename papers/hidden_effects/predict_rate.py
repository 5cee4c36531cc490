#!/usr/bin/env python3
"""One rate predicted from a fit on the other (issue #15: "rate dependence: one rate predicted
from a fit on the other").

    predict_rate.py TWILL OUTDIR [--seeds 1 2 3] [--fit-rate 300] [--resolution 8x12]
                    [--set KEY=VALUE ...]

For each seed: the rate-dependence spec's dataset with the effect hidden and its twin without
(synthesize.py, as run.py makes them; reused when OUTDIR has them), cut to the tests at
--fit-rate (loading and unloading), each fitted by `twill fit --set 'effects=[rate-dependence]'
--set resolution.levels=1` and any --set given (e.g. `repeats.rule=all repeats.scale=per-run`:
every specimen at the fit rate, each with its own scale). Every run at the other rate — specimens the fit never saw, at a
speed it never saw — is then simulated from the fit's params.yaml with its effects (at that
run's rate) and without them, and compared with its measured rows (average relative error,
model.md §8), as it is and after each run's own best scale (scaled_error: the specimen's 10–20 %
scale taken out, so what is left is the curve's shape, where a rate effect shows). The twin's
prediction without effects is the floor: what another specimen at another speed costs when
speed does not matter. Writes OUTDIR/rate-transfer.json and .md.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import yaml

from predict_heldout import error, rows, scaled_error, simulate
from run import HERE, fit_command, run, twin_spec, write_summary


def dataset(twill, out, seed, hidden):
    """The seed's generated dataset (hidden effect or twin), made when missing."""
    tag = f"rate-dependence-{seed}-{'hidden' if hidden else 'none'}"
    data = os.path.join(out, tag)
    if not os.path.exists(os.path.join(data, "fabric.yaml")):
        spec = os.path.join(out, tag + ".spec.yaml")
        twin_spec(os.path.join(HERE, "rate-dependence.yaml"), spec, hidden)
        if not run([sys.executable, os.path.join(HERE, "synthesize.py"), spec, "-o", data, "--twill", twill,
                    "--seed", str(seed)], data + ".log"):
            return None
    return data


def subset(data, rate, target):
    """A copy of `data` with only the tensile tests at `rate` mm/min."""
    with open(os.path.join(data, "fabric.yaml")) as f:
        fabric = yaml.safe_load(f)
    fabric["tensile"] = [t for t in fabric["tensile"] if t.get("rate_mm_min") == rate]
    shutil.rmtree(target, ignore_errors=True)
    os.makedirs(os.path.join(target, "tensile"))
    for test in fabric["tensile"]:
        for r in test["runs"]:
            shutil.copy(os.path.join(data, r), os.path.join(target, r))
    with open(os.path.join(target, "fabric.yaml"), "w") as f:
        yaml.safe_dump(fabric, f, sort_keys=False)


def predict(twill, data, fit, rate, resolution):
    """Mean error over every run of `data` not at `rate`, with and without the fit's effects."""
    with open(os.path.join(data, "fabric.yaml")) as f:
        fabric = yaml.safe_load(f)
    with open(os.path.join(fit, "params.yaml")) as f:
        params = yaml.safe_load(f)
    errors = {"with": [], "without": [], "with, scaled": [], "without, scaled": []}
    with tempfile.TemporaryDirectory() as tmp:
        files = {"with": os.path.join(tmp, "with.yaml"), "without": os.path.join(tmp, "without.yaml")}
        with open(files["with"], "w") as f:
            yaml.safe_dump(params, f, sort_keys=False)
        with open(files["without"], "w") as f:
            yaml.safe_dump({k: v for k, v in params.items() if k != "effects"}, f, sort_keys=False)
        for test in fabric["tensile"]:
            if test.get("rate_mm_min") == rate:
                continue
            for r in test["runs"]:
                x, measured = rows(os.path.join(data, r))
                for tag, path in files.items():
                    predicted = simulate(twill, path, test["angle_deg"], x, test["rate_mm_min"], resolution)
                    errors[tag].append(error(predicted, measured))
                    errors[tag + ", scaled"].append(scaled_error(predicted, measured))
    return {k: sum(v) / len(v) for k, v in errors.items()}, len(errors["with"])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("out")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    parser.add_argument("--fit-rate", type=float, default=300)
    parser.add_argument("--resolution", default="8x12")
    parser.add_argument("--set", nargs="*", default=[], dest="overrides", help="more `twill fit --set` overrides")
    args = parser.parse_args()
    twill = os.path.abspath(args.twill)
    os.makedirs(args.out, exist_ok=True)
    results = []
    for seed in args.seeds:
        row = {"seed": seed, "fit_rate_mm_min": args.fit_rate}
        for hidden in (True, False):
            data = dataset(twill, args.out, seed, hidden)
            if data is None:
                continue
            cut = f"{data}-at-{args.fit_rate:g}"
            fit = cut + "-fit"
            if not os.path.exists(os.path.join(fit, "report.json")):
                subset(data, args.fit_rate, cut)
                cmd = fit_command(twill, cut, fit, "[rate-dependence]", ["resolution.levels=1"] + args.overrides)
                if not run(cmd, fit + ".log"):
                    continue
            with open(os.path.join(fit, "report.json")) as f:
                effect = json.load(f)["effects"][0]
            mean, n = predict(twill, data, fit, args.fit_rate, args.resolution)
            key = "hidden" if hidden else "twin"
            row[key] = {"predicted_runs": n, "with": mean["with"], "without": mean["without"],
                        "with_scaled": mean["with, scaled"], "without_scaled": mean["without, scaled"],
                        "fit_error_with": effect["error_with"],
                        "parameters": {p["name"]: p["value"] for p in effect["parameters"]}}
        results.append(row)
        print(json.dumps(row), flush=True)
    def line(r):
        pct = lambda d, k: f"{100 * r[d][k]:.2f} %" if d in r else "—"
        fitted = ", ".join(f"{k.split('.')[-1]} {v:.3g}" for k, v in r.get("hidden", {}).get("parameters", {}).items())
        return [r["seed"], pct("hidden", "with"), pct("hidden", "without"), pct("twin", "without"),
                pct("hidden", "with_scaled"), pct("hidden", "without_scaled"), pct("twin", "without_scaled"), fitted]

    write_summary(os.path.join(args.out, "rate-transfer"), results,
                  ["seed", "other rate, with the effect", "without", "floor (twin, without)",
                   "each run scaled: with", "without", "floor", "fitted"], line)

if __name__ == "__main__":
    sys.exit(main())
