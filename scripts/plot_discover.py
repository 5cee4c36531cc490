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
before only. With the load cell's noise law the repeats show (discover.json's repeat_noise), a
band of ±2 sd of a reading along the first run's loading rows, on the same scale: the rows a
residual leaves it at are beyond the noise (docs/discovery.md §2).
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


# The band's half-width in standard deviations of a reading: 95 % of a row's noise lies within it.
BAND_SD = 2.0


def noise_band(noise, run):
    """The first run's loading rows (up to its largest extension) and ±BAND_SD sd of a reading
    there in % of its largest force; None without a law."""
    if not noise or not run["extension_mm"]:
        return None
    top = max(range(len(run["extension_mm"])), key=lambda i: run["extension_mm"][i])
    largest = max(abs(m) for m in run["measured_N"]) or 1.0
    w, level, median = noise["absolute_weight"], noise["level"], noise["median_N"]
    x = run["extension_mm"][:top + 1]
    half = [100 * BAND_SD * level * ((1 - w) * abs(f) + w * median) / largest for f in run["without_N"][:top + 1]]
    return x, half


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
        band = noise_band(discover.get("repeat_noise"), runs[0]) if runs else None
        if band:
            x, half = band
            ax.fill_between(x, [-h for h in half], half, color="tab:blue", alpha=0.15, lw=0,
                            label=f"±{BAND_SD:g} sd of the load cell's noise")
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
