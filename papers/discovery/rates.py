#!/usr/bin/env python3
"""How often `twill discover` names the right effect (issue #16): for each effect of the library,
scatter level and seed, a dataset with the effect hidden by the generator's own law
(papers/hidden_effects/synthesize.py, the effect's spec there) and its twin with no effect (the
same specimens, offsets and noise: the null data, with the same observables, so that every
candidate the hidden dataset can test is testable on the twin too), each given to
`twill discover`.

    rates.py TWILL OUTDIR [--effects SPEC ...] [--seeds 1 2 3 4 5] [--scatter 0.10 0.20]
             [--speeds MM_MIN ...] [--repeats N] [--set KEY=VALUE ...] [--no-twins] [--table-only]

--effects names specs of papers/hidden_effects: an effect (its spec), EFFECT-VARIANT (e.g.
misalignment-validation: validation strips beside the fit tests), or a mechanism outside the
library (yarn-damage; the right verdict there is `unexplained`, a name is a false one). Default:
every registered effect (`twill list --names effect`).

--speeds runs every test of the spec at these crosshead speeds (default: the spec's own). The
hysteresis spec tests at one speed, where a friction loop and a Maxwell loop look alike and the
honest verdict is `tied: hysteresis|rate-dependence (needs: two speeds)`; `--speeds 300 30` gives
the data that separate them. --repeats sets the specimens per test and speed (default: the spec's).

A run whose OUTDIR/<tag>-discover/discover.json exists is not repeated: the study resumes where
it stopped. Writes OUTDIR/rates.json (a row per dataset) and OUTDIR/rates.md (the rates table,
then a line per dataset), both rewritten after every run.

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


def row_of(spec, effect, scatter, seed, hidden, result, seconds):
    candidates = {c["name"]: c for c in result["candidates"]}
    mine = candidates.get(effect, {})
    row = {"spec": spec, "effect": effect, "scatter": scatter, "seed": seed, "hidden": hidden, "verdict": result["verdict"],
           "named": result["named"], "statuses": {n: c["status"] for n, c in candidates.items()},
           "seconds": seconds}
    if "error_without" in mine:
        row["candidate"] = {k: mine.get(k) for k in ("error_without", "error_with", "p_value", "held_out")}
        row["candidate"]["parameters"] = {p["name"]: p["value"] for p in mine.get("parameters", [])}
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


def write_tables(out, rows):
    with open(os.path.join(out, "rates.json"), "w") as f:
        json.dump(rows, f, indent=1)
    kinds = ["named", "named+false", "false", "tied", "untestable", "unexplained", "failed", "none"]
    groups = {}
    for r in rows:
        groups.setdefault((r.get("spec", r["effect"]), r["scatter"], r["hidden"]), []).append(classify(r))
    lines = ["| spec (hidden effect) | data | scatter | datasets | " + " | ".join(kinds) + " |",
             "|---|---|---|---|" + "---|" * len(kinds)]
    for (effect, scatter, hidden), got in sorted(groups.items()):
        lines.append(f"| {effect} | {'hidden' if hidden else 'twin (none)'} | {scatter:g} | {len(got)} | " +
                     " | ".join(str(got.count(k)) for k in kinds) + " |")
    lines += ["", "| spec (hidden effect) | data | scatter | seed | verdict | named | its error without → with (p) | "
              "held-out without → with | time |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        c = r.get("candidate", {})
        pct = lambda v: f"{100 * v:.2f} %" if isinstance(v, (int, float)) else "—"
        held = c.get("held_out") or {}
        p = c.get("p_value")
        lines.append(f"| {r.get('spec', r['effect'])} | {'hidden' if r['hidden'] else 'twin'} | {r['scatter']:g} | {r['seed']} | "
                     f"{r['verdict']} | {', '.join(r['named']) or '—'} | "
                     f"{pct(c.get('error_without'))} → {pct(c.get('error_with'))} ({'—' if p is None else f'{p:.2g}'}) | "
                     f"{pct(held.get('error_without'))} → {pct(held.get('error_with'))} | {r['seconds']:.0f} s |")
    with open(os.path.join(out, "rates.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("out")
    parser.add_argument("--effects", nargs="+", help="the specs of papers/hidden_effects to hide (default: every "
                        "registered effect's); EFFECT or EFFECT-VARIANT (e.g. misalignment-validation: validation "
                        f"strips beside the fit tests); also {', '.join(OUTSIDE_THE_LIBRARY)} (outside the library)")
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3, 4, 5])
    parser.add_argument("--scatter", nargs="+", type=float, default=[0.10, 0.20])
    parser.add_argument("--speeds", nargs="+", type=float, help="every test at these speeds (mm/min)")
    parser.add_argument("--repeats", type=int, help="specimens per test and speed")
    parser.add_argument("--set", nargs="*", default=DEFAULT_SET, dest="overrides")
    parser.add_argument("--no-twins", action="store_true", help="only the datasets with the effect hidden")
    parser.add_argument("--table-only", action="store_true", help="rewrite the tables from what has run")
    args = parser.parse_args()
    library = twill_cli.registered_names(args.twill, "effect")
    args.effects = args.effects or library
    unknown = [e for e in args.effects if not effect_of(e, library + OUTSIDE_THE_LIBRARY)]
    if unknown:
        parser.error(f"--effects: {', '.join(unknown)} names no registered effect ({', '.join(library)}) "
                     f"nor one outside the library ({', '.join(OUTSIDE_THE_LIBRARY)})")
    missing = [spec_path(e) for e in args.effects if not os.path.exists(spec_path(e))]
    if missing:
        parser.error(f"--effects: no spec {', '.join(missing)}")
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for scatter in args.scatter:
        for seed in args.seeds:
            for spec_name in args.effects:
                effect = effect_of(spec_name, library + OUTSIDE_THE_LIBRARY)
                for hidden in (True,) if args.no_twins else (True, False):
                    tag = f"{spec_name}-s{scatter:g}-{seed}-{'hidden' if hidden else 'twin'}"
                    data, result = os.path.join(args.out, tag), os.path.join(args.out, tag + "-discover")
                    done = os.path.join(result, "discover.json")
                    seconds = 0.0
                    if not os.path.exists(done):
                        if args.table_only:
                            continue
                        spec = os.path.join(args.out, tag + ".spec.yaml")
                        spec_for(spec_name, scatter, hidden, spec, args.speeds, args.repeats)
                        if not run([sys.executable, os.path.join(SPECS, "synthesize.py"), spec, "-o", data, "--twill",
                                    args.twill, "--seed", str(seed)], data + ".log"):
                            print(f"{tag}: generator failed, see {data}.log", flush=True)
                            continue
                        cmd = [args.twill, "discover", data, "-o", result, "--quiet", "--no-plots", "--force"]
                        for o in args.overrides:
                            cmd += ["--set", o]
                        t = time.time()
                        if not run(cmd, result + ".log"):
                            print(f"{tag}: discover failed, see {result}.log", flush=True)
                            continue
                        seconds = time.time() - t
                    with open(done) as f:
                        r = json.load(f)
                    row = row_of(spec_name, effect, scatter, seed, hidden, r, seconds or r.get("time_s", 0.0))
                    rows.append(row)
                    print(f"{tag}: {row['verdict']} named {row['named']} ({row['seconds']:.0f} s)", flush=True)
                    write_tables(args.out, rows)
    write_tables(args.out, rows)


if __name__ == "__main__":
    main()
