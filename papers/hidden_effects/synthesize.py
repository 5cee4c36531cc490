#!/usr/bin/env python3
"""Datasets with a hidden effect, from known parameters (issue #15 item 3).

    synthesize.py SPEC.yaml -o DIR [--twill build/app/twill] [--seed N]

The elastic strip comes from `twill simulate` (the paper's model at the spec's resolution);
the hidden effect is added here with the GENERATOR'S OWN LAWS, which differ from twill's
effect library (effects/), so that fitting them back is not circular:

  hysteresis       an Iwan (Masing) element per deformation mode: n Jenkins elements
                   (spring + Coulomb slider) with slip strains spread uniformly over
                   (0, 2 e_y]; loading and unloading branches differ, with a kink-free
                   parabolic build-up of friction (twill's library: Dahl, exponential);
  rate-dependence  two Maxwell branches (a two-term Prony series: beta_i, tau_i) per mode
                   (twill's library: one branch);
  misalignment     per-run angle offsets drawn uniformly from [-sqrt(3) s, sqrt(3) s] (sd s)
                   (twill's library: normal with spread s); the effect's spread_deg replaces
                   the spec's misalignment_deg (which every strip gets otherwise);
  poisson          a12 = r min(a11, a22) set in the truth's params, lateral strain columns;
                   optionally `coupling_curve: {mu, alpha}`, the truth's coupling curve eta2 (any
                   degree; twill's library frees eta2''(0) alone, docs/effects/poisson.md): its
                   eta2''(0) = sum mu (alpha - 1) is written to truth.yaml as coupling_curvature;
  yarn-damage      NOT in twill's library (issue #16's "mechanism outside the library"): the
                   yarns stretched past an onset strain lose force progressively and do not
                   heal on unloading (damage_factor);
  bending-anisotropy  a shell of another thickness per cantilever direction: the cantilever along
                   a direction with ratio b is simulated with tau sqrt(b) and the law's
                   stiffnesses over sqrt(b) (tau a and the membrane unchanged, the bending
                   stiffness tau^3 a / 12 times b) (twill's library: a factor on the bending
                   strains, S = diag(sqrt b_w, sqrt b_f, (b_w b_f)^(1/4)), one thickness).

Both path laws act on the strip path of docs/effects/strip_path.md (a lumped element in
parallel with the strip, split into warp/weft/shear by c(theta)): that structure is the
model's, the laws are not. Realism on top: a multiplicative scale per specimen (lognormal,
sd `scatter`: the 10-20 % between specimens of paper §6.4/§7) and measurement noise (sd
noise_N + noise_relative * |F|). Output: DIR/fabric.yaml and DIR/tensile/*.csv in the dataset
contract's format (docs/dataset-format.md), and DIR/truth.yaml with everything drawn.

Spec keys (unknown keys are an error naming the key):
  name, truth (a params.yaml, or a truth file with a `params:` block; relative to the spec),
  seed, resolution ("16x24"), discretization, scatter, misalignment_deg, noise_N,
  noise_relative, lateral_strain (bool), noise_lateral (sd of the lateral strains' noise), tests (list of {label, angle_deg, max_mm, step_mm,
  unload_to_mm (0: no unloading), repeats, rates_mm_min (list), role}),
  bend (measured cantilevers, copied), bend_tests (simulated cantilevers: list of {angle_deg,
  repeats}; each repeat's overhang at the D1388 chord angle, from `twill simulate --test bend
  --find-overhang`, plus noise of sd noise_overhang_mm), noise_overhang_mm,
  effect ({name, ...law parameters}; absent: none hidden).
"""
import argparse
import math
import os
import random
import subprocess
import sys

import yaml

SPEC_KEYS = {"name", "truth", "seed", "resolution", "discretization", "scatter", "misalignment_deg", "noise_N",
             "noise_relative", "lateral_strain", "noise_lateral", "tests", "effect", "bend", "bend_tests",
             "noise_overhang_mm"}
BEND_TEST_KEYS = {"angle_deg", "repeats"}
# ASTM D1388's cantilever: 25 mm wide, 200 mm long, the overhang read at a 41.5 degree chord.
BEND_WIDTH_MM, BEND_LENGTH_MM, BEND_CHORD_DEG = 25, 200, 41.5
TEST_KEYS = {"label", "angle_deg", "max_mm", "step_mm", "unload_to_mm", "repeats", "rates_mm_min", "role"}
EFFECT_KEYS = {
    "hysteresis": {"name", "warp_friction_N_m", "weft_friction_N_m", "shear_friction_N_m", "yield_strain", "sliders"},
    "rate-dependence": {"name", "ratios", "relaxation_s"},
    "poisson": {"name", "coupling_ratio", "coupling_curve"},
    "misalignment": {"name", "spread_deg"},
    "bending-anisotropy": {"name", "warp_ratio", "weft_ratio"},
    "yarn-damage": {"name", "onset_strain", "loss_per_strain", "largest_loss"},
    "none": {"name"},
}
SECONDS_PER_MINUTE = 60.0


