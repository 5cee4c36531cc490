#!/usr/bin/env python3
"""Draw the residuals of a `twill discover` run before and after the named effects.

Usage: plot_discover.py OUTDIR

Reads OUTDIR/baseline-report.json (the paper's model, every repeat with its specimen scale)
and, when present, OUTDIR/refit-report.json (the model with the named effects), and writes
OUTDIR/residuals.png: per fitted test, the relative residual (simulated - measured) / measured
of every fit run against the extension, before (grey) and after (colour), with the noise floor
of discover.json as a band.
Exit status 3 means matplotlib cannot be imported (twill turns that into a clear message).
"""
import argparse
import json
import os

from plot_common import pyplot_or_exit


def residuals_by_test(report):
    """{test label: [(run, extensions, relative residuals)]} of the report's fit curves."""
    out = {}
    for c in report.get("fit", []):
        pairs = [(e, (s - m) / m) for e, m, s in zip(c["extension_mm"], c["measured_N"], c["simulated_N"]) if m != 0]
        out.setdefault(c["label"], []).append((c["run"], [p[0] for p in pairs], [p[1] for p in pairs]))
    return out


def load(path):
    if not os.path.exists(path):
        return None
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", help="the folder twill discover writes")
    args = parser.parse_args()
    plt = pyplot_or_exit("plot_discover.py")

    discover = load(os.path.join(args.outdir, "discover.json")) or {}
    before = residuals_by_test(load(os.path.join(args.outdir, "baseline-report.json")) or {})
    refit = load(os.path.join(args.outdir, "refit-report.json"))
    after = residuals_by_test(refit) if refit else {}
    tests = sorted(before)
    fig, axes = plt.subplots(1, max(len(tests), 1), figsize=(4 * max(len(tests), 1), 3.6), squeeze=False)
    for ax, test in zip(axes[0], tests):
        floor = (discover.get("gap", {}).get(test) or {}).get("floor")
        if floor:
            ax.axhspan(-100 * floor, 100 * floor, color="0.9", label="noise floor")
        for k, (run, e, r) in enumerate(before[test]):
            ax.plot(e, [100 * x for x in r], color="0.55", lw=1, label="paper's model" if k == 0 else None)
        for k, (run, e, r) in enumerate(after.get(test, [])):
            ax.plot(e, [100 * x for x in r], lw=1.2, label="with " + ", ".join(discover.get("named", [])) if k == 0 else None)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(test)
        ax.set_xlabel("extension [mm]")
        ax.set_ylabel("relative residual [%]")
        ax.legend(fontsize=7)
    fig.suptitle(f"{discover.get('dataset', '')}: {discover.get('verdict', '')}", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(args.outdir, "residuals.png"), dpi=110)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
