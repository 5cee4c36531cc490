#!/usr/bin/env python3
"""Fitting hidden effects back (issue #15): for each effect spec and seed, a dataset with the
effect hidden by synthesize.py's own law and its twin with no effect (same seed: the same
specimens, offsets and noise), each fitted by `twill fit --set 'effects=[E]'`.

    run.py TWILL OUTDIR [--effects hysteresis rate-dependence] [--seeds 1 2 3] [--variant V]
           [--set KEY=VALUE ...] [--projection FIT_DIR]

Per (effect, seed) it reads the effect-fit stage's row of report.json:
  error_without  the paper's model fitted (its curves fitted on the loading branches), over
                 every row of the runs (the effect hidden in them);
  error_with     the effect fitted jointly with the curves;
  floor          error_without on the twin with no effect: what the paper's model reaches on
                 the generator's scatter, offsets and noise alone (the noise floor);
  null_with      error_with on the twin: the effect must not buy much where there is none;
  truth_floor    where the generator's law is the library's own (poisson's a12 = r min(a11, a22)):
                 the hidden data fitted with the effect held at the generator's value (its curves
                 fitted to the forces, the effect-fit stage evaluating, not fitting): the floor of
                 these data — the twin's is lower where the effect changes the noise's relative
                 size (lateral strains 2.5x smaller at r = 0.2 than at 0.5, the same 2e-4 noise);
and the fitted parameters against the generator's, scaled by the (geometric) mean specimen
scale of the runs the fit used (truth.yaml's `runs`) — and, with --projection FIT_DIR, against
the same effect fitted to the spec's noise-free data (E-noiseless.yaml: what the library's law
can return of the generator's at best, the law pair differing on purpose). With --variant V the spec is E-V.yaml (e.g.
misalignment-validation.yaml: the paper's validation strips added). Where the data have
validation strips, their rows add, hidden and twin: the validation error at the nominal angles
and with the searched offsets (means over the strips), and the offsets against those drawn
(RMS drawn, RMS found, worst |found − drawn|). Writes OUTDIR/summary.md and summary.json.
"""
import argparse
import json
import math
import os
import subprocess
import sys

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
# Which generated amplitudes each fitted parameter estimates, and the tests that identify it.
COMPARED = {
    "hysteresis": [("hysteresis.warp_friction_N_m", "warp_friction_N_m", "warp"),
                   ("hysteresis.weft_friction_N_m", "weft_friction_N_m", "weft")],
    "rate-dependence": [],
    # a dimensionless ratio of the law: the specimen scale multiplies forces, not strains
    "poisson": [("poisson.coupling_ratio", "coupling_ratio", None),
                ("poisson.coupling_curvature", "coupling_curvature", None)],
    # against the RMS of the offsets drawn for the fitted strips (drawn_spread), not the law's sd
    "misalignment": [("misalignment.spread_deg", "spread_deg", None)],
}
# The effect's options at the generator's value, where the generator's law is the library's.
TRUTH_OPTIONS = {"poisson": lambda effect: (f"coupling_ratio: {effect['coupling_ratio']}, "
                                            f"coupling_curvature: {effect.get('coupling_curvature', 0.0)}")}
# Overrides an effect needs to be fitted at all: misalignment's offsets are per fit run, so
# every repeat must be in the objective.
EFFECT_OVERRIDES = {"misalignment": ["repeats.rule=all"]}


def bending_stiffness_recovery(data_dir, fit_dir, fitted):
    """Per direction, the fitted cantilever bending stiffness b τ³ a / 12 against the one of the
    shell the generator simulated for that direction (truth-bend-<i>.yaml: τ³ a / 12): what a
    cantilever identifies (τ and equal ratios trade, docs/effects/bending-anisotropy.md)."""
    with open(os.path.join(fit_dir, "params.yaml")) as f:
        k = yaml.safe_load(f)
    with open(os.path.join(data_dir, "fabric.yaml")) as f:
        bends = yaml.safe_load(f)["bend"]
    out = {}
    for direction, a, angle in (("warp", "a11_Pa", 90), ("weft", "a22_Pa", 0)):
        index = next(i for i, b in enumerate(bends) if b["angle_deg"] == angle)
        with open(os.path.join(data_dir, f"truth-bend-{index}.yaml")) as f:
            shell = yaml.safe_load(f)
        got = fitted[f"bending-anisotropy.{direction}_bending_ratio"] * k["thickness_m"] ** 3 * k[a]
        expected = shell["thickness_m"] ** 3 * shell[a]
        out[f"bending stiffness {direction}"] = {"fitted": got / 12, "expected": expected / 12,
                                                 "relative": got / expected - 1}
    return out


def drawn_spread(truth, report):
    """RMS of the offsets drawn for the strips the fit used (fit and validation runs)."""
    used = {c["run"] for c in report["fit"] + report.get("validation", [])}
    offsets = [r["offset_deg"] for r in truth["runs"] if os.path.splitext(os.path.basename(r["run"]))[0] in used]
    return (sum(o * o for o in offsets) / len(offsets)) ** 0.5 if offsets else float("nan")


