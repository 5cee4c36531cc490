#!/usr/bin/env python3
"""Plot the tables of `twill report`: one figure per table, a line per group column.

Usage: plot_report.py TABLES.json OUTDIR

TABLES.json: {"tables": [{"file": str, "metric": str, "x_key": str, "x": [str],
              "numeric_x": bool, "series": [{"label": str, "y": [float | null]}]}]}
Each table goes to OUTDIR/<file>. Numeric x is drawn to scale (log scale when it spans more
than a decade and is positive), other x as evenly spaced categories in the table's order;
y on a log scale when every value is positive and they span more than two decades.
Exit status 3 means matplotlib cannot be imported (twill turns that into a clear message).
"""
import argparse
import json
import os
import sys

from plot_common import pyplot_or_exit

# Spans (max/min) above which an axis is drawn on a log scale.
X_LOG_SPAN = 10.0
Y_LOG_SPAN = 100.0
# Above this many lines the legend goes beside the axes (inside it hides the lines) and the
# lines cycle through markers as well as colours (matplotlib's default cycle has 10 colours).
LEGEND_INSIDE_MAX = 6
MARKERS = "os^vDP*Xh<>"


def log_scale(values, span):
    values = [v for v in values if v is not None]
    return bool(values) and min(values) > 0 and max(values) / min(values) > span


def plot_table(plt, table, path):
    many = len(table["series"]) > LEGEND_INSIDE_MAX
    fig, ax = plt.subplots(figsize=(9.6 if many else 6.4, 4.2))
    if table["numeric_x"]:
        x = [float(v) for v in table["x"]]
        if log_scale(x, X_LOG_SPAN):
            ax.set_xscale("log")
    else:
        x = list(range(len(table["x"])))
        ax.set_xticks(x)
        ax.set_xticklabels(table["x"], rotation=30 if len(table["x"]) > 4 else 0, ha="right" if len(table["x"]) > 4 else "center")
    every_y = []
    for i, series in enumerate(table["series"]):
        points = [(xi, yi) for xi, yi in zip(x, series["y"]) if yi is not None]
        if not points:
            continue
        every_y += [p[1] for p in points]
        ax.plot([p[0] for p in points], [p[1] for p in points], marker=MARKERS[(i // 10) % len(MARKERS)],
                label=series["label"])
    if log_scale(every_y, Y_LOG_SPAN):
        ax.set_yscale("log")
    ax.set_xlabel(table["x_key"])
    ax.set_ylabel(table["metric"])
    ax.set_title(f"{table['metric']} against {table['x_key']}", fontsize=10)
    ax.grid(True, alpha=0.3)
    if len(table["series"]) > 1 or table["series"][0]["label"] != "all":
        if many:
            ax.legend(fontsize=6, loc="center left", bbox_to_anchor=(1.01, 0.5))
        else:
            ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tables", help="JSON file written by twill report")
    parser.add_argument("outdir", help="folder for the figures")
    args = parser.parse_args()
    plt = pyplot_or_exit("plot_report.py")
    with open(args.tables, encoding="utf-8") as f:
        tables = json.load(f)["tables"]
    for table in tables:
        plot_table(plt, table, os.path.join(args.outdir, table["file"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
