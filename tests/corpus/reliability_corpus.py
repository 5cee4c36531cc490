#!/usr/bin/env python3
"""The reliability corpus of issue #13: malformed and hostile inputs of every kind, each with
its expected outcome, run against the `twill` program.

Usage: reliability_corpus.py --twill BUILD/app/twill [--only SUBSTRING] [--keep] [--asan]

The cases are generated here, each into its own scratch folder (a temporary directory; nothing
is written anywhere else): fabric.yaml values and structure, dataset paths (escapes, absolute
paths, symlinks, loops, folders, FIFOs), run CSVs, params.yaml, fit configs and --set,
command-line arguments of simulate/bench/inspect, and output folders (the destructive cases).
A case expects either acceptance (exit status 0) or rejection (exit status 2) with a message
holding given fragments (file:line, key, unit). Every case also checks that twill did not crash
(no signal, no status other than 0/1/2), did not hang (timeout), did not allocate past a
memory cap, printed no raw library error and no huge echo, and changed no file in its scratch
folder except the outputs the case allows. Cases that run a fit to completion use a tiny
protocol (one level of 2 cells across, degree 1, no bend/validation, a 6-point run).

Exit status 0 when every case passes; the summary line gives the count and the runtime.
"""
import argparse
import concurrent.futures
import hashlib
import os
import resource
import shutil
import stat
import subprocess
import sys
import tempfile
import time

# Per-case limits: a hang or runaway allocation must show up as a failure, not stall CI or take
# the machine. A rejected input is answered in milliseconds and the tiny fit takes ~1 s, so 60 s
# is a hang; 3 GiB of address space is ~50x a real fit's peak (README: 126 MB).
TIMEOUT_S = 60
MEMORY_CAP_BYTES = 3 * 1024**3
# Longest acceptable error output: a message names a file, a line, a key and quotes a short
# excerpt; anything longer echoes input (the issue's 10 MB cell).
MAX_OUTPUT_BYTES = 8000
# Raw library messages that must never reach a user.
RAW_ERRORS = ["json.exception", "std::bad_alloc", "basic_string", "stod", "stoi", "filesystem error",
              "terminate called", "Segmentation", "what():", "yaml-cpp"]
# Sanitizer reports (scripts/test-sanitize.sh): caught by their text too, not only by the exit
# status the script gives them, since an error status of 1 would pass as an expected failure.
SANITIZER_REPORTS = ["ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:"]

# Linear curves, no initial guess, cutoffs, bend or validation: the protocol as a --set list.
TINY_PROTOCOL = "[" + ", ".join(
    f"{{name: tensile-curve, label: {label}, angle_deg: {angle}, term: {term}, max_degree: 1, uniform_starts: false}}"
    for label, angle, term in [("warp", 90, "eta1"), ("weft", 0, "eta3"), ("bias", 45, "eta4")]) + \
    ", resolution-ladder, final-curves]"
TINY_FIT = ["--quiet", "--no-plots",
            "--set", "resolution.levels=1", "--set", "resolution.coarse_cells_across=2",
            "--set", "protocol=" + TINY_PROTOCOL,
            "--set", "stopping.max_iterations=3", "--set", "stopping.max_evaluations=6"]

RUN_CSV = "extension_mm,force_N\n" + "".join(
    f"{0.5 * i:.2f},{4.0 * i + 0.3 * i * i:.3f}\n" for i in range(1, 7))

# fabric.yaml of the base dataset, one key per line so every case knows its line numbers.
FABRIC_LINES = [
    "name: tiny",                      # 1
    "areal_density_g_m2: 294.0",       # 2
    "thickness_mm: 0.53",              # 3
    "weave: plain",                    # 4
    "tensile:",                        # 5
    "  - angle_deg: 90",               # 6
    "    width_mm: 50",                # 7
    "    gauge_length_mm: 75",         # 8
    "    rate_mm_min: 300",            # 9
    "    role: fit",                   # 10
    "    runs:",                       # 11
    "      - tensile/run-1.csv",       # 12
    "bend:",                           # 13
    "  - angle_deg: 90",               # 14
    "    width_mm: 25",                # 15
    "    length_mm: 200",              # 16
    "    chord_angle_deg: 41.5",       # 17
    "    overhang_mm: [80.9, 81.0]",   # 18
]
# key path -> (line, prefix written before the value)
FABRIC_KEYS = {
    "name": (1, "name: "),
    "areal_density_g_m2": (2, "areal_density_g_m2: "),
    "thickness_mm": (3, "thickness_mm: "),
    "tensile[0].angle_deg": (6, "  - angle_deg: "),
    "tensile[0].width_mm": (7, "    width_mm: "),
    "tensile[0].gauge_length_mm": (8, "    gauge_length_mm: "),
    "tensile[0].rate_mm_min": (9, "    rate_mm_min: "),
    "bend[0].angle_deg": (14, "  - angle_deg: "),
    "bend[0].width_mm": (15, "    width_mm: "),
    "bend[0].length_mm": (16, "    length_mm: "),
    "bend[0].chord_angle_deg": (17, "    chord_angle_deg: "),
}

PARAMS = """model: clyde2017
density_kg_m2: 0.294
thickness_m: 0.00053
a11_Pa: 1.2e8
a12_Pa: 4.0e7
a22_Pa: 0.8e8
G12_Pa: 2.0e6
eta1: {mu: [1.0], alpha: [2.0]}
eta3: {mu: [1.0], alpha: [3.0]}
eta4: {mu: [1.0], alpha: [1.5]}
cutoffs: {E11_max: null, E22_max: null, E12_max: null}
"""


class Case:
    """One input and its expected outcome.

    argv: arguments after `twill`; "{ds}" is the dataset folder, "{w}" the case's work folder.
    setup(work): writes the case's files (default: the base dataset in work/ds).
    expect: "accept", "reject" (bad input, status 2) or "fail" (a fit that fails, status 1);
    fragments: strings the output must contain.
    allowed: paths (relative to work) twill may create or change; check(work): extra checks,
    returns a list of problems.
    """

    def __init__(self, name, argv, expect="reject", fragments=(), setup=None, allowed=(), check=None,
                 needs_non_root=False):
        self.name, self.argv, self.expect = name, argv, expect
        self.fragments, self.setup, self.allowed, self.check = list(fragments), setup, list(allowed), check
        self.needs_non_root = needs_non_root


def write(path, data, mode="w"):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, mode) as f:
        f.write(data)