def validation_recovery(truth, report):
    """The validation strips: mean errors at the nominal angle and with the found offsets, and
    the found offsets against the drawn ones; None without validation strips."""
    runs = report.get("validation", [])
    if not runs:
        return None
    drawn = {os.path.splitext(os.path.basename(r["run"]))[0]: r["offset_deg"] for r in truth["runs"]}
    pairs = [(c["delta_theta_deg"], drawn[c["run"]]) for c in runs]
    rms = lambda values: (sum(v * v for v in values) / len(values)) ** 0.5
    return {"strips": len(runs),
            "error_nominal": sum(c["avg_rel_error_without_offset"] for c in runs) / len(runs),
            "error_with": sum(c["avg_rel_error"] for c in runs) / len(runs),
            "rms_drawn": rms([d for _, d in pairs]), "rms_found": rms([f for f, _ in pairs]),
            "worst_miss": max(abs(f - d) for f, d in pairs)}


def run(cmd, log):
    with open(log, "w") as f:
        status = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode
    if status != 0:
        print(f"failed ({status}): {' '.join(cmd)}; see {log}", file=sys.stderr)
    return status == 0


def fit_command(twill, data, out, effects, overrides):
    """`twill fit DATA -o OUT --quiet --set effects=EFFECTS` with each override as another --set."""
    cmd = [twill, "fit", data, "-o", out, "--quiet", "--set", f"effects={effects}"]
    for o in overrides:
        cmd += ["--set", o]
    return cmd


def twin_spec(spec_path, out_path, hidden):
    with open(spec_path) as f:
        spec = yaml.safe_load(f)
    spec["truth"] = os.path.join(HERE, spec["truth"]) if not os.path.isabs(spec["truth"]) else spec["truth"]
    if not hidden:
        spec["effect"] = {"name": "none"}
    with open(out_path, "w") as f:
        yaml.safe_dump(spec, f, sort_keys=False)


def write_summary(stem, rows, header, line):
    """STEM.json (the rows) and STEM.md (a table: `header`, then line(row) per row)."""
    with open(stem + ".json", "w") as f:
        json.dump(rows, f, indent=1)
    with open(stem + ".md", "w") as f:
        f.write("| " + " | ".join(header) + " |\n|" + "---|" * len(header) + "\n")
        for r in rows:
            f.write("| " + " | ".join(str(cell) for cell in line(r)) + " |\n")


def truth_floor(twill, effect, data, fit, overrides):
    """The effect-fit row's error_with of `data` fitted with `effect` held at the generator's value
    (truth.yaml): the fit's config.yaml names the protocol index of the effect's effect-fit stage,
    which is set to evaluate only. None where the generator's law is not the library's."""
    if effect not in TRUTH_OPTIONS:
        return None
    oracle = fit + "-truth"
    if not os.path.exists(os.path.join(oracle, "report.json")):
        with open(os.path.join(data, "truth.yaml")) as f:
            options = TRUTH_OPTIONS[effect](yaml.safe_load(f)["effect"])
        with open(os.path.join(fit, "config.yaml")) as f:
            protocol = yaml.safe_load(f)["protocol"]
        index = next(i for i, s in enumerate(protocol) if s["name"] == "effect-fit" and s.get("effect") == effect)
        cmd = fit_command(twill, data, oracle, f"[{{name: {effect}, {options}}}]",
                          [f"protocol[{index}].fit=false"] + overrides + EFFECT_OVERRIDES.get(effect, []))
        if not run(cmd, oracle + ".log"):
            return None
    return effect_row(os.path.join(oracle, "report.json"))[0]["error_with"]


def effect_row(report_path):
    with open(report_path) as f:
        report = json.load(f)
    return report["effects"][0], report


def mean_scale(truth, report, label):
    """The geometric mean of the drawn specimen scales of the runs the fit used for `label`'s test:
    the specimen the fitted law describes (one run: its scale; every run with a scale each, at
    geometric mean 1 per test: their geometric mean)."""
    used = {c["run"] for c in report["fit"] if c["label"].startswith(label)}
    scales = [r["scale"] for r in truth["runs"] if os.path.splitext(os.path.basename(r["run"]))[0] in used]
    return math.exp(sum(math.log(x) for x in scales) / len(scales)) if scales else float("nan")


# Against a fit of the same effect to the spec's noise-free data (--projection: E-noiseless.yaml
# fitted alike): what the library's law can return of the generator's at best. Per parameter, the
# test whose specimen scale multiplies it (None: dimensionless or a time).
PROJECTED = {"hysteresis": [("hysteresis.warp_friction_N_m", "warp"), ("hysteresis.weft_friction_N_m", "weft")],
             "rate-dependence": [("rate-dependence.viscous_ratio", None), ("rate-dependence.relaxation_s", None)]}