def fail(where, message):
    sys.exit(f"synthesize: {where}: {message}")


def check_keys(mapping, known, where):
    for key in mapping:
        if key not in known:
            fail(where, f"unknown key '{key}' (known: {', '.join(sorted(known))})")


def mode_coefficients(angle_deg):
    t = math.radians(angle_deg)
    return (math.sin(t) ** 2, math.cos(t) ** 2, math.sin(t) * math.cos(t))


def strains(extensions_mm, gauge_mm):
    return [0.0] + [x / gauge_mm for x in extensions_mm]


def iwan_stress(path, saturation, yield_strain, sliders):
    """Masing/Iwan element: `sliders` Jenkins elements, slip strains (i + 1/2) 2 e_y / n, each
    carrying saturation / n at slip; returns the stress at every path point after the first."""
    slips = [(i + 0.5) * 2.0 * yield_strain / sliders for i in range(sliders)]
    stress_each = [0.0] * sliders
    out = []
    for a, b in zip(path[:-1], path[1:]):
        for i, slip in enumerate(slips):
            limit = saturation / sliders
            stiffness = limit / slip
            stress_each[i] = max(-limit, min(limit, stress_each[i] + stiffness * (b - a)))
        out.append(sum(stress_each))
    return out


def prony_response(path, times, ratios, relaxation_s):
    """Unit responses of Maxwell branches (exact for strain linear in time), summed with weights."""
    states = [0.0] * len(ratios)
    out = []
    for (a, b), (ta, tb) in zip(zip(path[:-1], path[1:]), zip(times[:-1], times[1:])):
        dt = tb - ta
        for i, tau in enumerate(relaxation_s):
            if dt > 0:
                decay = math.exp(-dt / tau)
                states[i] = states[i] * decay + (b - a) / dt * tau * (1 - decay)
            else:
                states[i] += b - a
        out.append(sum(r * s for r, s in zip(ratios, states)))
    return out


def damage_factor(effect, angle_deg, extensions_mm, gauge_mm=75.0):
    """Outside twill's library: progressive yarn breakage. The yarn family stretched most (mode
    share max(c_warp, c_weft) of the strip strain) loses a share D = min(largest_loss,
    loss_per_strain (k - onset_strain)+) of its force, k the largest such strain so far (damage
    does not heal on unloading). The strip force is multiplied by 1 - D: a softening beyond the
    onset that no stiffening curve, friction, overstress, offset, coupling or bending factor
    makes."""
    if effect.get("name") != "yarn-damage":
        return [1.0] * len(extensions_mm)
    c = mode_coefficients(angle_deg)
    share = max(c[0], c[1])
    largest, out = 0.0, []
    for x in extensions_mm:
        largest = max(largest, share * x / gauge_mm)
        loss = effect["loss_per_strain"] * max(0.0, largest - effect["onset_strain"])
        out.append(1.0 - min(effect["largest_loss"], loss))
    return out


def path_force(effect, params, angle_deg, extensions_mm, rate_mm_min, width_mm=50.0, gauge_mm=75.0):
    """The hidden effect's clamp force [N] at each extension (strip_path.md's split)."""
    name = effect.get("name", "none")
    c = mode_coefficients(angle_deg)
    eps = strains(extensions_mm, gauge_mm)
    width_m = width_mm * 1e-3
    if name == "hysteresis":
        saturations = (effect["warp_friction_N_m"], effect["weft_friction_N_m"], effect["shear_friction_N_m"])
        total = [0.0] * len(extensions_mm)
        for m in range(3):
            mode_path = [c[m] * e for e in eps]
            stress = iwan_stress(mode_path, saturations[m], effect["yield_strain"], int(effect.get("sliders", 20)))
            total = [t + width_m * c[m] * s for t, s in zip(total, stress)]
        return total
    if name == "rate-dependence":
        times = [0.0]
        speed = rate_mm_min / SECONDS_PER_MINUTE
        previous = 0.0
        for x in extensions_mm:
            times.append(times[-1] + abs(x - previous) / speed)
            previous = x
        moduli = (params["a11_Pa"], params["a22_Pa"], 2 * params["G12_Pa"])
        stiffness = params["thickness_m"] * sum(mod * cm * cm for mod, cm in zip(moduli, c))
        return [width_m * stiffness * r for r in prony_response(eps, times, effect["ratios"], effect["relaxation_s"])]
    return [0.0] * len(extensions_mm)