def base_dataset(work, lines=None, csv=RUN_CSV, folder="ds"):
    ds = os.path.join(work, folder)
    text = "\n".join(FABRIC_LINES if lines is None else lines) + "\n"
    write(os.path.join(ds, "fabric.yaml"), text.encode() if isinstance(text, str) else text, "wb")
    write(os.path.join(ds, "tensile", "run-1.csv"), csv.encode() if isinstance(csv, str) else csv, "wb")
    return ds


def with_line(line_no, text):
    lines = list(FABRIC_LINES)
    lines[line_no - 1] = text
    return lines


def dataset_setup(lines=None, csv=RUN_CSV, extra=None):
    def setup(work):
        base_dataset(work, lines, csv)
        if extra:
            extra(work)
    return setup


# ------------------------------------------------------------------------------------------
# The cases

BAD_NUMBERS = ["0", "-1", "1e6", "1e308", "-1e300", ".nan", ".inf", "-.inf", "abc", "[1, 2]", "",
               "1e400", "0x10", "{a: 1}", "1,5"]


def fabric_value_cases():
    cases = []
    for key, (line, prefix) in FABRIC_KEYS.items():
        if key == "name":
            continue
        for value in BAD_NUMBERS:
            if key.endswith("angle_deg") and value in ("0", "-1"):
                continue  # valid angles; accepted below
            if key == "bend[0].length_mm" and value == "1e6":
                continue  # beyond the range anyway; covered by 1e308
            cases.append(Case(f"fabric/{key}={value or 'empty'}", ["inspect", "{ds}"],
                              fragments=[f"fabric.yaml:{line}", f"key '{key}'"],
                              setup=dataset_setup(with_line(line, prefix + value))))
    # Issue examples, by name.
    cases.append(Case("issue/thickness_mm=1e6", ["fit", "{ds}", "-o", "{w}/out"] + TINY_FIT,
                      fragments=["fabric.yaml:3", "key 'thickness_mm'", "mm", "got 1e+06"],
                      setup=dataset_setup(with_line(3, "thickness_mm: 1e6"))))
    cases.append(Case("issue/width_mm=1e308", ["fit", "{ds}", "-o", "{w}/out"] + TINY_FIT,
                      fragments=["fabric.yaml:7", "key 'tensile[0].width_mm'", "mm"],
                      setup=dataset_setup(with_line(7, "    width_mm: 1e308"))))
    cases.append(Case("issue/gauge_length_mm=1e300", ["fit", "{ds}", "-o", "{w}/out"] + TINY_FIT,
                      fragments=["fabric.yaml:8", "key 'tensile[0].gauge_length_mm'", "mm"],
                      setup=dataset_setup(with_line(8, "    gauge_length_mm: 1e300"))))
    for key, line, value in [("tensile[0].angle_deg", 6, "0"), ("tensile[0].angle_deg", 6, "-45"),
                             ("thickness_mm", 3, "2.5"), ("areal_density_g_m2", 2, "12"),
                             ("tensile[0].width_mm", 7, "25.0"), ("bend[0].chord_angle_deg", 17, "45")]:
        prefix = FABRIC_KEYS[key][1]
        cases.append(Case(f"fabric/accept/{key}={value}", ["inspect", "{ds}"], expect="accept",
                          setup=dataset_setup(with_line(line, prefix + value))))
    for value, fragment in [("[0, 81]", "overhang_mm[0]"), ("[81, 1e9]", "overhang_mm[1]"),
                            ("[250]", "does not fit"), ("[]", "at least one overhang"), ("[.nan]", "overhang_mm[0]")]:
        cases.append(Case(f"fabric/overhang_mm={value}", ["inspect", "{ds}"], fragments=["fabric.yaml:18", fragment],
                          setup=dataset_setup(with_line(18, "    overhang_mm: " + value))))
    return cases


def fabric_structure_cases():
    L = FABRIC_LINES
    c = []
    def add(name, lines, fragments, argv=("inspect", "{ds}"), expect="reject"):
        c.append(Case("fabric/" + name, list(argv), expect=expect, fragments=fragments, setup=dataset_setup(lines)))
    add("unknown-key", L[:4] + ["colour: red"] + L[4:], ["fabric.yaml:5", "key 'colour'", "unknown key"])
    add("unknown-test-key", L[:9] + ["    speed: 3"] + L[9:], ["fabric.yaml:10", "tensile[0].speed", "unknown key"])
    add("duplicate-key", L[:3] + ["thickness_mm: 0.6"] + L[3:], ["fabric.yaml:4", "duplicate key"])
    add("missing-name", L[1:], ["fabric.yaml", "key 'name'", "missing"])
    add("missing-width", L[:6] + L[7:], ["fabric.yaml", "tensile[0].width_mm", "missing"])
    add("missing-runs", L[:10] + L[12:], ["fabric.yaml", "tensile[0].runs", "missing"])
    add("runs-not-list", L[:10] + ["    runs: tensile/run-1.csv"] + L[12:], ["fabric.yaml:11", "tensile[0].runs", "list"])
    add("runs-empty", L[:10] + ["    runs: []"] + L[12:], ["fabric.yaml:11", "at least one run"])
    add("runs-item-map", with_line(12, "      - {a: 1}"), ["fabric.yaml:12", "tensile[0].runs[0]", "text"])
    add("role-bad", with_line(10, "    role: fitting"), ["fabric.yaml:10", "unknown role"])
    add("label-empty", L[:6] + ['    label: ""'] + L[6:], ["fabric.yaml:7", "label"])
    add("duplicate-label", L[:12] + L[5:12] + L[12:], ["fabric.yaml", "tensile[1]", "already used"])
    add("tensile-not-list", L[:4] + ["tensile: 3"], ["fabric.yaml:5", "key 'tensile'", "list"])
    add("no-tests", L[:4], ["fabric.yaml", "at least one test"])
    add("root-list", ["- a", "- b"], ["fabric.yaml:1", "mapping"])
    add("empty-file", [""], ["fabric.yaml", "mapping"])
    add("syntax-error", L[:2] + ["thickness_mm: [0.5"] + L[3:], ["fabric.yaml", "YAML syntax error"])
    add("tab-indent", L[:6] + ["\twidth_mm: 50"] + L[7:], ["fabric.yaml", "YAML syntax error"])
    add("bend-chord-90", with_line(17, "    chord_angle_deg: 90"), ["fabric.yaml:17", "between 0 and 90"])
    add("key-not-text", L[:4] + ["[a]: 1"] + L[4:], ["fabric.yaml:5", "plain text"])
    # Non-UTF-8 text is rejected when read (issue: it failed in the JSON writer after the fit).
    for key, line, prefix in [("name", 1, "name: "), ("weave", 4, "weave: ")]:
        for label, raw in [("ff", b"\xff"), ("overlong", b"\xc0\xaf"), ("surrogate", b"\xed\xa0\x80"),
                           ("truncated", b"ab\xe2\x82")]:
            def setup(work, line=line, prefix=prefix, raw=raw):
                ds = base_dataset(work)
                lines = [l.encode() for l in FABRIC_LINES]
                lines[line - 1] = prefix.encode() + b"abc" + raw + b"def"
                write(os.path.join(ds, "fabric.yaml"), b"\n".join(lines) + b"\n", "wb")
            argv = ["fit", "{ds}", "-o", "{w}/out"] + TINY_FIT if key == "name" else ["inspect", "{ds}"]
            c.append(Case(f"{'issue' if key == 'name' and label == 'ff' else 'fabric'}/non-utf8-{key}-{label}", argv,
                          fragments=[f"fabric.yaml:{line}", f"key '{key}'", "UTF-8"], setup=setup))
    def utf8_key(work):
        ds = base_dataset(work)
        write(os.path.join(ds, "fabric.yaml"), "\n".join(FABRIC_LINES).encode() + b"\nk\xffy: 1\n", "wb")
    c.append(Case("fabric/non-utf8-key", ["inspect", "{ds}"], fragments=["fabric.yaml:19", "UTF-8"], setup=utf8_key))
    add("accept/utf8-name", with_line(1, "name: Köper — 斜纹"), [], expect="accept")
    add("accept/base", None, [], expect="accept")
    return c


