#!/usr/bin/env python3
"""How often `twill discover` names the right effect (issue #16): for each effect of the library,
scatter level and seed, a dataset with the effect hidden by the generator's own law
(papers/hidden_effects/synthesize.py, the effect's spec there) and its twin with no effect (the
same specimens, offsets and noise: the null data, with the same observables, so that every
candidate the hidden dataset can test is testable on the twin too), each given to
`twill discover`.

    rates.py TWILL OUTDIR [--effects SPEC ...] [--seeds 1 2 3 4 5] [--scatter 0.10 0.20]
             [--speeds MM_MIN ...] [--repeats N] [--set KEY=VALUE ...] [--no-twins | --no-hidden] [--table-only]
             [--record DIR]
    rates.py TWILL OUTDIR --groups papers/discovery/table.yaml [--table-only] [--record DIR]

--groups runs each group of a groups file (the whole table of papers/discovery/README.md is
table.yaml: the one-speed effects and the loop effects at two speeds, at both scatter levels)
into OUTDIR/<group name> with the group's own settings, and writes the combined table to
OUTDIR/rates.md and rates.json, and every group's counts in one table to OUTDIR/rates-summary.md
(the README's).

--effects names specs of papers/hidden_effects: an effect (its spec), EFFECT-VARIANT (e.g.
misalignment-validation: validation strips beside the fit tests), or a mechanism outside the
library (yarn-damage; the right verdict there is `unexplained`, a name is a false one). Default:
every registered effect (`twill list --names effect`).

--speeds runs every test of the spec at these crosshead speeds (default: the spec's own). The
hysteresis spec tests at one speed, where a friction loop and a Maxwell loop look alike and the
honest verdict is `tied: hysteresis|rate-dependence (needs: two speeds)`; `--speeds 300 30` gives
the data that separate them. --repeats sets the specimens per test and speed (default: the spec's).

A run whose OUTDIR/<tag>-discover/discover.json exists is not repeated: the study resumes where
it stopped. --record DIR keeps each dataset's row as DIR/<tag>.json (with --groups,
DIR/<group name>/<tag>.json) the moment it is known, and a dataset whose row is recorded there is
not run again: a study in a scratch OUTDIR survives the loss of the machine when DIR is in the
repository (papers/discovery/runs-0118c33). Writes OUTDIR/rates.json (a row per dataset) and
OUTDIR/rates.md (the rates table, then a line per dataset), both rewritten after every run.

Per dataset the row holds the verdict, the named effects, every candidate's status, and for the
hidden effect its gap (error before/after/floor over its effect-fit rows: the excess over the
floor must shrink threefold) and its held-out errors. Counted per (effect, scatter):
  named     the hidden effect is among the named;
  false     another effect is named (on a twin: anything named);
  tied      the verdict is a tie;
  untestable  the hidden effect was untestable (the data lack its observables: a spec error);
  unexplained the verdict is `unexplained at ...`;
  failed    nothing named and the hidden effect's fit or held-out check failed (its reason says);
  none      nothing named, no tie, no misfit.
"""
import argparse
import json
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
SPECS = os.path.join(HERE, "..", "hidden_effects")
sys.path.insert(0, SPECS)
sys.path.insert(0, os.path.join(HERE, "..", "..", "scripts"))
from run import twin_spec  # noqa: E402  (the hidden-effects study's spec writer)
import twill_cli  # noqa: E402  (scripts/twill_cli.py: the registry's names)

import yaml  # noqa: E402

# Mechanisms the generator hides that are in no effect of twill's library (synthesize.py): the
# right verdict on them is `unexplained at ...`; a name is a false one. The library's effects are
# the registry's (`twill list --names effect`).
OUTSIDE_THE_LIBRARY = ["yarn-damage"]
DEFAULT_SET = ["resolution.levels=1"]  # 8x12 fits of 16x24 data, as papers/hidden_effects


def run(cmd, log):
    with open(log, "w") as f:
        return subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode == 0


def spec_path(spec):
    """The hidden-effects study's spec (papers/hidden_effects/SPEC.yaml, SPEC an effect or EFFECT-VARIANT)."""
    return os.path.join(SPECS, f"{spec}.yaml")


