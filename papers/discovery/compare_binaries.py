#!/usr/bin/env python3
"""Whether another twill binary reads the rates table's datasets as the table's binary did
(papers/discovery/README.md: the table is run by one frozen binary; code changed after it is
checked on a sample of its datasets with this script).

    compare_binaries.py TWILL OUT GROUP_OUT TAG ... [--set KEY=VALUE ...] [-o TABLE.md]

For each TAG (a dataset of rates.py: OUT_GROUP/<tag> holds its data, OUT_GROUP/<tag>-discover its
discover.json from the table's binary) TWILL runs `twill discover` into OUT/<tag> (skipped when
OUT/<tag>/discover.json exists) with the group's --set overrides, and the two discover.json are
compared: the verdict, the named effects and, per candidate, its status, its error without and
with it, its calibrated p and its held-out error with it. Prints (and with -o writes) a markdown
table with a line per dataset: `same`, or what differs.
"""
import argparse
import json
import os
import subprocess
import time

from rates import table_cell  # noqa: E402  (papers/discovery/rates.py, beside this file)

# What a candidate's comparison reads from discover.json.
CANDIDATE_KEYS = ("status", "error_without", "error_with", "p_value")


def candidate_view(c):
    view = {k: c.get(k) for k in CANDIDATE_KEYS}
    view["held_out_with"] = (c.get("held_out") or {}).get("error_with")
    return view


def differences(table, other):
    """What differs between two discover.json, in words (empty: the same)."""
    found = []
    for key in ("verdict", "named"):
        if table[key] != other[key]:
            found.append(f"{key} {table[key]} → {other[key]}")
    theirs = {c["name"]: candidate_view(c) for c in other["candidates"]}
    for c in table["candidates"]:
        mine, got = candidate_view(c), theirs.get(c["name"])
        if got is None:
            found.append(f"{c['name']} missing")
            continue
        changed = [f"{k} {mine[k]:.6g} → {got[k]:.6g}" if isinstance(mine[k], float) and isinstance(got[k], float)
                   else f"{k} {mine[k]} → {got[k]}" for k in mine if mine[k] != got[k]]
        if changed:
            found.append(f"{c['name']}: " + ", ".join(changed))
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill", help="the binary to compare with the table's")
    parser.add_argument("out", help="where its discovers go (OUT/<tag>)")
    parser.add_argument("group_out", help="the table's group folder (rates.py's OUT/<group>)")
    parser.add_argument("tags", nargs="+")
    parser.add_argument("--set", nargs="*", default=[], dest="overrides", help="the group's overrides")
    parser.add_argument("-o", "--table", help="also write the markdown table here")
    args = parser.parse_args()
    lines = ["| dataset | the table's verdict | this binary | time (table's, this) |", "|---|---|---|---|"]
    for tag in args.tags:
        frozen = os.path.join(args.group_out, tag + "-discover", "discover.json")
        if not os.path.exists(frozen):
            raise SystemExit(f"{frozen}: no discover.json of the table's binary")
        result = os.path.join(args.out, tag)
        seconds = None
        if not os.path.exists(os.path.join(result, "discover.json")):
            cmd = [args.twill, "discover", os.path.join(args.group_out, tag), "-o", result, "--quiet", "--no-plots",
                   "--force"]
            for o in args.overrides:
                cmd += ["--set", o]
            start = time.time()
            subprocess.run(cmd, check=True)
            seconds = time.time() - start
        with open(frozen) as f:
            table = json.load(f)
        with open(os.path.join(result, "discover.json")) as f:
            other = json.load(f)
        found = differences(table, other)
        took = other.get("time_s", seconds or 0.0)
        lines.append(f"| {tag} | {table_cell(table['verdict'])} | {table_cell('; '.join(found) or 'same')} | "
                     f"{table.get('time_s', 0):.0f} s, {took:.0f} s |")
        print(lines[-1], flush=True)
    if args.table:
        with open(args.table, "w") as f:
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