def dataset_folder_cases():
    c = []
    def special(name, make, fragments, argv=("inspect", "{ds}")):
        def setup(work):
            base_dataset(work)
            make(work, os.path.join(work, "ds"))
        c.append(Case("folder/" + name, list(argv), fragments=fragments, setup=setup))
    special("fabric-missing", lambda w, ds: os.remove(os.path.join(ds, "fabric.yaml")), ["fabric.yaml", "cannot open"])
    special("fabric-is-dir", lambda w, ds: (os.remove(os.path.join(ds, "fabric.yaml")),
                                            os.mkdir(os.path.join(ds, "fabric.yaml"))), ["fabric.yaml", "directory"])
    special("fabric-is-fifo", lambda w, ds: (os.remove(os.path.join(ds, "fabric.yaml")),
                                             os.mkfifo(os.path.join(ds, "fabric.yaml"))), ["fabric.yaml", "special file"])
    special("fabric-symlink-loop", lambda w, ds: (os.remove(os.path.join(ds, "fabric.yaml")),
                                                  os.symlink("fabric.yaml", os.path.join(ds, "fabric.yaml"))),
            ["fabric.yaml", "symlink loop"])
    special("fabric-dangling-symlink", lambda w, ds: (os.remove(os.path.join(ds, "fabric.yaml")),
                                                      os.symlink("nowhere.yaml", os.path.join(ds, "fabric.yaml"))),
            ["fabric.yaml", "symlink to nothing"])
    c.append(Case("folder/dataset-missing", ["inspect", "{w}/nothing"], fragments=["nothing", "no such directory"],
                  setup=lambda w: None))
    c.append(Case("folder/dataset-is-file", ["fit", "{w}/file.txt", "-o", "{w}/out"] + TINY_FIT,
                  fragments=["file.txt"], setup=lambda w: write(os.path.join(w, "file.txt"), "x")))
    c.append(Case("folder/fit-no-dataset", ["fit", "-o", "{w}/out", "--quiet"], fragments=["DATASET"],
                  setup=lambda w: None))
    return c


def run_path_cases():
    c = []
    line = 12
    def path_case(name, listed, fragments, extra=None, expect="reject", issue=False):
        lines = with_line(line, "      - " + listed)
        frag = [] if expect == "accept" else [f"fabric.yaml:{line}", "key 'tensile[0].runs[0]'"] + fragments
        c.append(Case(("issue/" if issue else "paths/") + name, ["inspect", "{ds}"], expect=expect, fragments=frag,
                      setup=dataset_setup(lines, extra=extra)))
    path_case("etc-passwd-relative", "../../../../../../../../etc/passwd", ["leaves the dataset folder"], issue=True)
    path_case("etc-passwd-absolute", "/etc/passwd", ["absolute path"], issue=True)
    path_case("absolute-inside", "{ABS}", ["absolute path"])
    path_case("dev-zero", "/dev/zero", ["absolute path"])
    path_case("parent-csv", "../outside.csv", ["leaves the dataset folder"],
              extra=lambda w: write(os.path.join(w, "outside.csv"), RUN_CSV))
    path_case("dotdot-inside", "tensile/../tensile/run-1.csv", [], expect="accept")
    path_case("dot-slash", "./tensile/run-1.csv", [], expect="accept")
    path_case("symlink-outside", "tensile/link.csv", ["leaves the dataset folder"],
              extra=lambda w: (write(os.path.join(w, "outside.csv"), RUN_CSV),
                               os.symlink(os.path.join(w, "outside.csv"), os.path.join(w, "ds", "tensile", "link.csv"))))
    path_case("symlink-dir-outside", "sub/run.csv", ["leaves the dataset folder"],
              extra=lambda w: (write(os.path.join(w, "elsewhere", "run.csv"), RUN_CSV),
                               os.symlink(os.path.join(w, "elsewhere"), os.path.join(w, "ds", "sub"))))
    path_case("symlink-to-dev-zero", "tensile/zero.csv", ["leaves the dataset folder"],
              extra=lambda w: os.symlink("/dev/zero", os.path.join(w, "ds", "tensile", "zero.csv")))
    path_case("symlink-inside", "tensile/alias.csv", [], expect="accept",
              extra=lambda w: os.symlink("run-1.csv", os.path.join(w, "ds", "tensile", "alias.csv")))
    path_case("symlink-loop", "tensile/loop.csv", ["symlink loop"],
              extra=lambda w: os.symlink("loop.csv", os.path.join(w, "ds", "tensile", "loop.csv")))
    path_case("symlink-loop-pair", "tensile/a.csv", ["symlink loop"],
              extra=lambda w: (os.symlink("b.csv", os.path.join(w, "ds", "tensile", "a.csv")),
                               os.symlink("a.csv", os.path.join(w, "ds", "tensile", "b.csv"))))
    path_case("directory", "tensile", ["a directory"])
    path_case("dataset-root", ".", ["a directory"])
    path_case("fifo", "tensile/pipe.csv", ["special file"],
              extra=lambda w: os.mkfifo(os.path.join(w, "ds", "tensile", "pipe.csv")))
    path_case("missing", "tensile/run-9.csv", ["no such file"])
    path_case("empty", '""', ["empty path"])
    path_case("fabric-itself", "fabric.yaml", ["missing required extension"], expect="reject")
    # The CSV's own error names the CSV line and where fabric.yaml lists it.
    c[-1].fragments = ["fabric.yaml:1", "run listed in", "fabric.yaml:12, key 'tensile[0].runs[0]'"]
    for case in c:
        if "{ABS}" in str(case.setup):
            pass
    # absolute-inside needs the real path: patch its setup.
    def abs_inside(work):
        ds = os.path.join(work, "ds")
        base_dataset(work, with_line(line, "      - " + os.path.join(ds, "tensile", "run-1.csv")))
    for case in c:
        if case.name.endswith("absolute-inside"):
            case.setup = abs_inside
    return c