def projection_recovery(projection_dir, effect, truth, report, fitted):
    with open(os.path.join(projection_dir, "report.json")) as f:
        projected = {p["name"]: p["value"] for p in json.load(f)["effects"][0]["parameters"]}
    out = {}
    for name, label in PROJECTED.get(effect, []):
        expected = projected[name] * (mean_scale(truth, report, label) if label else 1.0)
        out[name + " vs projection"] = {"fitted": fitted[name], "expected": expected,
                                        "difference": fitted[name] - expected, "relative": fitted[name] / expected - 1}
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("twill")
    parser.add_argument("out")
    parser.add_argument("--effects", nargs="+", default=["hysteresis", "rate-dependence"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    parser.add_argument("--variant", default=None, help="fit the spec E-VARIANT.yaml instead of E.yaml")
    parser.add_argument("--set", nargs="*", default=["resolution.levels=1"], dest="overrides")
    parser.add_argument("--projection", help="a fit of the effect to the spec's noise-free data (E-noiseless.yaml, "
                                             "fitted with the same --set): recovery against it as well")
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = []
    for effect in args.effects:
        for seed in args.seeds:
            stem = f"{effect}-{args.variant}" if args.variant else effect
            row = {"effect": stem, "seed": seed}
            for hidden in (True, False):
                tag = f"{stem}-{seed}-{'hidden' if hidden else 'none'}"
                spec = os.path.join(args.out, tag + ".spec.yaml")
                twin_spec(os.path.join(HERE, f"{stem}.yaml"), spec, hidden)
                data, fit = os.path.join(args.out, tag), os.path.join(args.out, tag + "-fit")
                if not os.path.exists(os.path.join(fit, "report.json")):
                    ok = run([sys.executable, os.path.join(HERE, "synthesize.py"), spec, "-o", data, "--twill",
                              args.twill, "--seed", str(seed)], data + ".log")
                    cmd = fit_command(args.twill, data, fit, f"[{effect}]", args.overrides + EFFECT_OVERRIDES.get(effect, []))
                    if not (ok and run(cmd, fit + ".log")):
                        continue
                e, report = effect_row(os.path.join(fit, "report.json"))
                with open(os.path.join(data, "truth.yaml")) as f:
                    truth = yaml.safe_load(f)
                validation = validation_recovery(truth, report)
                if validation:
                    # The spread params.yaml carries: estimated after the validation stage (from the
                    # validation offsets alone when there are two or more; the effect-fit row has the
                    # fit runs').
                    with open(os.path.join(fit, "params.yaml")) as f:
                        final = yaml.safe_load(f).get("effects", {}).get(effect, {})
                    validation["spread_final"] = final.get("spread_deg")
                    row["validation" if hidden else "null_validation"] = validation
                if hidden:
                    row.update(error_without=e["error_without"], error_with=e["error_with"],
                               parameters={p["name"]: p["value"] for p in e["parameters"]})
                    oracle = truth_floor(args.twill, effect, data, fit, args.overrides)
                    if oracle is not None:
                        row["truth_floor"] = oracle
                    row["recovery"] = (bending_stiffness_recovery(data, fit, row["parameters"])
                                       if effect == "bending-anisotropy" else {})
                    if args.projection:
                        row["recovery"].update(projection_recovery(args.projection, effect, truth, report,
                                                                   row["parameters"]))
                    for name, key, label in COMPARED.get(effect, []):
                        if effect == "misalignment":
                            expected = drawn_spread(truth, report)
                        else:
                            expected = truth["effect"].get(key, 0.0) * (mean_scale(truth, report, label) if label else 1.0)
                        fitted = row["parameters"][name]
                        row["recovery"][name] = {"fitted": fitted, "expected": expected, "difference": fitted - expected,
                                                 "relative": fitted / expected - 1 if expected else None}
                else:
                    row.update(floor=e["error_without"], null_with=e["error_with"],
                               null_parameters={p["name"]: p["value"] for p in e["parameters"]})
            rows.append(row)
            print(json.dumps(row), flush=True)
    def line(r):
        rec = ", ".join(f"{k.split('.')[-1]} {v['fitted']:.4g} vs {v['expected']:.4g}"
                        + (f" ({100 * v['relative']:+.1f} %)" if v.get("relative") is not None else "")
                        for k, v in r.get("recovery", {}).items())
        pct = lambda k: f"{100 * r[k]:.2f} %" if k in r else "—"
        def strips(key):
            v = r.get(key)
            spread = f", spread in params.yaml {v['spread_final']:.2f}°" if v and v.get("spread_final") is not None else ""
            return (f"{100 * v['error_nominal']:.2f} → {100 * v['error_with']:.2f} %, offsets RMS {v['rms_found']:.2f}° "
                    f"(drawn {v['rms_drawn']:.2f}°), worst miss {v['worst_miss']:.2f}°{spread}") if v else "—"
        return [r["effect"], r["seed"], pct("error_without"), pct("error_with"), pct("floor"), pct("null_with"),
                pct("truth_floor"), rec,
                strips("validation"), strips("null_validation")]

    write_summary(os.path.join(args.out, "summary"), rows,
                  ["effect", "seed", "error without", "error with", "floor", "with, on the twin",
                   "floor at the generator's value", "recovery",
                   "validation strips: nominal → with offsets", "the same on the twin"], line)


if __name__ == "__main__":
    main()
