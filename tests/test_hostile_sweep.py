"""A sweep of hostile inputs through the real command line, one process per case, as a user would meet
them: named pipes, devices, huge files, numbers that would plan or run "forever", boxes that overflow or
blow up everywhere, a full disk, edited data, files a glob would misread.

Each case must end with the exit status it states (2 where it refuses), one line ``error: ...`` on a
refusal, no traceback anywhere, and every input file byte-identical afterwards. The timeout turns a
hang into a failure; it is generous and no speed requirement. The output-onto-input cases of every
output flag are ``tests/test_outputs_never_inputs.py``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from bwbench import cli

REPO = Path(__file__).resolve().parents[1]
NAME = "pom-mt24u01_0.01MPa_r1.csv"
HANG = 300  # s: a hang detector only
RUNAWAY = {"n+": [9.0, 10.75], "n-": [4.5, 5.0], "gamma+": [-7.5, -7.0], "beta+": [0.1, 0.2],
           "gamma-": [-5.0, -4.5], "beta-": [0.001, 0.002]}


def toml(**study) -> str:
    lines = {"name": '"t"', "seed": 1, "budget": 20, "seeds": 1, **study}
    return ("[study]\n" + "".join(f"{k} = {v}\n" for k, v in lines.items())
            + f'[specimens]\nfiles = ["{NAME}"]\n[optimizers]\nrandom = {{}}\n')


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """Specimens (good, in ms, zero force, named like a glob), parameters, boxes, TOMLs, a FIFO, a
    sparse 300 MiB file, and a finished study whose specimen was edited afterwards."""
    lab = tmp_path_factory.mktemp("hostile")
    shutil.copy(REPO / "data" / "specimens" / NAME, lab / NAME)
    lines = (lab / NAME).read_text().splitlines()
    # Time, displacement and force only (the shipped files also log the velocity; a unit trap needs only these).
    columns = [lines[0].split(",").index(c) for c in ("time_s", "displacement_mm", "force_N")]
    rows = [[float(line.split(",")[j]) for j in columns] for line in lines[1:]]
    write = lambda name, f: (lab / name).write_text(  # noqa: E731
        "time_s,displacement_mm,force_N\n" + "".join(f"{t:.6f},{x:.6f},{v:.4f}\n" for (t, x, v) in map(f, rows)))
    write("ms.csv", lambda r: (r[0] * 1000, r[1], r[2]))
    write("zero.csv", lambda r: (r[0], r[1], 0.0))
    shutil.copy(lab / NAME, lab / "run[1].csv")
    truth = next(s["truth"] for s in json.loads((REPO / "data" / "specimens" / "manifest.json").read_text())["specimens"]
                 if s["file"] == NAME)
    (lab / "p.json").write_text(json.dumps(truth))
    (lab / "wide.json").write_text(json.dumps({"xi+": [-1e308, 1e308]}))
    (lab / "runaway.json").write_text(json.dumps(RUNAWAY))
    (lab / "seeds.toml").write_text(toml(seeds=1_000_000_000))
    (lab / "budget.toml").write_text(toml(budget=9223372036854775807))
    (lab / "wide.toml").write_text(toml() + '[bounds]\n"xi+" = [-1e308, 1e308]\n')
    os.mkfifo(lab / "fifo.csv")
    os.mkfifo(lab / "fifo.png")
    with open(lab / "huge.csv", "wb") as fh:
        fh.truncate(300 * 2**20)  # sparse: no disk used
    edited = lab / "edited"
    edited.mkdir()
    shutil.copy(lab / NAME, edited / NAME)
    cwd = os.getcwd()
    assert cli.main(["fit", str(lab / NAME), "--optimizer", "random", "--budget", "20", "--out",
                     str(lab / "r0.json")]) == 0  # a fit result for predict
    os.chdir(edited)
    try:
        assert cli.main(["compare", "--specimens", NAME, "--optimizers", "random", "--seeds", "1", "--budget", "20",
                         "--workers", "1"]) == 0
    finally:
        os.chdir(cwd)
    text = (edited / NAME).read_text().splitlines()
    text[5] = text[5].rsplit(",", 1)[0] + ",99.5"  # one force value
    (edited / NAME).write_text("\n".join(text) + "\n")
    return lab


COMPARE = ["compare", "--specimens", NAME, "--optimizers", "random", "--seeds", "1", "--budget", "20", "--workers", "1"]
FIT = ["fit", NAME, "--optimizer", "random", "--budget", "20", "--out", "r.json"]
# (id, argv, exit status, a fragment of stdout+stderr; extra environment)
CASES = [
    ("data check: a FIFO", ["data", "check", "fifo.csv"], 2, "named pipe (FIFO)"),
    ("data check: /dev/zero", ["data", "check", "/dev/zero"], 2, "character device"),
    ("data check: 300 MiB", ["data", "check", "huge.csv"], 2, "above the limit of 256 MiB"),
    ("data check: time in ms", ["data", "check", "ms.csv"], 0, "is time_s in milliseconds?"),
    ("data check: zero force", ["data", "check", "zero.csv"], 0, "force_N is 0 in every row"),
    ("simulate: params a FIFO", ["simulate", "--params", "fifo.csv", "--specimen", NAME, "--out", "o.csv"], 2,
     "named pipe"),
    ("simulate: a full disk", ["simulate", "--params", "p.json", "--specimen", NAME, "--out", "/dev/full"], 2,
     "cannot write /dev/full: No space left on device"),
    ("evaluate: specimen a FIFO", ["evaluate", "--params", "p.json", "--specimen", "fifo.csv"], 2, "named pipe"),
    ("fit: specimen a FIFO", ["fit", "fifo.csv", "--optimizer", "random", "--out", "r.json"], 2, "named pipe"),
    ("fit: bounds /dev/zero", [*FIT, "--bounds", "/dev/zero"], 2, "character device"),
    ("fit: box width overflows", [*FIT, "--bounds", "wide.json"], 2, "overflows to infinity"),
    ("fit: box blows up", [*FIT, "--bounds", "runaway.json"], 2, "blows up (force not finite) at every one"),
    ("fit: budget 2^63-1", ["fit", NAME, "--optimizer", "random", "--budget", "9223372036854775807", "--out", "r.json"],
     2, "BWBENCH_MAX_BUDGET="),
    ("fit: a full disk", ["fit", NAME, "--optimizer", "random", "--budget", "20", "--out", "/dev/full"], 2,
     "cannot write /dev/full: No space left on device"),
    ("fit: --out a FIFO nothing reads", ["fit", NAME, "--optimizer", "random", "--budget", "20", "--out", "fifo.csv"],
     2, "a named pipe (FIFO) that nothing reads"),
    ("fit: --plot a FIFO nothing reads", [*FIT, "--plot", "fifo.png"], 2, "a named pipe (FIFO) that nothing reads"),
    ("simulate: --out a FIFO nothing reads", ["simulate", "--params", "p.json", "--specimen", NAME, "--out",
                                              "fifo.csv"], 2, "a named pipe (FIFO) that nothing reads"),
    ("compare: --csv a FIFO nothing reads", [*COMPARE, "--db", "f.sqlite", "--csv", "fifo.csv"], 2,
     "a named pipe (FIFO) that nothing reads"),
    ("report: --out a file", ["report", "--db", "edited/study.sqlite", "--data", ".", "--out", "p.json"], 2,
     "is a file, not a folder"),
    ("data generate: --out a file", ["data", "generate", "--out", "p.json"], 2, "is a file, not a folder"),
    ("fit: 0 threads", [*FIT, "--threads", "0"], 2, "--threads must be 1 to"),
    ("fit: 999 threads", [*FIT, "--threads", "999"], 2, "--threads must be 1 to"),
    ("compare: specimen a FIFO", ["compare", "--specimens", "fifo.csv", "--optimizers", "random"], 2, "named pipe"),
    ("compare: config a FIFO", ["compare", "--config", "fifo.csv"], 2, "named pipe"),
    ("compare: db a FIFO", [*COMPARE, "--db", "fifo.csv"], 2, "named pipe (FIFO), not a study database"),
    ("compare: 10^9 seeds", [*COMPARE[:6], "1000000000", *COMPARE[7:]], 2, "BWBENCH_MAX_SEEDS="),
    ("compare: 10^9 seeds in a TOML", ["compare", "--config", "seeds.toml"], 2, "BWBENCH_MAX_SEEDS="),
    ("compare: budget 2^63-1 in a TOML", ["compare", "--config", "budget.toml"], 2, "BWBENCH_MAX_BUDGET="),
    ("compare: 240,000 runs", ["compare", "--specimens", NAME, "ms.csv", "--optimizers",
                               "random,cmaes,de,pso,anneal,firefly", "--seeds", "10000", "--formulation",
                               "paper,identifiable"], 2, "BWBENCH_MAX_RUNS="),
    ("compare: 500 workers", [*COMPARE[:-2], "--workers", "500", "--db", "w.sqlite"], 2, "BWBENCH_MAX_WORKERS="),
    ("compare: box width overflows in a TOML", ["compare", "--config", "wide.toml"], 2, "overflows to infinity"),
    ("compare: box blows up", [*COMPARE, "--bounds", "runaway.json", "--db", "b.sqlite"], 2, "blows up"),
    ("compare: a limit that is not a number", [*COMPARE, "--db", "x.sqlite"], 2, "BWBENCH_MAX_SEEDS='many'",
     {"BWBENCH_MAX_SEEDS": "many"}),
    ("compare: an existing run[1].csv", ["compare", "--specimens", "run[1].csv", "--optimizers", "random",
                                         "--seeds", "1", "--budget", "20", "--workers", "1", "--db", "g.sqlite"], 0,
     "1/1 runs"),
    ("report: db a FIFO", ["report", "--db", "fifo.csv", "--out", "rep"], 2, "named pipe (FIFO), not a study database"),
    ("report: a specimen edited since the study", ["report", "--db", "edited/study.sqlite", "--out", "rep"], 2,
     "changed since the study ran (SHA-256 differs)"),
    ("identifiability: zero force, --json", ["identifiability", "zero.csv", "--params", "p.json", "--formulation",
                                             "identifiable", "--json"], 2, "force_N is 0 in every row"),
    ("identifiability: params a FIFO", ["identifiability", NAME, "--params", "fifo.csv"], 2, "named pipe"),
    ("predict: --fit a FIFO", ["predict", "--fit", "fifo.csv", NAME], 2, "named pipe"),
    ("predict: --fit a parameter file", ["predict", "--fit", "p.json", NAME], 2, "not a fit result"),
    ("predict: data a FIFO", ["predict", "--fit", "r0.json", "fifo.csv"], 2, "named pipe"),
    ("predict: --plot a FIFO nothing reads", ["predict", "--fit", "r0.json", NAME, "--plot", "fifo.png"], 2,
     "a named pipe (FIFO) that nothing reads"),
    ("evaluate: a fit result and another model", ["evaluate", "--params", "r0.json", "--specimen", NAME, "--model",
                                                  "spencer"], 2, "--model spencer does not match"),
    ("fit: --fix-mass a word", [*FIT, "--formulation", "identifiable", "--fix-mass", "heavy"], 2,
     "--fix-mass must be 'auto', 'fit' or a mass"),
    ("fit: --fix-mass in the paper formulation", [*FIT, "--fix-mass", "0"], 2, "--fix-mass applies to the identifiable"),
    ("compare: --validate a training file", [*COMPARE, "--validate", NAME, "--db", "v.sqlite"], 2,
     "is also a training specimen"),
    ("compare: --validate a FIFO", [*COMPARE, "--validate", "fifo.csv", "--db", "v.sqlite"], 2, "named pipe"),
    ("identifiability: a billion grid points", ["identifiability", NAME, "--params", "p.json", "--grid",
                                                "1000000000"], 2, "--grid must be 2 to 1000"),
]


def snapshot(folder: Path) -> dict:
    """Every regular file's bytes (the sparse 300 MiB file by size only)."""
    return {p: (p.stat().st_size if p.name == "huge.csv" else p.read_bytes())
            for p in folder.rglob("*") if p.is_file() and not p.is_symlink()}


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_a_hostile_input_ends_as_stated_with_no_traceback_and_every_input_unchanged(lab, case):
    name, argv, status, fragment, *env = case
    before = snapshot(lab)
    process = subprocess.run([sys.executable, "-m", "bwbench.cli", *argv], cwd=lab, capture_output=True, text=True,
                             timeout=HANG, stdin=subprocess.DEVNULL, env={**os.environ, **(env[0] if env else {})})
    output = process.stdout + process.stderr
    assert "Traceback" not in output, output
    assert process.returncode == status, output
    assert fragment in output, output
    if status == 2:
        lines = process.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: "), process.stderr
    after = snapshot(lab)
    assert {p: v for p, v in after.items() if p in before} == before  # every input byte-identical
    if status == 2:
        assert set(after) == set(before)  # a refusal writes nothing