def csv_cases():
    c = []
    H = "extension_mm,force_N\n"
    rows = RUN_CSV.split("\n", 1)[1]
    def add(name, csv, fragments, expect="reject", issue=False):
        frag = ["run-1.csv"] + fragments + ["fabric.yaml:12, key 'tensile[0].runs[0]'"]
        c.append(Case(("issue/" if issue else "csv/") + name, ["inspect", "{ds}"], expect=expect,
                      fragments=[] if expect == "accept" else frag, setup=dataset_setup(csv=csv)))
    add("bad-cell", H + "0.5,4\n1.0,1O.0\n", ["run-1.csv:3", "force_N", "not a finite number"])
    for v in ["nan", "inf", "-inf", "1e400", "", "0x1p3", "1,2", "'", "1e", "--1"]:
        add(f"cell={v or 'empty'}", H + "0.5,4\n1.0," + v + "\n1.5,9\n", ["run-1.csv:3"])
    add("empty-file", "", ["empty file"])
    add("header-only", H, ["no data rows"])
    add("comments-only", "# nothing\n\n# here\n", ["empty file"])
    add("one-row", H + "0.5,4\n", ["run-1.csv:2", "only one data row"], issue=True)
    add("all-zero-forces", H + "".join(f"{0.5 * i},0\n" for i in range(1, 6)), ["no positive force"], issue=True)
    add("all-negative-forces", H + "".join(f"{0.5 * i},{-3.0 * i}\n" for i in range(1, 6)), ["no positive force"],
        issue=True)
    add("one-pulling-row", H + "0.5,4\n0,-1\n", ["fewer than 2 rows"])
    add("negative-extensions", H + "-0.5,4\n-1.0,8\n", ["fewer than 2 rows"])
    add("force-1e7", H + "0.5,4\n1.0,1e7\n", ["run-1.csv:3", "force", "N"])
    add("force-kN-1e4", "extension_mm,force_kN\n0.5,4\n1.0,1e4\n", ["run-1.csv:3", "N"])
    add("extension-1e6", H + "0.5,4\n1e6,8\n", ["run-1.csv:3", "extension", "strain"])
    add("extension-below-clamps", H + "0.5,4\n-100,8\n1.0,9\n", ["run-1.csv:3", "strain"])
    add("extension-metres", "extension_m,force_N\n0.5,4\n1.0,8\n", ["run-1.csv:3", "strain", "mm"])
    add("wrong-column-count", H + "0.5,4\n1.0,8,3\n", ["run-1.csv:3", "row has 3 cells"])
    add("missing-force", "extension_mm,time_s\n0.5,4\n1,2\n", ["run-1.csv:1", "missing required force"])
    add("missing-extension", "force_N\n4\n8\n", ["run-1.csv:1", "missing required extension"])
    add("semicolons", "extension_mm;force_N\n0.5;4\n1;8\n", ["missing required extension"])
    add("two-force-columns", "extension_mm,force_N,load_N\n0.5,4,4\n1,8,8\n", ["two columns give the force"])
    add("unknown-unit", "extension (furlong),force_N\n0.5,4\n1,8\n", ["missing required extension"])
    add("binary", "\x00\x01\x02\xff\n\x00,\x00\n", ["run-1.csv"])
    big = "9" * (10 * 1024 * 1024)
    add("10MB-cell", H + "0.5,4\n1.0," + big + "x\n", ["run-1.csv:3", "bytes)"], issue=True)
    add("non-utf8-cell", H.encode() + b"0.5,4\n1.0,8\xff\n", ["run-1.csv:3", "\\xFF"])
    add("accept/bom-crlf", "\ufeffextension_mm,force_N\r\n0.5,4\r\n1.0,8\r\n", [], expect="accept")
    add("accept/tester-export", "# tester\nTime (s),Extension (mm),Load (N)\n\n0,0,0\n1,0.5,4\n2,1.0,8\n2.5,0.5,3\n",
        [], expect="accept")
    add("accept/comments", H + "# loading\n0.5,4\n\n1.0,8\n", [], expect="accept")
    add("accept/units", "Extension (cm),Load (kN)\n0.05,0.004\n0.1,0.008\n", [], expect="accept")
    return c


