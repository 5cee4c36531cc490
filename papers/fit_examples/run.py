#!/usr/bin/env python3
"""Fit every example dataset with every optimiser and check the acceptance bars (issues #6, #12).

Usage: run.py TWILL_BINARY EXAMPLES_DIR OUTPUT_DIR [--optimizers bfgs,...] [--set KEY=VALUE ...]

EXAMPLES_DIR is ../shared/data/examples (one folder per fabric plus truth/<name>.yaml with the
parameters the data was generated from). For each (fabric, optimiser) it runs
`twill fit FABRIC -o OUTPUT_DIR/<fabric>-<optimiser> --quiet --set optimizer=<optimiser> ...`
and writes OUTPUT_DIR/summary.md: per fit the average relative errors (warp/weft/bias, worst
run), the membrane stiffnesses tau*a11, tau*a22, tau*G12 relative to the truth, the drape
angles, the validation errors with their offsets, and the wall time; each acceptance bar is
marked pass/FAIL:
  fit error <= 2 % warp/weft, <= 4 % bias; tau*a11, tau*a22 within 2 %, tau*G12 within 5 %
  (issue #12 tightened them from 3 % and 10 % with the locking-free default); both drape
  angles within 1 deg of 41.5.
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
import twill_cli  # noqa: E402  (scripts/twill_cli.py: what the binary is asked)

STIFFNESS_BAR = 0.02  # tau*a11, tau*a22 relative to the truth (issue #12)
SHEAR_BAR = 0.05      # tau*G12 (issue #12; was 0.10 while the default locked off-axis)


def read_truth(path):
    """The params block of truth/<name>.yaml, with a minimal YAML reader (no PyYAML needed)."""
    values = {}
    in_params = False
    with open(path, encoding="utf-8") as f:
        for line in f:
            if line.startswith("params:"):
                in_params = True
                continue
            if in_params and line and not line.startswith(" "):
                break
            stripped = line.strip()
            if in_params and ":" in stripped and line.startswith("  ") and not line.startswith("   "):
                key, _, value = stripped.partition(":")
                try:
                    values[key] = float(value)
                except ValueError:
                    pass
    return values


def registered_names(twill: str, category: str) -> str:
    """The registered names of a category, comma-separated (`twill list --names`)."""
    return ",".join(twill_cli.registered_names(twill, category))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("twill")
    parser.add_argument("examples")
    parser.add_argument("output")
    parser.add_argument("--optimizers", default=None,
                        help="comma-separated names (default: every registered optimiser, `twill list --names optimizer`)")
    parser.add_argument("--fabrics", default="canvas,poplin")
    parser.add_argument("--refit", action="store_true",
                        help="re-run fits whose OUTPUT_DIR/<fabric>-<optimiser>/report.json exists")
    parser.add_argument("--set", action="append", default=[], dest="sets")
    args = parser.parse_args()
    if args.optimizers is None:
        args.optimizers = registered_names(args.twill, "optimizer")
    os.makedirs(args.output, exist_ok=True)

    lines = ["| fabric | optimiser | warp | weft | bias | tau a11 | tau a22 | tau G12 | drape | "
             "validation (offset) | time | bars |", "|" + "---|" * 12]
    for fabric in args.fabrics.split(","):
        truth = read_truth(os.path.join(args.examples, "truth", fabric + ".yaml"))
        for optimizer in args.optimizers.split(","):
            out = os.path.join(args.output, f"{fabric}-{optimizer}")
            cmd = [args.twill, "fit", os.path.join(args.examples, fabric), "-o", out, "--quiet",
                   "--no-plots", "--set", f"optimizer={optimizer}"]
            for s in args.sets:
                cmd += ["--set", s]
            report_path = os.path.join(out, "report.json")
            start = time.time()
            if os.path.exists(report_path) and not args.refit:
                # A finished fit (twill writes OUTDIR atomically): summarised, not re-run; its
                # wall time is the one twill measured.
                result = subprocess.CompletedProcess(cmd, 0, "", "")
            else:
                result = subprocess.run(cmd, capture_output=True, text=True)
            elapsed = time.time() - start
            if result.returncode != 0:
                lines.append(f"| {fabric} | {optimizer} | failed: {result.stderr.strip()[:120]} |" + " |" * 10)
                print(f"{fabric} {optimizer}: failed\n{result.stderr}", file=sys.stderr)
                continue
            with open(os.path.join(out, "report.json"), encoding="utf-8") as f:
                report = json.load(f)
            worst = {}
            for c in report["fit"]:
                worst[c["label"]] = max(worst.get(c["label"], 0.0), c["avg_rel_error"])
            p = report["parameters"]
            tau = p["thickness_m"]
            ttau = truth["thickness_m"]
            rel = {k: tau * p[k] / (ttau * truth[k]) - 1 for k in ("a11_Pa", "a22_Pa", "G12_Pa")}
            drape = [b["chord_angle_deg"] for b in report["bend"]]
            val = report["validation"]
            bars = {
                "fit": worst.get("warp", 1) <= 0.02 and worst.get("weft", 1) <= 0.02 and worst.get("bias", 1) <= 0.04,
                "stiffness": abs(rel["a11_Pa"]) <= STIFFNESS_BAR and abs(rel["a22_Pa"]) <= STIFFNESS_BAR and abs(rel["G12_Pa"]) <= SHEAR_BAR,
                "drape": len(drape) > 0 and all(abs(d - 41.5) <= 1.0 for d in drape),
            }
            val_text = ", ".join(f"{c['label']} {100 * c['avg_rel_error']:.1f} % ({c['delta_theta_deg']:+.1f}°)"
                                 for c in val[:2]) + (f" … ({len(val)} runs)" if len(val) > 2 else "")
            lines.append(
                f"| {fabric} | {optimizer} | {100 * worst.get('warp', float('nan')):.2f} % | "
                f"{100 * worst.get('weft', float('nan')):.2f} % | {100 * worst.get('bias', float('nan')):.2f} % | "
                f"{100 * rel['a11_Pa']:+.2f} % | {100 * rel['a22_Pa']:+.2f} % | {100 * rel['G12_Pa']:+.2f} % | "
                f"{', '.join(f'{d:.2f}°' for d in drape)} | {val_text} | {report['timing_s']['total']:.0f} s | "
                + ", ".join(f"{k} {'pass' if v else 'FAIL'}" for k, v in bars.items()) + " |")
            print(lines[-1], file=sys.stderr)
    with open(os.path.join(args.output, "summary.md"), "w", encoding="utf-8") as f:
        f.write(f"`{' '.join(sys.argv)}`\n\n" + "\n".join(lines) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
