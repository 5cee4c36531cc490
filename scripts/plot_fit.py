#!/usr/bin/env python3
"""Draw the figures of a `twill fit` report, after the paper's Figs. 2-4.

Usage: plot_fit.py REPORT.json OUTDIR

Writes into OUTDIR:
  fig2_force_elongation.png  measured vs fitted force-elongation per fitted curve, full range
                             (top row) and the small-strain zoom (first 25 % of the extension,
                             bottom row)
  fig3_error_vs_degree.png   average relative error vs curve degree per stage and resolution
                             (the degree progression of paper section 5.4)
  fig4_validation_error.png  relative error vs elongation of the validation strips (with the
                             fitted angle offset)
Exit status 3 means matplotlib cannot be imported (twill turns that into a clear message).
"""
import argparse
import json
import os
import sys

from plot_common import pyplot_or_exit



def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("report", help="report.json written by twill fit")
    parser.add_argument("outdir", help="folder for the PNG files")
    args = parser.parse_args()
    plt = pyplot_or_exit("plot_fit.py")

    with open(args.report, encoding="utf-8") as f:
        report = json.load(f)
    name = report.get("dataset", "")

    # Fig. 2: measured vs fitted, full range and small-strain zoom.
    fits = report.get("fit", [])
    if fits:
        fig, axes = plt.subplots(2, len(fits), figsize=(4 * len(fits), 7), squeeze=False)
        for col, c in enumerate(fits):
            x, m, s = c["extension_mm"], c["measured_N"], c["simulated_N"]
            for row in range(2):
                ax = axes[row][col]
                ax.plot(x, m, "o", ms=3, label="measured")
                ax.plot(x, s, "-", label="fitted")
                if row == 1:
                    limit = x[0] + 0.25 * (x[-1] - x[0])
                    ax.set_xlim(0, limit)
                    visible = [v for xi, v in zip(x, m + s) if xi <= limit] or m
                    ax.set_ylim(0, 1.1 * max(max(m[: len(visible)] or [1]), max(s[: len(visible)] or [1])))
                    ax.set_title("small strain", fontsize=9)
                else:
                    ax.set_title(f"{c['label']} {c['run']} (deg {c['degree']}, "
                                 f"{100 * c['avg_rel_error']:.2f} %)", fontsize=9)
                ax.set_xlabel("elongation [mm]")
                ax.set_ylabel("force [N]")
                ax.legend(fontsize=7)
        fig.suptitle(f"{name}: measured vs fitted (paper Fig. 2)")
        fig.tight_layout()
        fig.savefig(os.path.join(args.outdir, "fig2_force_elongation.png"), dpi=110)
        plt.close(fig)

    # Fig. 3: error vs degree, per stage and resolution.
    stages = [s for s in report.get("stages", []) if s.get("degree", 0) > 0]
    fig, ax = plt.subplots(figsize=(5, 4))
    groups = {}
    for s in stages:
        groups.setdefault((s["stage"], s["resolution"]), []).append((s["degree"], 100 * s["avg_rel_error"]))
    for (stage, res), points in sorted(groups.items()):
        points.sort()
        ax.plot([p[0] for p in points], [p[1] for p in points], "o-", label=f"{stage} {res}")
    ax.set_xlabel("curve degree")
    ax.set_ylabel("average relative error [%]")
    ax.set_xticks(sorted({s["degree"] for s in stages}) or [1])
    ax.set_title(f"{name}: error vs degree (paper Fig. 3)")
    if groups:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(args.outdir, "fig3_error_vs_degree.png"), dpi=110)
    plt.close(fig)

    # Fig. 4: validation relative error vs elongation.
    fig, ax = plt.subplots(figsize=(5, 4))
    for c in report.get("validation", []):
        rel = [100 * (s - m) / m for s, m in zip(c["simulated_N"], c["measured_N"])]
        ax.plot(c["extension_mm"], rel, "-",
                label=f"{c['label']} {c['run']} (dθ {c['delta_theta_deg']:+.1f}°)")
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("elongation [mm]")
    ax.set_ylabel("relative error [%]")
    ax.set_title(f"{name}: validation (paper Fig. 4)")
    if report.get("validation"):
        ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(os.path.join(args.outdir, "fig4_validation_error.png"), dpi=110)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