def params_cases():
    c = []
    def add(name, text, fragments, expect="reject", extra_argv=()):
        def setup(work, text=text):
            write(os.path.join(work, "p.yaml"), text if isinstance(text, bytes) else text.encode(), "wb")
        argv = ["simulate", "--params", "{w}/p.yaml", "--test", "tensile", "--angle-deg", "90",
                "--extensions-mm", "0.5,1", "--resolution", "1x2"] + list(extra_argv)
        c.append(Case("params/" + name, argv, expect=expect, fragments=fragments, setup=setup))
    P = PARAMS
    add("accept/valid", P, [], expect="accept")
    add("unknown-key", P + "colour: red\n", ["p.yaml:12", "colour", "unknown key"])
    add("negative-stiffness", P.replace("a22_Pa: 0.8e8", "a22_Pa: -0.8e8"), ["p.yaml:6", "a22_Pa"])
    add("nan-stiffness", P.replace("a11_Pa: 1.2e8", "a11_Pa: .nan"), ["p.yaml:4", "a11_Pa"])
    add("inf-thickness", P.replace("thickness_m: 0.00053", "thickness_m: .inf"), ["p.yaml:3", "thickness_m"])
    add("zero-thickness", P.replace("thickness_m: 0.00053", "thickness_m: 0"), ["p.yaml:3", "thickness_m"])
    add("model-non-utf8", P.replace("clyde2017", "clyde\udcff2017").encode("utf-8", "surrogateescape"),
        ["p.yaml:1", "model", "UTF-8"])
    add("mu-alpha-lengths", P.replace("eta1: {mu: [1.0], alpha: [2.0]}", "eta1: {mu: [1.0], alpha: [2.0, 3.0]}"),
        ["p.yaml:8", "eta1"])
    add("syntax", P + "a: [\n", ["p.yaml", "YAML syntax error"])
    add("duplicate", P + "a11_Pa: 1\n", ["p.yaml:12", "duplicate key"])
    add("empty", "", ["p.yaml", "mapping"])
    c.append(Case("params/is-directory", ["simulate", "--params", "{w}", "--test", "tensile", "--angle-deg", "90",
                                          "--extensions-mm", "1"], fragments=["--params"], setup=lambda w: None))
    return c


def simulate_cases():
    c = []
    def setup(work):
        write(os.path.join(work, "p.yaml"), PARAMS)
    base = ["simulate", "--params", "{w}/p.yaml", "--test", "tensile", "--angle-deg", "90",
            "--extensions-mm", "0.5,1", "--resolution", "1x2"]
    def replaced(option, value):
        argv = list(base)
        if option in argv:
            argv[argv.index(option) + 1] = value
        else:
            argv += [option, value]
        return argv
    for option, values, fragment in [
            ("--angle-deg", ["1e300", "nan", "inf", "-inf", "181", "-1e9"], "deg"),
            ("--extensions-mm", ["nan", "inf", "1e300", "-1000", "abc", "0.5,,1", "0.5,nan", "1e400", ","], "--extensions-mm"),
            ("--width-mm", ["0", "-1", "1e308", "nan"], "mm"),
            ("--gauge-mm", ["0", "1e300", "-5", "inf"], "mm"),
            ("--resolution", ["100000x100000", "0x4", "4x", "x4", "4x4x4", "1e3x2", "-1x4",
                              "99999999999999999999x1", "4 x 4", "300x300", "16x24junk"], "--resolution")]:
        for v in values:
            name = ("issue/" if (option, v) in [("--angle-deg", "1e300"), ("--extensions-mm", "nan"),
                                                ("--resolution", "100000x100000")] else "simulate/")
            frags = [option, fragment]
            if option == "--resolution" and v in ("100000x100000", "300x300"):
                frags += ["would need", "the limit is"]
            c.append(Case(f"{name}tensile{option}={v}", replaced(option, v), fragments=frags, setup=setup))
    bend = ["simulate", "--params", "{w}/p.yaml", "--test", "bend", "--angle-deg", "90", "--resolution", "1x4"]
    for v in ["0", "-3", "1e300", "nan"]:
        c.append(Case(f"simulate/bend--overhang-mm={v}", bend + ["--overhang-mm", v], fragments=["--overhang-mm"],
                      setup=setup))
    c.append(Case("simulate/bend--resolution=4x100000", bend[:-1] + ["4x100000", "--overhang-mm", "80"],
                  fragments=["--resolution", "would need"], setup=setup))
    c.append(Case("simulate/accept/tensile", base, expect="accept", setup=setup))
    c.append(Case("simulate/accept/out-file", base + ["--out", "{w}/curve.csv"], expect="accept", setup=setup,
                  allowed=["curve.csv"]))
    return c


def other_command_cases():
    c = []
    def ref(work):
        write(os.path.join(work, "ref", "params.yaml"), PARAMS)
        write(os.path.join(work, "ref", "tensile-warp.csv"), RUN_CSV)
    bench = ["bench", "--reference", "{w}/ref", "--discretization", "triangle-shell"]
    for v in ["100000x100000", "0x1", "ax4", "8x12,16x24"]:
        c.append(Case(f"bench/--resolution={v}", bench + ["--resolution", v], fragments=["--resolution"], setup=ref))
    c.append(Case("bench/--label=a1e300", bench + ["--resolution", "1x2", "--label", "a1e300"],
                  fragments=["--label"], setup=ref))
    c.append(Case("bench/--label=axyz", bench + ["--resolution", "1x2", "--label", "axyz"],
                  fragments=["--label"], setup=ref))
    c.append(Case("bench/accept", bench + ["--resolution", "1x2", "--label", "warp"], expect="accept", setup=ref))
    for v in ["-1", "abc", "1e3", "-9223372036854775809"]:
        c.append(Case(f"{'issue' if v == '-1' else 'inspect'}/--seed={v}", ["inspect", "{ds}", "--seed", v],
                      fragments=["--seed"], setup=dataset_setup()))
    c.append(Case("inspect/accept/--seed=7", ["inspect", "{ds}", "--seed", "7"], expect="accept",
                  setup=dataset_setup()))
    return c


