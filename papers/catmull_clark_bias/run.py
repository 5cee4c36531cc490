#!/usr/bin/env python3
"""Convergence of the Catmull-Clark KL tensile strip against the independent references.

For each (material, angle, fibre_strain, resolution) it runs `twill simulate --test tensile`
at the reference's extensions (CSV cached in OUTDIR, so a rerun only adds what is missing) and
prints, per curve, the worst relative force error over reference points above 1 N and the
error at the last point; with three resolutions of one curve it adds the observed order
log2(|f1 - f2| / |f2 - f3|) at the last point and the Richardson limit with that order and with
orders 1 and 2 (docs/catmull_clark_kl.md section 12 discusses the result).

usage: run.py TWILL SHARED_DIR OUTDIR [--materials canvas,poplin] [--labels bias,...]
              [--resolutions 16x24,32x48] [--fibre-strain pointwise,face-mean]
"""
import argparse
import csv
import math
import os
import subprocess
import sys

ANGLES = {"warp": 90.0, "weft": 0.0, "bias": 45.0, "a22.5": 22.5, "a67.5": 67.5}


def read_curve(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return ([float(r["extension_mm"]) for r in rows], [float(r["force_N"]) for r in rows],
            [float(r["lateral_strain"]) for r in rows])


def simulate(twill, shared, outdir, material, label, resolution, fibre_strain):
    out = os.path.join(outdir, f"{material}-{label}-{fibre_strain}-{resolution}.csv")
    if os.path.exists(out):
        return out
    ref = os.path.join(shared, "data", "reference", material)
    extensions, _, _ = read_curve(os.path.join(ref, f"tensile-{label}.csv"))
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    subprocess.run([twill, "simulate", "--params", os.path.join(ref, "params.yaml"), "--test",
                    "tensile", "--angle-deg", str(ANGLES[label]), "--extensions-mm",
                    ",".join(f"{e:g}" for e in extensions), "--resolution", resolution,
                    "--option", f"fibre_strain={fibre_strain}", "--option", "threads=1",
                    "--out", out + ".tmp"], check=True, env=env)
    os.replace(out + ".tmp", out)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("shared")
    parser.add_argument("outdir")
    parser.add_argument("--materials", default="canvas,poplin")
    parser.add_argument("--labels", default="warp,weft,bias,a22.5,a67.5")
    parser.add_argument("--resolutions", default="32x48")
    parser.add_argument("--fibre-strain", default="pointwise,face-mean")
    args = parser.parse_args()
    os.makedirs(args.outdir, exist_ok=True)
    resolutions = args.resolutions.split(",")
    print("| material | angle | fibre strain | " + " | ".join(
        f"{r} worst / last" for r in resolutions) + " | order (last) | limit p_obs / p=1 / p=2 |")
    print("|---" * (4 + len(resolutions) + 1) + "|")
    for material in args.materials.split(","):
        for label in args.labels.split(","):
            _, ref, _ = read_curve(os.path.join(args.shared, "data", "reference", material,
                                                f"tensile-{label}.csv"))
            for fibre in args.fibre_strain.split(","):
                cells, last = [], []
                for r in resolutions:
                    _, f, _ = read_curve(simulate(args.twill, args.shared, args.outdir, material,
                                                  label, r, fibre))
                    errors = [(f[i] - ref[i]) / ref[i] for i in range(len(ref)) if ref[i] > 1.0]
                    worst = max(errors, key=abs)
                    cells.append(f"{100 * worst:+.2f} % / {100 * errors[-1]:+.2f} %")
                    last.append(f[-1])
                extra = " | |"
                if len(last) == 3 and (last[0] - last[1]) * (last[1] - last[2]) > 0:
                    d1, d2 = last[0] - last[1], last[1] - last[2]
                    p = math.log2(d1 / d2)
                    lim = lambda q: 100 * ((last[2] - d2 / (2 ** q - 1)) / ref[-1] - 1)
                    extra = f" | {p:.2f} | {lim(p):+.2f} / {lim(1):+.2f} / {lim(2):+.2f} % |"
                print(f"| {material} | {ANGLES[label]:g} | {fibre} | " + " | ".join(cells) + extra)
                sys.stdout.flush()


if __name__ == "__main__":
    main()
