#!/usr/bin/env python3
"""Plot force-extension curves that `twill` wrote as JSON: one panel per test, runs overlaid.

Usage: plot_curves.py CURVES.json OUTPUT.(png|svg|pdf)

CURVES.json: {"title": str, "panels": [{"title": str, "xlabel": str, "ylabel": str,
              "curves": [{"label": str, "x": [float], "y": [float], "highlight": bool}]}]}
Rows are drawn in file order, so an unloading branch shows as the curve coming back down.
Exit status 3 means matplotlib cannot be imported (twill turns that into a clear message).
"""
import argparse
import json
import math
import sys

from plot_common import pyplot_or_exit



def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("curves", help="JSON file written by twill")
    parser.add_argument("output", help="image to write (.png, .svg or .pdf)")
    args = parser.parse_args()

    plt = pyplot_or_exit("plot_curves.py")

    with open(args.curves, encoding="utf-8") as f:
        data = json.load(f)
    panels = data["panels"]
    if not panels:
        print("plot_curves.py: no panels to plot", file=sys.stderr)
        return 1

    columns = min(3, len(panels))
    rows = math.ceil(len(panels) / columns)
    fig, axes = plt.subplots(rows, columns, figsize=(5.0 * columns, 3.8 * rows), squeeze=False)
    for ax, panel in zip(axes.flat, panels):
        for curve in panel["curves"]:
            highlight = curve.get("highlight", False)
            ax.plot(curve["x"], curve["y"], marker=".", markersize=3,
                    linewidth=2.4 if highlight else 1.0, alpha=1.0 if highlight else 0.75,
                    label=curve["label"] + (" (fit)" if highlight else ""))
        ax.set_title(panel["title"])
        ax.set_xlabel(panel["xlabel"])
        ax.set_ylabel(panel["ylabel"])
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    for ax in list(axes.flat)[len(panels):]:
        ax.set_visible(False)
    fig.suptitle(data.get("title", ""))
    fig.tight_layout()
    fig.savefig(args.output, dpi=120)
    return 0


if __name__ == "__main__":
    sys.exit(main())