def config_cases():
    c = []
    fit = ["fit", "{ds}", "-o", "{w}/out", "--quiet", "--no-plots"]
    def add(name, extra, fragments, setup=None, issue=False):
        c.append(Case(("issue/" if issue else "config/") + name, fit + extra, fragments=fragments,
                      setup=setup or dataset_setup()))
    add("resolution.coarse_cells_across=100000", ["--set", "resolution.coarse_cells_across=100000"],
        ["--set", "resolution.coarse_cells_across", "would need", "the limit is"], issue=True)
    add("bend cells_along=100000", ["--set", "experiments.bend.cells_along=100000"],
        ["--set", "experiments.bend.cells_along", "would need", "the limit is"], issue=True)
    add("bend cells_across=100000", ["--set", "experiments.bend.cells_across=100000"],
        ["--set", "experiments.bend.cells_across", "would need"], issue=True)
    # An int option: the schema caps it at the type's largest value before any size check.
    add("coarse_cells_across=int64max", ["--set", "resolution.coarse_cells_across=9223372036854775807"],
        ["resolution.coarse_cells_across", "2147483647"])
    add("coarse_cells_across=4000", ["--set", "resolution.coarse_cells_across=4000"], ["would need"])
    add("coarse_cells_across=100-levels5", ["--set", "resolution.coarse_cells_across=100", "--set",
                                            "resolution.levels=5"], ["tensile[0]", "would need"])
    for kv, frag in [("resolution.levels=9", "resolution.levels"), ("repeats.seed=-1", "repeats.seed"),
                     ("protocol[1].max_degree=nan", "protocol[1].max_degree"), ("stopping.gradient_tolerance=.nan", "gradient_tolerance"),
                     ("solver.gradient_tolerance=-1", "solver.gradient_tolerance"), ("optimizer=newton", "optimizer"),
                     ("protocol[1].maximum=2", "protocol[1].maximum"), ("resolution.coarse_cells_across=0", "coarse_cells_across"),
                     ("resolution.coarse_cells_across=1.5", "coarse_cells_across"), ("data.max_points=1e99", "max_points"),
                     ("protocol[*].max_offset_deg=inf", "max_offset_deg"), ("noequals", "key.path=value"),
                     ("resolution.coarse_cells_across=99999999999999999999", "coarse_cells_across")]:
        add(f"--set {kv}", ["--set", kv], ["--set", frag])
    # A key of a config written before the protocol became data says where it moved.
    add("--set degree.max=1 (moved)", ["--set", "degree.max=1"], ["--set", "'degree' moved", "protocol[*].max_degree"])
    add("-c-old-stages-key", ["-c", "{w}/c.yaml"], ["c.yaml:1", "'stages' moved", "strain-cutoff"],
        setup=dataset_setup(extra=lambda w: write(os.path.join(w, "c.yaml"), "stages: {bend: false}\n")))
    add("-c-directory", ["-c", "{w}/confdir"], ["confdir", "directory"],
        setup=dataset_setup(extra=lambda w: os.mkdir(os.path.join(w, "confdir"))), issue=True)
    add("-c-missing", ["-c", "{w}/none.yaml"], ["none.yaml", "cannot open"])
    add("-c-fifo", ["-c", "{w}/pipe.yaml"], ["pipe.yaml", "special file"],
        setup=dataset_setup(extra=lambda w: os.mkfifo(os.path.join(w, "pipe.yaml"))))
    add("-c-unknown-key", ["-c", "{w}/c.yaml"], ["c.yaml:2", "unknown key"],
        setup=dataset_setup(extra=lambda w: write(os.path.join(w, "c.yaml"), "optimizer: bfgs\ncolour: red\n")))
    add("-c-non-utf8", ["-c", "{w}/c.yaml"], ["c.yaml:1", "UTF-8"],
        setup=dataset_setup(extra=lambda w: write(os.path.join(w, "c.yaml"), b"optimizer: bf\xffgs\n", "wb")))
    add("-c-huge-cells", ["-c", "{w}/c.yaml"], ["c.yaml", "experiments.bend.cells_along", "would need"],
        setup=dataset_setup(extra=lambda w: write(os.path.join(w, "c.yaml"),
                                                  "experiments: {bend: {cells_along: 1000000}}\n")))
    return c


# ---- output folders (the destructive cases) -------------------------------------------------

def has(path, text=None):
    def check(work):
        p = os.path.join(work, path)
        if not os.path.exists(p):
            return [f"{path} is missing"]
        if text is not None and open(p).read() != text:
            return [f"{path} changed"]
        return []
    return check


def all_of(*checks):
    return lambda work: [p for c in checks for p in c(work)]


def absent(path):
    return lambda work: [f"{path} exists"] if os.path.lexists(os.path.join(work, path)) else []


OUTPUTS = ["params.yaml", "config.yaml", "report.json", "report.md", ".twill-fit"]