def schedule(test):
    step = test["step_mm"]
    n = int(round(test["max_mm"] / step))
    up = [step * i for i in range(1, n + 1)]
    down_to = test.get("unload_to_mm", 0)
    down = [step * i for i in range(n - 1, 0, -1) if step * i >= down_to] if down_to > 0 else []
    return up + down


def simulate(twill, params_path, angle_deg, extensions, spec):
    out = subprocess.run([twill, "simulate", "--params", params_path, "--test", "tensile", "--angle-deg",
                          f"{angle_deg:.6f}", "--extensions-mm", ",".join(f"{x:.6g}" for x in extensions),
                          "--resolution", spec.get("resolution", "16x24"), "--discretization",
                          spec.get("discretization", "catmull-clark-kl")],
                         check=True, capture_output=True, text=True).stdout.strip().splitlines()
    header = out[0].split(",")
    rows = [dict(zip(header, map(float, line.split(",")))) for line in out[1:]]
    return [r["force_N"] for r in rows], [r.get("lateral_strain", 0.0) for r in rows]


def truth_params(spec, spec_dir):
    with open(os.path.join(spec_dir, spec["truth"])) as f:
        truth = yaml.safe_load(f)
    params = dict(truth.get("params", truth))
    effect = spec.get("effect", {"name": "none"})
    if effect.get("name") == "poisson":
        params["a12_Pa"] = effect["coupling_ratio"] * min(params["a11_Pa"], params["a22_Pa"])
        if "coupling_curve" in effect:
            params["eta2"] = {"mu": list(effect["coupling_curve"]["mu"]), "alpha": list(effect["coupling_curve"]["alpha"])}
    return params


def bend_ratio(effect, angle_deg):
    """The hidden bending ratio of a cantilever along angle_deg (warp: 90, weft: 0)."""
    if effect.get("name") != "bending-anisotropy":
        return 1.0
    if abs(math.remainder(angle_deg, 180.0)) == 90.0:
        return effect["warp_ratio"]
    if abs(math.remainder(angle_deg, 180.0)) == 0.0:
        return effect["weft_ratio"]
    sys.exit(f"synthesize: bend_tests: bending-anisotropy's ratios are for warp (90) and weft (0), not {angle_deg}")


