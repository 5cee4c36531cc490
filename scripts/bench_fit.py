#!/usr/bin/env python3
"""Time `twill fit` of one dataset with several binaries back to back (the fit benchmark).

Usage: bench_fit.py DATASET OUTDIR BINARY [BINARY ...] [--repeat N] [--set KEY=VALUE ...]
                    [--variant-set KEY=VALUE ...]

Runs `BINARY fit DATASET -o OUTDIR/<i>-<name> --quiet` for each binary in turn (N rounds,
alternating, so that a change of the machine's load hits every binary alike), with one BLAS
and OpenMP thread as bootstrap.sh does, and prints per binary: wall time, CPU time and peak
memory of the process (from wait4), the load average before the run, and the fit's own
per-stage timings (report.json `timing_s`). With --variant-set, each binary also runs with
those overrides added (e.g. `--variant-set 'effects=[hysteresis]'`: the cost of an effect on
a fit, with and without it back to back). Machines here are shared: compare binaries of
one run, not figures of different days. Binaries that predate a stage's timing key show '-'.
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import time


def run_once(binary, dataset, outdir, sets):
    if os.path.exists(outdir):
        shutil.rmtree(outdir)
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    command = [binary, "fit", dataset, "-o", outdir, "--quiet"]
    for s in sets:
        command += ["--set", s]
    load = os.getloadavg()[0]
    start = time.monotonic()
    process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    wall = time.monotonic() - start
    stderr = process.stderr.read().decode(errors="replace")
    process.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{binary}: twill fit failed (exit {os.waitstatus_to_exitcode(status)}):\n{stderr}")
    with open(os.path.join(outdir, "report.json"), encoding="utf-8") as f:
        report = json.load(f)
    return {
        "load": load,
        "wall_s": wall,
        "cpu_s": usage.ru_utime + usage.ru_stime,
        "peak_mb": usage.ru_maxrss / 1024.0,
        "stages": report.get("timing_s", {}),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset")
    parser.add_argument("outdir")
    parser.add_argument("binaries", nargs="+")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--set", action="append", default=[], dest="sets")
    parser.add_argument("--variant-set", action="append", default=[], dest="variant_sets")
    args = parser.parse_args()
    for b in args.binaries:
        if not (os.path.isfile(b) and os.access(b, os.X_OK)):
            raise SystemExit(f"{b}: not an executable file")
    os.makedirs(args.outdir, exist_ok=True)
    # A variant: (binary, its extra overrides, its column).
    variants = []
    for i, b in enumerate(args.binaries):
        variants.append((b, [], f"{i}: {os.path.basename(b)}"))
        if args.variant_sets:
            variants.append((b, args.variant_sets, f"{i}: {os.path.basename(b)} + {' '.join(args.variant_sets)}"))
    results = [[] for _ in variants]
    for round_index in range(args.repeat):
        for v, (b, extra, column) in enumerate(variants):
            r = run_once(b, args.dataset, os.path.join(args.outdir, f"{v}-{os.path.basename(b)}"), args.sets + extra)
            results[v].append(r)
            print(f"round {round_index + 1}: {column}: {r['wall_s']:.1f} s wall (load {r['load']:.2f})", file=sys.stderr)
    columns = [column for _, _, column in variants]
    best = [min(rs, key=lambda r: r["wall_s"]) for rs in results]
    print("| | " + " | ".join(columns) + " |")
    print("|---|" + "---|" * len(columns))
    for key, fmt in [("wall_s", "{:.1f} s"), ("cpu_s", "{:.1f} s"), ("peak_mb", "{:.0f} MB"), ("load", "{:.2f}")]:
        label = {"wall_s": "wall (best of rounds)", "cpu_s": "CPU (user + sys)", "peak_mb": "peak RSS",
                 "load": "load average before"}[key]
        print(f"| {label} | " + " | ".join(fmt.format(b[key]) for b in best) + " |")
    stages = []
    for b in best:
        for k in b["stages"]:
            if k not in stages and k != "total":
                stages.append(k)
    for k in stages + ["total"]:
        cells = [f"{b['stages'][k]:.1f}" if k in b["stages"] else "-" for b in best]
        print(f"| {k} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