def output_cases():
    c = []
    fit = ["fit", "{ds}"] + TINY_FIT
    def folder_with(files, marker=False):
        def setup(work):
            base_dataset(work)
            for name, text in files.items():
                write(os.path.join(work, "mydir", name), text)
            if marker:
                write(os.path.join(work, "mydir", ".twill-fit"), "old marker\n")
        return setup
    c.append(Case("issue/-o-dataset-folder", fit + ["-o", "{ds}"], fragments=["-o", "dataset"]))
    c.append(Case("output/-o-dataset-folder-force", fit + ["-o", "{ds}", "--force"], fragments=["-o", "dataset"]))
    c.append(Case("output/-o-dataset-folder-slash", fit + ["-o", "{ds}/"], fragments=["-o", "dataset"]))
    c.append(Case("output/-o-dataset-via-dotdot", fit + ["-o", "{ds}/tensile/.."], fragments=["-o", "dataset"]))
    c.append(Case("output/-o-other-dataset", fit + ["-o", "{w}/other", "--force"], fragments=["fabric.yaml"],
                  setup=lambda w: (base_dataset(w), base_dataset(w, folder="other"))))
    c.append(Case("issue/-o-dir-with-notes", fit + ["-o", "{w}/mydir"], fragments=["-o", "not a twill output", "--force"],
                  setup=folder_with({"notes.txt": "my notes\n"}), check=has("mydir/notes.txt", "my notes\n")))
    c.append(Case("output/-o-dir-with-notes-force", fit + ["-o", "{w}/mydir", "--force"], expect="accept",
                  setup=folder_with({"notes.txt": "my notes\n"}), allowed=["mydir"],
                  check=all_of(has("mydir/notes.txt", "my notes\n"), *[has("mydir/" + f) for f in OUTPUTS])))
    c.append(Case("output/-o-dir-force-user-subdir-kept", fit + ["-o", "{w}/mydir", "--force"], expect="accept",
                  setup=folder_with({"sub/data.csv": "1,2\n", "report.md.bak": "mine\n"}), allowed=["mydir"],
                  check=all_of(has("mydir/sub/data.csv", "1,2\n"), has("mydir/report.md.bak", "mine\n"))))
    c.append(Case("issue/-o-existing-file", fit + ["-o", "{w}/file.txt"], fragments=["-o", "not a folder"],
                  setup=lambda w: (base_dataset(w), write(os.path.join(w, "file.txt"), "keep\n")),
                  check=has("file.txt", "keep\n")))
    c.append(Case("output/-o-existing-file-force", fit + ["-o", "{w}/file.txt", "--force"],
                  fragments=["-o", "not a folder"],
                  setup=lambda w: (base_dataset(w), write(os.path.join(w, "file.txt"), "keep\n")),
                  check=has("file.txt", "keep\n")))
    c.append(Case("output/-o-dangling-symlink", fit + ["-o", "{w}/link"], fragments=["-o", "not a folder"],
                  setup=lambda w: (base_dataset(w), os.symlink(os.path.join(w, "nowhere"), os.path.join(w, "link")))))
    c.append(Case("output/-o-previous-output-replaced", fit + ["-o", "{w}/mydir"], expect="accept",
                  setup=folder_with({"params.yaml": "old\n", "fig2_force_elongation.png": "old\n"}, marker=True),
                  allowed=["mydir"],
                  check=all_of(*[has("mydir/" + f) for f in OUTPUTS], absent("mydir/fig2_force_elongation.png"),
                               lambda w: ["params.yaml not replaced"]
                               if open(os.path.join(w, "mydir/params.yaml")).read() == "old\n" else [])))
    c.append(Case("output/-o-previous-output-user-file-kept", fit + ["-o", "{w}/mydir"], expect="accept",
                  setup=folder_with({"params.yaml": "old\n", "notes.txt": "mine\n"}, marker=True), allowed=["mydir"],
                  check=all_of(has("mydir/notes.txt", "mine\n"), has("mydir/params.yaml"))))
    c.append(Case("output/-o-empty-dir", fit + ["-o", "{w}/mydir"], expect="accept",
                  setup=lambda w: (base_dataset(w), os.makedirs(os.path.join(w, "mydir"))), allowed=["mydir"],
                  check=has("mydir/params.yaml")))
    c.append(Case("output/-o-new-nested", fit + ["-o", "{w}/a/b/c"], expect="accept", allowed=["a"],
                  check=has("a/b/c/params.yaml")))
    c.append(Case("output/-o-trailing-slash", fit + ["-o", "{w}/new/"], expect="accept", allowed=["new"],
                  check=has("new/params.yaml")))
    c.append(Case("output/-o-partial-is-users", fit + ["-o", "{w}/mydir"], fragments=["mydir.partial", "not twill's"],
                  setup=lambda w: (base_dataset(w), write(os.path.join(w, "mydir.partial", "x.txt"), "mine\n")),
                  check=has("mydir.partial/x.txt", "mine\n")))
    c.append(Case("output/-o-partial-leftover-removed", fit + ["-o", "{w}/mydir"], expect="accept",
                  setup=lambda w: (base_dataset(w), write(os.path.join(w, "mydir.partial", ".twill-fit"), "m\n"),
                                   write(os.path.join(w, "mydir.partial", "params.yaml"), "half\n")),
                  allowed=["mydir", "mydir.partial"], check=all_of(has("mydir/params.yaml"), absent("mydir.partial"))))
    c.append(Case("output/-o-unwritable", fit + ["-o", "{w}/ro/out"], fragments=["-o", "not writable"],
                  setup=lambda w: (base_dataset(w), os.makedirs(os.path.join(w, "ro")), os.chmod(os.path.join(w, "ro"), 0o555)),
                  needs_non_root=True))
    # /proc takes no new entries, even from root (who passes every permission check above).
    c.append(Case("output/-o-unwritable-proc", fit + ["-o", "/proc/twill-corpus-out"],
                  fragments=["-o", "output folder /proc/twill-corpus-out"]))
    # The default output path is built from the dataset's name, made one safe path component.
    c.append(Case("issue/hostile-name-default-out", fit, expect="accept", allowed=["out"],
                  setup=dataset_setup(with_line(1, 'name: "/../../../ESCAPED"')),
                  check=all_of(has("out/fit-ESCAPED/params.yaml"), absent("../ESCAPED"), absent("ESCAPED"))))
    c.append(Case("output/dotdot-name-default-out", fit, expect="accept", allowed=["out"],
                  setup=dataset_setup(with_line(1, 'name: ".."')), check=has("out/fit-dataset/params.yaml")))
    c.append(Case("output/long-name-default-out", fit, expect="accept", allowed=["out"],
                  setup=dataset_setup(with_line(1, "name: " + "x" * 300)), check=has("out/fit-" + "x" * 64 + "/params.yaml")))
    return c


BIAS_CSV = "extension_mm,force_N\n" + "".join(f"{74.0 * i:.2f},{5e5 * (i / 10) ** 2 + 1:.3f}\n" for i in range(1, 11))


def late_failure_cases():
    """A fit whose bias stage fails after warp and weft finished: a bias run to 10x its gauge,
    which the coarse strip cannot follow (measured: "stage bias: degree 1 fit failed")."""
    def setup(work):
        lines = FABRIC_LINES[:12] + [
            "  - angle_deg: 0", "    width_mm: 50", "    gauge_length_mm: 75", "    runs: [tensile/run-1.csv]",
            "  - angle_deg: 45", "    width_mm: 50", "    gauge_length_mm: 75", "    runs: [tensile/bias-1.csv]"]
        ds = base_dataset(work, lines)
        write(os.path.join(ds, "tensile", "bias-1.csv"), BIAS_CSV)
    def incomplete_report(work):
        p = os.path.join(work, "out.incomplete", "report-incomplete.md")
        if not os.path.exists(p):
            return ["out.incomplete/report-incomplete.md is missing"]
        text = open(p).read()
        problems = [] if text.startswith("# INCOMPLETE") else ["the kept report is not marked incomplete"]
        return problems + ([] if "| warp |" in text else ["the finished warp stage is not in the kept report"])
    return [
        Case("issue/late-failure-keeps-finished-stages", ["fit", "{ds}", "-o", "{w}/out"] + TINY_FIT, expect="fail",
             fragments=["stage bias", "marked incomplete", "out.incomplete/report-incomplete.md"], setup=setup,
             allowed=["out.incomplete"],
             check=all_of(absent("out"), absent("out.partial"), absent("out.incomplete/params.yaml"),
                          absent("out.incomplete/report.md"), incomplete_report)),
        Case("output/early-failure-leaves-nothing", ["fit", "{ds}", "-o", "{w}/out"] + TINY_FIT +
             ["--set", "solver.gradient_tolerance=1e-300"], expect="fail", fragments=["stage warp"],
             check=all_of(absent("out"), absent("out.partial"), absent("out.incomplete"))),
    ]


def all_cases():
    return (fabric_value_cases() + fabric_structure_cases() + dataset_folder_cases() + run_path_cases() +
            csv_cases() + params_cases() + simulate_cases() + other_command_cases() + config_cases() + output_cases() +
            late_failure_cases())