def effect_of(spec, names):
    """The effect a spec hides: the longest of `names` the spec's name is or starts with (EFFECT-VARIANT)."""
    matches = [n for n in names if spec == n or spec.startswith(n + "-")]
    return max(matches, key=len) if matches else None


def spec_for(spec_name, scatter, hidden, path, speeds=None, repeats=None):
    twin_spec(spec_path(spec_name), path, hidden)
    with open(path) as f:
        spec = yaml.safe_load(f)
    spec["scatter"] = scatter
    for test in spec["tests"]:
        if speeds:
            test["rates_mm_min"] = list(speeds)
        if repeats:
            test["repeats"] = repeats
    with open(path, "w") as f:
        yaml.safe_dump(spec, f, sort_keys=False)


# How discover's reason states the excess over the floors that must shrink threefold
# (fitting/discovery_judge.cpp, judge_one), before → after, in points.
EXCESS = re.compile(r"excess over each test's floor ([0-9.]+) → ([0-9.]+) points")


def row_of(spec, effect, scatter, seed, hidden, result, seconds):
    candidates = {c["name"]: c for c in result["candidates"]}
    mine = candidates.get(effect, {})
    row = {"spec": spec, "effect": effect, "scatter": scatter, "seed": seed, "hidden": hidden, "verdict": result["verdict"],
           "named": result["named"], "statuses": {n: c["status"] for n, c in candidates.items()},
           "seconds": seconds}
    if "error_without" in mine:
        row["candidate"] = {k: mine.get(k) for k in ("error_without", "error_with", "p_value", "held_out")}
        row["candidate"]["parameters"] = {p["name"]: p["value"] for p in mine.get("parameters", [])}
        excess = EXCESS.search(mine.get("reason", ""))
        if excess:  # the judge's test-by-test excess over the floors (docs/discovery.md §1), in points
            row["candidate"]["excess"] = [float(excess.group(1)), float(excess.group(2))]
    row["gap"] = result["gap"]
    return row


def classify(row):
    if row["verdict"].startswith("tied"):
        return "tied"
    if row["verdict"].startswith("unexplained"):
        return "unexplained"
    if row["hidden"] and row["statuses"].get(row["effect"]) == "untestable":
        return "untestable"
    if row["hidden"] and row["statuses"].get(row["effect"]) == "failed" and not row["named"]:
        return "failed"
    if row["hidden"] and row["effect"] in row["named"]:
        return "named" if len(row["named"]) == 1 else "named+false"
    return "false" if row["named"] else "none"


def table_cell(text):
    """`text` inside a markdown table cell: a tie's `A|B` escaped."""
    return text.replace("|", "\\|")


KINDS = ["named", "named+false", "false", "tied", "untestable", "unexplained", "failed", "none"]


def count_lines(rows, group=None):
    """The rates table of `rows`: a line per (spec, scatter, hidden or twin) with the count of each
    kind (classify); with `group`, its name in a first column (the summary over groups)."""
    counted = {}
    for r in rows:
        if not r.get("same_data_as"):  # counted once, under the twin that ran
            counted.setdefault((r.get("spec", r["effect"]), r["scatter"], r["hidden"]), []).append(classify(r))
    first, rule = ("| group ", "|---") if group is not None else ("", "")
    lines = [first + "| spec (hidden effect) | data | scatter | datasets | " + " | ".join(KINDS) + " |",
             rule + "|---|---|---|---|" + "---|" * len(KINDS)]
    for (effect, scatter, hidden), got in sorted(counted.items()):
        lines.append((f"| {group} " if group is not None else "") +
                     f"| {effect} | {'hidden' if hidden else 'twin (none)'} | {scatter:g} | {len(got)} | " +
                     " | ".join(str(got.count(k)) for k in KINDS) + " |")
    return lines


