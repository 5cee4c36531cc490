#!/usr/bin/env python3
"""Draw the residuals of a `twill discover` run before and after the named effects.

Usage: plot_discover.py OUTDIR

Reads OUTDIR/discover.json and writes OUTDIR/residuals.png: per test, the residual
(simulated - measured) of every run over the rows the gap was measured on (for a path effect
loading then unloading, so a loop shows as a loop), in % of the run's largest measured force
(per point the relative residual blows up where an unloading branch nears zero force), against
the extension, before
(grey: the paper's model) and after (colour: with the named effects); the title carries the
test's gap (average relative errors before, after and the noise floor). When nothing is named,
before only.
Exit status 3 means matplotlib cannot be imported (twill turns that into a clear message).
"""
import argparse
import json
import os

from plot_common import pyplot_or_exit


def relative(values, measured):
    """Residuals in % of the run's largest |measured| force."""
    largest = max((abs(m) for m in measured), default=0) or 1.0
    return [100 * (v - m) / largest for v, m in zip(values, measured)]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("outdir", help="the folder twill discover writes")
    args = parser.parse_args()
    plt = pyplot_or_exit("plot_discover.py")

    with open(os.path.join(args.outdir, "discover.json"), encoding="utf-8") as f:
        discover = json.load(f)
    curves = discover.get("curves", [])
    named = discover.get("named", [])
    tests = sorted({c["test"] for c in curves})
    fig, axes = plt.subplots(1, max(len(tests), 1), figsize=(4 * max(len(tests), 1), 3.6), squeeze=False)
    for ax, test in zip(axes[0], tests):
        gap = discover.get("gap", {}).get(test) or {}
        runs = [c for c in curves if c["test"] == test]
        for k, c in enumerate(runs):
            ax.plot(c["extension_mm"], relative(c["without_N"], c["measured_N"]), color="0.55", lw=1,
                    label="paper's model" if k == 0 else None)
        if named:
            for k, c in enumerate(runs):
                ax.plot(c["extension_mm"], relative(c["with_N"], c["measured_N"]), lw=1.2,
                        label="with " + ", ".join(named) if k == 0 else None)
        ax.axhline(0, color="k", lw=0.5)
        # The gap's errors are averages relative to the measured forces, another scale than the
        # axis': they go in the title rather than as a band.
        words = [f"{k} {100 * gap[k]:.2f} %" for k in ("before", "after", "floor") if gap.get(k) is not None]
        ax.set_title(test + ("\n" + ", ".join(words) if words else ""), fontsize=9)
        ax.set_xlabel("extension [mm]")
        ax.set_ylabel("residual [% of the run's largest force]")
        ax.legend(fontsize=7)
    fig.suptitle(f"{discover.get('dataset', '')}: {discover.get('verdict', '')}", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(args.outdir, "residuals.png"), dpi=110)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