# ------------------------------------------------------------------------------------------
# Running

def snapshot(root):
    """path -> (kind, size, content hash) of everything under root (symlinks not followed)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = os.path.join(dirpath, name)
            st = os.lstat(p)
            rel = os.path.relpath(p, root)
            if stat.S_ISREG(st.st_mode):
                with open(p, "rb") as f:
                    out[rel] = ("file", st.st_size, hashlib.sha1(f.read()).hexdigest())
            elif stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p), "")
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir", 0, "")
            else:
                out[rel] = ("special", 0, "")
    return out


def limit_memory():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_CAP_BYTES, MEMORY_CAP_BYTES))


def asan_memory_cap(asan_options):
    """ASAN_OPTIONS that put the memory cap on a program built with AddressSanitizer, which
    reserves terabytes of address space for its shadow memory at start, so RLIMIT_AS cannot apply.
    ASan's allocator applies the cap instead: one allocation or a resident size past it fails
    (returns null, so `new` throws) as it would under RLIMIT_AS."""
    cap_mb = MEMORY_CAP_BYTES // 1024**2
    cap = f"max_allocation_size_mb={cap_mb}:soft_rss_limit_mb={cap_mb}:allocator_may_return_null=1"
    return f"{asan_options}:{cap}" if asan_options else cap


def run_case(case, twill, scratch, keep, asan):
    case_dir = tempfile.mkdtemp(prefix="case-", dir=scratch)
    work = os.path.join(case_dir, "work")
    os.makedirs(work)
    (case.setup or dataset_setup())(work)
    # The outer folder holds a sentinel: anything escaping `work` lands next to it and shows.
    before = snapshot(case_dir)
    argv = [a.replace("{ds}", os.path.join(work, "ds")).replace("{w}", work) for a in case.argv]
    env = dict(os.environ, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    if asan:
        env["ASAN_OPTIONS"] = asan_memory_cap(env.get("ASAN_OPTIONS", ""))
    problems = []
    start = time.time()
    try:
        p = subprocess.run([twill] + argv, cwd=work, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, timeout=TIMEOUT_S, preexec_fn=None if asan else limit_memory,
                           env=env)
        status, output = p.returncode, p.stdout.decode("utf-8", "replace")
    except subprocess.TimeoutExpired:
        status, output = None, ""
        problems.append(f"hang: no answer in {TIMEOUT_S} s")
    elapsed = time.time() - start
    if status is not None:
        if status < 0:
            problems.append(f"crash: signal {-status}")
        elif status not in (0, 1, 2):
            problems.append(f"unexpected exit status {status}")
        elif case.expect == "accept" and status != 0:
            problems.append(f"expected acceptance, got status {status}")
        elif case.expect == "reject" and status != 2:
            problems.append(f"expected rejection (status 2), got {status}")
        elif case.expect == "fail" and status != 1:
            problems.append(f"expected a failure (status 1), got {status}")
        if case.expect in ("reject", "fail"):
            for fragment in case.fragments:
                if fragment not in output:
                    problems.append(f"message lacks '{fragment}'")
        if len(output) > MAX_OUTPUT_BYTES:
            problems.append(f"output of {len(output)} bytes (echoes input?)")
        for raw in RAW_ERRORS:
            if raw in output:
                problems.append(f"raw library message '{raw}'")
        for report in SANITIZER_REPORTS:
            if report in output:
                problems.append(f"sanitizer report '{report}'")
    # Restore permissions a case took away before looking (and cleaning up).
    for dirpath, dirnames, _ in os.walk(case_dir):
        for d in dirnames:
            os.chmod(os.path.join(dirpath, d), 0o755)
    after = snapshot(case_dir)
    allowed = [os.path.join("work", a.rstrip("/")) for a in case.allowed]
    def is_allowed(rel):
        return any(rel == a or rel.startswith(a + os.sep) for a in allowed)
    for rel in sorted(set(before) | set(after)):
        if before.get(rel) != after.get(rel) and not is_allowed(rel):
            what = "created" if rel not in before else "deleted" if rel not in after else "changed"
            problems.append(f"{what} outside the allowed output: {rel}")
            if len(problems) > 12:
                break
    if case.check and status is not None:
        problems += case.check(work)
    if not keep:
        shutil.rmtree(case_dir, ignore_errors=True)
    return problems, elapsed, output


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--twill", required=True, help="the twill binary")
    parser.add_argument("--only", default="", help="run only cases whose name contains this")
    parser.add_argument("--keep", action="store_true", help="keep the scratch folders")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")
    parser.add_argument("--asan", action="store_true",
                        help="twill is built with AddressSanitizer: cap memory through ASan, not RLIMIT_AS")
    parser.add_argument("--jobs", type=int, default=2, help="cases run at the same time (default 2)")
    args = parser.parse_args()
    cases = [c for c in all_cases() if args.only in c.name]
    names = [c.name for c in cases]
    assert len(names) == len(set(names)), "case names must be unique"
    if args.list:
        for c in cases:
            print(f"{c.expect:7s} {c.name}")
        return 0
    twill = os.path.abspath(args.twill)
    is_root = os.geteuid() == 0
    scratch = tempfile.mkdtemp(prefix="twill-corpus-")
    start = time.time()
    failed, skipped = [], []
    try:
        runnable = []
        for case in cases:
            if case.needs_non_root and is_root:
                skipped.append(case.name)  # root writes anywhere: permissions cannot be tested
            else:
                runnable.append(case)
        with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
            results = pool.map(lambda c: (c, run_case(c, twill, scratch, args.keep, args.asan)), runnable)
            for case, (problems, elapsed, output) in results:
                if problems:
                    failed.append(case.name)
                    print(f"FAIL {case.name} ({elapsed:.2f} s)")
                    for p in problems:
                        print(f"     - {p}")
                    print("     output: " + output[:600].replace("\n", "\n             "))
    finally:
        if not args.keep:
            shutil.rmtree(scratch, ignore_errors=True)
    ran = len(cases) - len(skipped)
    print(f"reliability corpus: {ran - len(failed)} of {ran} cases pass "
          f"({sum(c.expect == 'reject' for c in cases)} rejections, {sum(c.expect == 'accept' for c in cases)} "
          f"acceptances, {sum(c.expect == 'fail' for c in cases)} failing fits; {len(skipped)} skipped as root: {', '.join(skipped) or 'none'}) in {time.time() - start:.1f} s")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