def write_tables(out, rows):
    with open(os.path.join(out, "rates.json"), "w") as f:
        json.dump(rows, f, indent=1)
    lines = count_lines(rows)
    lines += ["", "| spec (hidden effect) | data | scatter | seed | verdict | named | its error without → with (p) | "
              "its excess over the floors [points] | held-out without → with | time |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        c = r.get("candidate", {})
        pct = lambda v: f"{100 * v:.2f} %" if isinstance(v, (int, float)) else "—"
        held = c.get("held_out") or {}
        p = c.get("p_value")
        lines.append(f"| {r.get('spec', r['effect'])} | {'hidden' if r['hidden'] else 'twin'} | {r['scatter']:g} | {r['seed']} | "
                     f"{table_cell(r['verdict'])}"
                     f"{' (the same data as ' + r['same_data_as'] + ')' if r.get('same_data_as') else ''} | "
                     f"{', '.join(r['named']) or '—'} | "
                     f"{pct(c.get('error_without'))} → {pct(c.get('error_with'))} ({'—' if p is None else f'{p:.2g}'}) | "
                     f"{'{:.2f} → {:.2f}'.format(*c['excess']) if c.get('excess') else '—'} | "
                     f"{pct(held.get('error_without'))} → {pct(held.get('error_with'))} | {r['seconds']:.0f} s |")
    with open(os.path.join(out, "rates.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def check_effects(effects, library, where):
    """The specs `effects` name, or a message saying which do not (an effect or a spec file)."""
    unknown = [e for e in effects if not effect_of(e, library + OUTSIDE_THE_LIBRARY)]
    if unknown:
        return (f"{where}: {', '.join(unknown)} names no registered effect ({', '.join(library)}) "
                f"nor one outside the library ({', '.join(OUTSIDE_THE_LIBRARY)})")
    missing = [spec_path(e) for e in effects if not os.path.exists(spec_path(e))]
    return f"{where}: no spec {', '.join(missing)}" if missing else None


def check_datasets(group, where):
    """A message when the group runs neither hidden datasets nor twins, else None."""
    return None if group["twins"] or group["hidden"] else f"{where}: neither hidden datasets nor twins: nothing to run"


def run_group(twill, out, group, library, table_only, record=None):
    """One group's datasets (generated, then discovered, unless their discover.json exists or their
    row is in `record`); its rows, and OUT/rates.json and rates.md rewritten after every run.
    `group`: the keys of GROUP_KEYS."""
    os.makedirs(out, exist_ok=True)
    if record:
        os.makedirs(record, exist_ok=True)
    rows = []
    twins = {}  # a twin's data (twin_key) -> (its tag, its discover.json): two specs' twins can be the same data
    for scatter in group["scatter"]:
        for seed in group["seeds"]:
            for spec_name in group["effects"]:
                effect = effect_of(spec_name, library + OUTSIDE_THE_LIBRARY)
                for hidden in [h for h, wanted in ((True, group["hidden"]), (False, group["twins"])) if wanted]:
                    tag = tag_of(spec_name, scatter, seed, hidden)
                    row = recorded_row(record, tag)
                    if not row:
                        row = run_dataset(twill, out, group, spec_name, effect, scatter, seed, hidden, table_only, twins)
                        keep_row(record, row)
                    if row:
                        rows.append(row)
                        write_tables(out, rows)
    write_tables(out, rows)
    return rows


def tag_of(spec_name, scatter, seed, hidden):
    """A dataset's name in OUT and in the record."""
    return f"{spec_name}-s{scatter:g}-{seed}-{'hidden' if hidden else 'twin'}"


def recorded_row(record, tag):
    """The row `record` keeps for the dataset `tag`, or None."""
    path = os.path.join(record, tag + ".json") if record else None
    if not path or not os.path.exists(path):
        return None
    with open(path) as f:
        row = json.load(f)
    print(f"{tag}: recorded in {path}: {row['verdict']}", flush=True)
    return row


def keep_row(record, row):
    """Writes `row` into `record` (whole or not at all: through a temporary file)."""
    if not record or not row:
        return
    path = os.path.join(record, row["tag"] + ".json")
    with open(path + ".tmp", "w") as f:
        json.dump(row, f, indent=1)
    os.replace(path + ".tmp", path)


def twin_key(spec_path, seed):
    """What a twin's data depend on: its spec without the name, and the seed. The loop effects'
    specs at the same speeds and repeats differ only in their effect and name, so their twins are
    the same specimens, offsets and noise (papers/discovery/README.md, session 32)."""
    with open(spec_path) as f:
        spec = yaml.safe_load(f)
    spec.pop("name", None)
    return json.dumps(spec, sort_keys=True) + f" seed {seed}"


def run_dataset(twill, out, group, spec_name, effect, scatter, seed, hidden, table_only, twins):
    """One dataset's row (None when it has not run and `table_only`, or when it failed). A twin
    whose data an earlier twin of the group has (`twins`, by twin_key) is not run again: its row is
    that twin's, marked `same_data_as`, and counted once."""
    tag = tag_of(spec_name, scatter, seed, hidden)
    data, result = os.path.join(out, tag), os.path.join(out, tag + "-discover")
    done = os.path.join(result, "discover.json")
    spec = os.path.join(out, tag + ".spec.yaml")
    key = None
    if not hidden:
        spec_for(spec_name, scatter, hidden, spec, group["speeds"], group["repeats"])
        key = twin_key(spec, seed)
        if key in twins and (os.path.exists(done) or os.path.exists(twins[key][1])):
            earlier_tag, earlier_done = twins[key]
            with open(done if os.path.exists(done) else earlier_done) as f:
                r = json.load(f)
            row = row_of(spec_name, effect, scatter, seed, hidden, r, 0.0)
            row.update(tag=tag, same_data_as=earlier_tag)
            print(f"{tag}: the same data as {earlier_tag}: {row['verdict']}", flush=True)
            return row
    seconds = 0.0
    if not os.path.exists(done):
        if table_only:
            return None
        spec_for(spec_name, scatter, hidden, spec, group["speeds"], group["repeats"])
        if not run([sys.executable, os.path.join(SPECS, "synthesize.py"), spec, "-o", data, "--twill", twill,
                    "--seed", str(seed)], data + ".log"):
            print(f"{tag}: generator failed, see {data}.log", flush=True)
            return None
        cmd = [twill, "discover", data, "-o", result, "--quiet", "--no-plots", "--force"]
        for o in group["overrides"]:
            cmd += ["--set", o]
        t = time.time()
        if not run(cmd, result + ".log"):
            print(f"{tag}: discover failed, see {result}.log", flush=True)
            return None
        seconds = time.time() - t
    with open(done) as f:
        r = json.load(f)
    row = row_of(spec_name, effect, scatter, seed, hidden, r, seconds or r.get("time_s", 0.0))
    row["tag"] = tag
    if key is not None:
        twins[key] = (tag, done)
    print(f"{tag}: {row['verdict']} named {row['named']} ({row['seconds']:.0f} s)", flush=True)
    return row


# A group's keys and their defaults (the command line's, and a groups file's entries').
GROUP_KEYS = {"effects": None, "seeds": [1, 2, 3, 4, 5], "scatter": [0.10, 0.20], "speeds": None, "repeats": None,
              "overrides": DEFAULT_SET, "twins": True, "hidden": True}


def read_groups(path, library):
    """The groups of a groups file (papers/discovery/table.yaml): a list of {name, and GROUP_KEYS}."""
    with open(path) as f:
        entries = yaml.safe_load(f)
    if not isinstance(entries, list) or not entries:
        raise SystemExit(f"{path}: expected a list of groups")
    groups = []
    for i, entry in enumerate(entries):
        where = f"{path}: group {i + 1}"
        if not isinstance(entry, dict) or "name" not in entry:
            raise SystemExit(f"{where}: expected a mapping with a name")
        unknown = sorted(set(entry) - set(GROUP_KEYS) - {"name", "data"})
        if unknown:
            raise SystemExit(f"{where} ({entry['name']}): unknown key {', '.join(unknown)} "
                             f"(known: name, data, {', '.join(GROUP_KEYS)})")
        group = dict(GROUP_KEYS)
        group.update(entry)
        group["effects"] = group["effects"] or library
        message = check_effects(group["effects"], library, f"{where} ({entry['name']}) effects") or \
            check_datasets(group, f"{where} ({entry['name']})")
        if message:
            raise SystemExit(message)
        groups.append(group)
    return groups


def write_combined(out, groups_rows):
    """OUT/rates.md: each group's counts under its name and data, then every group's rows."""
    lines = ["# The rates of `twill discover` over its groups (papers/discovery/rates.py --groups)", ""]
    for group, rows in groups_rows:
        lines += [f"## {group['name']}", "", group.get("data", ""), "",
                  f"`rates.py TWILL OUT/{group['name']}` with {describe(group)}", ""]
        with open(os.path.join(out, group["name"], "rates.md")) as f:
            lines.append(f.read())
    with open(os.path.join(out, "rates.md"), "w") as f:
        f.write("\n".join(lines))
    with open(os.path.join(out, "rates.json"), "w") as f:
        json.dump({g["name"]: rows for g, rows in groups_rows}, f, indent=1)
    summary = ["# The rates of `twill discover`, every group's counts in one table (papers/discovery/rates.py --groups)",
               ""] + count_lines([], group="")[:2]
    for group, rows in groups_rows:
        summary += count_lines(rows, group=group["name"])[2:]
    with open(os.path.join(out, "rates-summary.md"), "w") as f:
        f.write("\n".join(summary) + "\n")


def describe(group):
    """A group's settings as rates.py's options."""
    parts = [f"--effects {' '.join(group['effects'])}", f"--seeds {' '.join(map(str, group['seeds']))}",
             f"--scatter {' '.join(f'{s:g}' for s in group['scatter'])}"]
    if group["speeds"]:
        parts.append(f"--speeds {' '.join(f'{v:g}' for v in group['speeds'])}")
    if group["repeats"]:
        parts.append(f"--repeats {group['repeats']}")
    parts.append(f"--set {' '.join(group['overrides'])}")
    if not group["twins"]:
        parts.append("--no-twins")
    if not group["hidden"]:
        parts.append("--no-hidden")
    return "`" + " ".join(parts) + "`"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("out")
    parser.add_argument("--groups", help="a groups file (papers/discovery/table.yaml): each group run into "
                        "OUT/<its name> with its own settings, the combined table in OUT/rates.md; the options "
                        "below are then not taken")
    parser.add_argument("--effects", nargs="+", help="the specs of papers/hidden_effects to hide (default: every "
                        "registered effect's); EFFECT or EFFECT-VARIANT (e.g. misalignment-validation: validation "
                        f"strips beside the fit tests); also {', '.join(OUTSIDE_THE_LIBRARY)} (outside the library)")
    parser.add_argument("--seeds", nargs="+", type=int, default=GROUP_KEYS["seeds"])
    parser.add_argument("--scatter", nargs="+", type=float, default=GROUP_KEYS["scatter"])
    parser.add_argument("--speeds", nargs="+", type=float, help="every test at these speeds (mm/min)")
    parser.add_argument("--repeats", type=int, help="specimens per test and speed")
    parser.add_argument("--set", nargs="*", default=GROUP_KEYS["overrides"], dest="overrides")
    parser.add_argument("--no-twins", action="store_true", help="only the datasets with the effect hidden")
    parser.add_argument("--no-hidden", action="store_true", help="only the null twins (null data at more seeds)")
    parser.add_argument("--table-only", action="store_true", help="rewrite the tables from what has run")
    parser.add_argument("--record", help="keep each dataset's row in RECORD/<tag>.json (with --groups, "
                        "RECORD/<group name>/<tag>.json); a recorded dataset is not run again")
    args = parser.parse_args()
    library = twill_cli.registered_names(args.twill, "effect")
    if args.groups:
        groups = read_groups(args.groups, library)
        done = []
        for group in groups:
            record = os.path.join(args.record, group["name"]) if args.record else None
            done.append((group, run_group(args.twill, os.path.join(args.out, group["name"]), group, library,
                                          args.table_only, record)))
            write_combined(args.out, done)
        return
    group = {"effects": args.effects or library, "seeds": args.seeds, "scatter": args.scatter, "speeds": args.speeds,
             "repeats": args.repeats, "overrides": args.overrides, "twins": not args.no_twins,
             "hidden": not args.no_hidden}
    message = check_effects(group["effects"], library, "--effects") or check_datasets(group, "--no-twins with --no-hidden")
    if message:
        parser.error(message)
    run_group(args.twill, args.out, group, library, args.table_only, args.record)


if __name__ == "__main__":
    main()
