#!/usr/bin/env python3
"""Triangle-shell cantilever against the Catmull-Clark shell (issue #4, acceptance: the 41.5 deg
overhang within 3 % of Catmull-Clark for the same parameters).

Runs `twill simulate --test bend --angle-deg 90 --find-overhang --json` for every parameter file x
configuration x resolution and writes `cantilever.md`: the overhang [mm], its relative difference
to Catmull-Clark at the same resolution and at the finest one, and the wall time of the overhang
search. Configurations: Catmull-Clark; the triangle shell with the shape-operator bending (default)
per mesh pattern, with clamp hinges at the platform edge and with the default clamp (first cell
column held); the two hinge models for comparison. Paths come from the arguments; see README.md.
"""
import argparse
import json
import os
import subprocess
import sys

CONFIGS = [
    # (label, discretization, options)
    ("Catmull-Clark", "catmull-clark-kl", []),
    ("shape-operator, alternating, clamp hinges", "triangle-shell", ["clamp_hinges=start"]),
    ("shape-operator, alternating, first column held", "triangle-shell", []),
    ("shape-operator, right, clamp hinges", "triangle-shell", ["pattern=right", "clamp_hinges=start"]),
    ("shape-operator, cross, clamp hinges", "triangle-shell", ["pattern=cross", "clamp_hinges=start"]),
    ("shape-operator, irregular, clamp hinges", "triangle-shell", ["pattern=irregular", "clamp_hinges=start"]),
    ("hinges (directional), alternating, clamp hinges", "triangle-shell",
     ["hinge_model=directional", "clamp_hinges=start"]),
    ("hinges (cylinders), alternating, clamp hinges", "triangle-shell",
     ["hinge_model=cylinders", "clamp_hinges=start"]),
]


def overhang(twill, params, discretization, options, resolution, env):
    cmd = [twill, "simulate", "--params", params, "--test", "bend", "--angle-deg", "90",
           "--find-overhang", "--json", "--discretization", discretization, "--resolution", resolution]
    for o in options + (["threads=1"] if discretization == "triangle-shell" else []):
        cmd += ["--option", o]
    run = subprocess.run(cmd, capture_output=True, text=True, env=env)
    try:
        j = json.loads(run.stdout)
    except json.JSONDecodeError:
        return {"overhang_mm": float("nan"), "wall_time_s": float("nan"), "converged": False}
    return j


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--twill", required=True, help="path of the twill program")
    ap.add_argument("--params", required=True, nargs="+", help="params.yaml files (label = file stem or folder name)")
    ap.add_argument("--out", required=True, help="output folder (cantilever.md, cantilever.json)")
    ap.add_argument("--resolutions", default="4x32,4x64,8x64,8x128,16x128")
    ap.add_argument("--configs", default="", help="comma-separated indices into the configuration list (default: all)")
    args = ap.parse_args()
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    os.makedirs(args.out, exist_ok=True)
    resolutions = args.resolutions.split(",")
    configs = [CONFIGS[int(i)] for i in args.configs.split(",")] if args.configs else CONFIGS
    results = {}
    lines = []
    for params in args.params:
        stem = os.path.splitext(os.path.basename(params))[0]
        name = os.path.basename(os.path.dirname(params)) if stem == "params" else stem
        lines += [f"### {name}", "",
                  "| configuration | " + " | ".join(resolutions) + " |",
                  "|---" * (len(resolutions) + 1) + "|"]
        reference = {}
        for label, discretization, options in configs:
            cells = []
            for r in resolutions:
                j = overhang(args.twill, params, discretization, options, r, env)
                results[f"{name} | {label} | {r}"] = j
                L = j["overhang_mm"]
                if discretization == "catmull-clark-kl":
                    reference[r] = L
                    cells.append(f"{L:.2f} ({j['wall_time_s']:.1f} s)")
                else:
                    d = f", {100 * (L / reference[r] - 1):+.2f} %" if r in reference else ""
                    stopped = "" if j.get("converged", False) else " (not converged)"
                    cells.append(f"{L:.2f}{d} ({j['wall_time_s']:.1f} s){stopped}")
                print(f"{name} | {label} | {r}: {cells[-1]}", flush=True)
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
        lines.append("")
    lines.append("Overhang [mm] at a 41.5 deg chord angle, angle 90 (warp along the strip), 25 mm wide; "
                 "in brackets the relative difference to Catmull-Clark at the same resolution and the "
                 "wall time of the overhang search (one thread).")
    with open(os.path.join(args.out, "cantilever.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(args.out, "cantilever.json"), "w") as f:
        json.dump(results, f, indent=1)


if __name__ == "__main__":
    sys.exit(main())