def simulated_bends(twill, spec, params, effect, rng, out):
    """The spec's bend_tests as dataset entries: overhangs at the chord angle, with noise."""
    entries = []
    for i, test in enumerate(spec.get("bend_tests", [])):
        check_keys(test, BEND_TEST_KEYS, f"bend_tests[{i}]")
        # tau' a' = tau a (the membrane) and tau'^3 a' = b tau^3 a (the bending stiffness).
        shrink = bend_ratio(effect, test["angle_deg"]) ** 0.5
        shell = dict(params, thickness_m=params["thickness_m"] * shrink)
        for key in ("a11_Pa", "a12_Pa", "a22_Pa", "G12_Pa"):
            shell[key] = params[key] / shrink
        path = os.path.join(out, f"truth-bend-{i}.yaml")
        with open(path, "w") as f:
            yaml.safe_dump(shell, f, sort_keys=False)
        found = subprocess.run([twill, "simulate", "--params", path, "--test", "bend", "--angle-deg",
                                f"{test['angle_deg']:g}", "--find-overhang"], check=True, capture_output=True,
                               text=True).stdout.strip()
        overhang = float(found.split("=")[1])
        noise = spec.get("noise_overhang_mm", 0.0)
        entries.append({"angle_deg": test["angle_deg"], "width_mm": BEND_WIDTH_MM, "length_mm": BEND_LENGTH_MM,
                        "chord_angle_deg": BEND_CHORD_DEG,
                        "overhang_mm": [round(overhang + rng.gauss(0.0, noise), 2) for _ in range(test["repeats"])]})
    return entries


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("spec")
    parser.add_argument("-o", "--out", required=True)
    parser.add_argument("--twill", default="build/app/twill")
    parser.add_argument("--seed", type=int, help="overrides the spec's seed")
    args = parser.parse_args()
    with open(args.spec) as f:
        spec = yaml.safe_load(f)
    check_keys(spec, SPEC_KEYS, args.spec)
    effect = spec.get("effect", {"name": "none"})
    if effect.get("name") not in EFFECT_KEYS:
        fail(args.spec + ": effect.name", f"unknown '{effect.get('name')}' (known: {', '.join(EFFECT_KEYS)})")
    check_keys(effect, EFFECT_KEYS[effect["name"]], args.spec + ": effect")
    seed = args.seed if args.seed is not None else spec.get("seed", 1)
    rng = random.Random(seed)
    params = truth_params(spec, os.path.dirname(os.path.abspath(args.spec)))
    os.makedirs(os.path.join(args.out, "tensile"), exist_ok=True)
    params_path = os.path.join(args.out, "truth-params.yaml")
    with open(params_path, "w") as f:
        yaml.safe_dump(params, f, sort_keys=False)
    sd = effect["spread_deg"] if effect.get("name") == "misalignment" else spec.get("misalignment_deg", 0.0)
    spread = sd * math.sqrt(3.0)
    fabric = {"name": spec["name"], "areal_density_g_m2": 1e3 * params["density_kg_m2"],
              "thickness_mm": 1e3 * params["thickness_m"], "tensile": []}
    drawn = []
    for i, test in enumerate(spec["tests"]):
        check_keys(test, TEST_KEYS, f"{args.spec}: tests[{i}]")
        for rate in test.get("rates_mm_min", [300]):
            label = test["label"] if len(test.get("rates_mm_min", [300])) == 1 else f"{test['label']}-{rate:g}"
            entry = {"angle_deg": test["angle_deg"], "label": label, "width_mm": 50, "gauge_length_mm": 75.0,
                     "rate_mm_min": rate, "role": test.get("role", "fit"), "runs": []}
            for r in range(test.get("repeats", 3)):
                offset = rng.uniform(-spread, spread)
                scale = math.exp(rng.gauss(0.0, spec.get("scatter", 0.0)))
                x = schedule(test)
                force, lateral = simulate(args.twill, params_path, test["angle_deg"] + offset, x, spec)
                extra = path_force(effect, params, test["angle_deg"] + offset, x, rate)
                kept = damage_factor(effect, test["angle_deg"] + offset, x)
                force = [f * k for f, k in zip(force, kept)]
                noisy = [scale * (f + e) + rng.gauss(0.0, spec.get("noise_N", 0.0) + spec.get("noise_relative", 0.0)
                                                     * abs(f + e)) for f, e in zip(force, extra)]
                name = f"tensile/{label}-{r + 1}.csv"
                with open(os.path.join(args.out, name), "w") as f:
                    f.write("extension_mm,force_N" + (",lateral_strain" if spec.get("lateral_strain") else "") + "\n")
                    for j, xj in enumerate(x):
                        row = f"{xj:.6g},{noisy[j]:.6g}"
                        if spec.get("lateral_strain"):
                            row += f",{lateral[j] + rng.gauss(0.0, spec.get('noise_lateral', 0.0)):.6g}"
                        f.write(row + "\n")
                entry["runs"].append(name)
                drawn.append({"run": name, "offset_deg": offset, "scale": scale})
            fabric["tensile"].append(entry)
    fabric["bend"] = spec.get("bend", []) + simulated_bends(args.twill, spec, params, effect, rng, args.out)
    if not fabric["bend"]:
        del fabric["bend"]
    with open(os.path.join(args.out, "fabric.yaml"), "w") as f:
        yaml.safe_dump(fabric, f, sort_keys=False)
    if effect.get("name") == "poisson":  # what the library's coupling_curvature estimates
        curve = effect.get("coupling_curve", {"mu": [1.0], "alpha": [1.0]})
        effect = dict(effect, coupling_curvature=sum(m * (a - 1) for m, a in zip(curve["mu"], curve["alpha"])))
    with open(os.path.join(args.out, "truth.yaml"), "w") as f:
        yaml.safe_dump({"generator": "papers/hidden_effects/synthesize.py", "seed": seed, "params": params,
                        "effect": effect, "scatter": spec.get("scatter", 0.0),
                        "misalignment_deg": spec.get("misalignment_deg", 0.0), "noise_N": spec.get("noise_N", 0.0),
                        "noise_relative": spec.get("noise_relative", 0.0), "runs": drawn}, f, sort_keys=False)
    print(f"synthesize: {sum(len(t['runs']) for t in fabric['tensile'])} runs in {args.out}")


if __name__ == "__main__":
    main()
