"""A sweep of hostile inputs through the real command line, one process per case, as a user would meet
them: named pipes, devices, huge files, numbers that would plan or run "forever", boxes that overflow or
blow up everywhere, a full disk, edited data, files a glob would misread.

Each case must end with the exit status it states (2 where it refuses), one line ``error: ...`` on a
refusal, no traceback anywhere, and every input file byte-identical afterwards. The timeout turns a
hang into a failure; it is generous and no speed requirement. The output-onto-input cases of every
output flag are ``tests/system/test_outputs_never_inputs.py``.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from bwbench import cli

REPO = Path(__file__).resolve().parents[2]
NAME = "pom-mt24u01_0.01MPa_r1.csv"
HANG = 300  # s: a hang detector only
RUNAWAY = {
    "n+": [9.0, 10.75],
    "n-": [4.5, 5.0],
    "gamma+": [-7.5, -7.0],
    "beta+": [0.1, 0.2],
    "gamma-": [-5.0, -4.5],
    "beta-": [0.001, 0.002],
}


def toml(**study) -> str:
    lines = {"name": '"t"', "seed": 1, "budget": 20, "seeds": 1, **study}
    return (
        "[study]\n"
        + "".join(f"{k} = {v}\n" for k, v in lines.items())
        + f'[specimens]\nfiles = ["{NAME}"]\n[optimizers]\nrandom = {{}}\n'
    )


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
        "time_s,displacement_mm,force_N\n" + "".join(f"{t:.6f},{x:.6f},{v:.4f}\n" for (t, x, v) in map(f, rows))
    )
    write("ms.csv", lambda r: (r[0] * 1000, r[1], r[2]))
    write("zero.csv", lambda r: (r[0], r[1], 0.0))
    shutil.copy(lab / NAME, lab / "run[1].csv")
    truth = next(
        s["truth"]
        for s in json.loads((REPO / "data" / "specimens" / "manifest.json").read_text())["specimens"]
        if s["file"] == NAME
    )
    (lab / "p.json").write_text(json.dumps(truth))
    (lab / "wide.json").write_text(json.dumps({"xi+": [-1e308, 1e308]}))
    (lab / "runaway.json").write_text(json.dumps(RUNAWAY))
    (lab / "seeds.toml").write_text(toml(seeds=1_000_000_000))
    (lab / "budget.toml").write_text(toml(budget=9223372036854775807))
    (lab / "wide.toml").write_text(toml(formulation='"paper"') + '[bounds]\n"xi+" = [-1e308, 1e308]\n')
    os.mkfifo(lab / "fifo.csv")
    os.mkfifo(lab / "fifo.png")
    with open(lab / "huge.csv", "wb") as fh:
        fh.truncate(300 * 2**20)  # sparse: no disk used
    edited = lab / "edited"
    edited.mkdir()
    shutil.copy(lab / NAME, edited / NAME)
    cwd = os.getcwd()
    assert (
        cli.main(["fit", str(lab / NAME), "--optimizer", "random", "--budget", "20", "--out", str(lab / "r0.json")])
        == 0
    )  # a fit result for predict
    os.chdir(edited)
    try:
        assert (
            cli.main(
                [
                    "compare",
                    "--specimens",
                    NAME,
                    "--optimizers",
                    "random",
                    "--seeds",
                    "1",
                    "--budget",
                    "20",
                    "--workers",
                    "1",
                ]
            )
            == 0
        )
    finally:
        os.chdir(cwd)
    text = (edited / NAME).read_text().splitlines()
    text[5] = text[5].rsplit(",", 1)[0] + ",99.5"  # one force value
    (edited / NAME).write_text("\n".join(text) + "\n")
    third_sweep(lab, lines)
    return lab


def third_sweep(lab: Path, lines: list) -> None:
    """The third sweep's files: signal columns gone wrong (dead, flipped, in ms), absurd force, CR line
    ends, fit results and a study database edited by hand, a dataset folder holding a user's files."""
    header = lines[0].split(",")
    rows = [[float(c) for c in line.split(",")] for line in lines[1:]]
    j = {name: header.index(name) for name in header}

    def variant(name, change):
        out = [list(r) for r in rows]
        for r in out:
            change(r)
        (lab / name).write_text(",".join(header) + "\n" + "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in out))

    variant("dead_v.csv", lambda r: r.__setitem__(j["velocity_mm_s"], 0.0))
    variant("flipped_v.csv", lambda r: r.__setitem__(j["velocity_mm_s"], -r[j["velocity_mm_s"]]))
    variant("ms_v.csv", lambda r: r.__setitem__(j["time_s"], 1000 * r[j["time_s"]]))
    variant("huge_f.csv", lambda r: r.__setitem__(j["force_N"], 1e300 * (1 + r[j["force_N"]])))
    (lab / "cr.csv").write_text((lab / NAME).read_text().replace("\n", "\r"))
    (lab / "same.csv").symlink_to(lab / NAME)
    fit = json.loads((lab / "r0.json").read_text())
    for name, edit in {
        "units_list": ("units", ["N"]),
        "excitation": ("excitation", "chirp"),
        "n_negative": ("params", {**fit["params"], "n-": -3}),
        "not_finite": ("params", {**fit["params"], "eta+": None}),
    }.items():
        (lab / f"{name}.json").write_text(json.dumps({**fit, edit[0]: edit[1]}))
    for name, sql in {
        "bad_params": "UPDATE runs SET params_json = '{not json'",
        "bad_mse": "UPDATE runs SET mse = 'abc'",
        "bad_config": "UPDATE study SET value = '{broken' WHERE key = 'config_json'",
    }.items():
        shutil.copy(lab / "edited" / "study.sqlite", lab / f"{name}.sqlite")
        with sqlite3.connect(lab / f"{name}.sqlite") as conn:
            conn.execute(sql)
    (lab / "mine").mkdir()
    (lab / "mine" / "manifest.json").write_text('{"mine": true}\n')


COMPARE = ["compare", "--specimens", NAME, "--optimizers", "random", "--seeds", "1", "--budget", "20", "--workers", "1"]
FIT = ["fit", NAME, "--optimizer", "random", "--budget", "20", "--out", "r.json"]
# the paper's parameter names (xi+, gamma+, ...) in a bounds file: the lab's copy of a specimen is not the
# paper's (no manifest), so its default is the identifiable formulation
PAPER = ["--formulation", "paper"]
# (id, argv, exit status, a fragment of stdout+stderr; extra environment)
CASES = [
    ("data check: a FIFO", ["data", "check", "fifo.csv"], 2, "named pipe (FIFO)"),
    ("data check: /dev/zero", ["data", "check", "/dev/zero"], 2, "character device"),
    ("data check: 300 MiB", ["data", "check", "huge.csv"], 2, "above the limit of 256 MiB"),
    ("data check: time in ms", ["data", "check", "ms.csv"], 0, "is time_s in milliseconds?"),
    ("data check: zero force", ["data", "check", "zero.csv"], 0, "force_N is 0 in every row"),
    (
        "simulate: params a FIFO",
        ["simulate", "--params", "fifo.csv", "--specimen", NAME, "--out", "o.csv"],
        2,
        "named pipe",
    ),
    (
        "simulate: a full disk",
        ["simulate", "--params", "p.json", "--specimen", NAME, "--out", "/dev/full"],
        2,
        "cannot write /dev/full: No space left on device",
    ),
    ("evaluate: specimen a FIFO", ["evaluate", "--params", "p.json", "--specimen", "fifo.csv"], 2, "named pipe"),
    ("fit: specimen a FIFO", ["fit", "fifo.csv", "--optimizer", "random", "--out", "r.json"], 2, "named pipe"),
    ("fit: bounds /dev/zero", [*FIT, "--bounds", "/dev/zero"], 2, "character device"),
    ("fit: box width overflows", [*FIT, *PAPER, "--bounds", "wide.json"], 2, "overflows to infinity"),
    ("fit: box blows up", [*FIT, *PAPER, "--bounds", "runaway.json"], 2, "blows up (force not finite) at every one"),
    (
        "fit: budget 2^63-1",
        ["fit", NAME, "--optimizer", "random", "--budget", "9223372036854775807", "--out", "r.json"],
        2,
        "BWBENCH_MAX_BUDGET=",
    ),
    (
        "fit: a full disk",
        ["fit", NAME, "--optimizer", "random", "--budget", "20", "--out", "/dev/full"],
        2,
        "cannot write /dev/full: No space left on device",
    ),
    (
        "fit: --out a FIFO nothing reads",
        ["fit", NAME, "--optimizer", "random", "--budget", "20", "--out", "fifo.csv"],
        2,
        "a named pipe (FIFO) that nothing reads",
    ),
    ("fit: --plot a FIFO nothing reads", [*FIT, "--plot", "fifo.png"], 2, "a named pipe (FIFO) that nothing reads"),
    (
        "simulate: --out a FIFO nothing reads",
        ["simulate", "--params", "p.json", "--specimen", NAME, "--out", "fifo.csv"],
        2,
        "a named pipe (FIFO) that nothing reads",
    ),
    (
        "compare: --csv a FIFO nothing reads",
        [*COMPARE, "--db", "f.sqlite", "--csv", "fifo.csv"],
        2,
        "a named pipe (FIFO) that nothing reads",
    ),
    (
        "report: --out a file",
        ["report", "--db", "edited/study.sqlite", "--data", ".", "--out", "p.json"],
        2,
        "is a file, not a folder",
    ),
    ("data generate: --out a file", ["data", "generate", "--out", "p.json"], 2, "is a file, not a folder"),
    ("fit: 0 threads", [*FIT, "--threads", "0"], 2, "--threads must be 1 to"),
    ("fit: 999 threads", [*FIT, "--threads", "999"], 2, "--threads must be 1 to"),
    ("compare: specimen a FIFO", ["compare", "--specimens", "fifo.csv", "--optimizers", "random"], 2, "named pipe"),
    ("compare: config a FIFO", ["compare", "--config", "fifo.csv"], 2, "named pipe"),
    ("compare: db a FIFO", [*COMPARE, "--db", "fifo.csv"], 2, "named pipe (FIFO), not a study database"),
    ("compare: 10^9 seeds", [*COMPARE[:6], "1000000000", *COMPARE[7:]], 2, "BWBENCH_MAX_SEEDS="),
    ("compare: 10^9 seeds in a TOML", ["compare", "--config", "seeds.toml"], 2, "BWBENCH_MAX_SEEDS="),
    ("compare: budget 2^63-1 in a TOML", ["compare", "--config", "budget.toml"], 2, "BWBENCH_MAX_BUDGET="),
    (
        "compare: 240,000 runs",
        [
            "compare",
            "--specimens",
            NAME,
            "ms.csv",
            "--optimizers",
            "random,cmaes,de,pso,anneal,firefly",
            "--seeds",
            "10000",
            "--formulation",
            "paper,identifiable",
        ],
        2,
        "BWBENCH_MAX_RUNS=",
    ),
    ("compare: 500 workers", [*COMPARE[:-2], "--workers", "500", "--db", "w.sqlite"], 2, "BWBENCH_MAX_WORKERS="),
    ("compare: box width overflows in a TOML", ["compare", "--config", "wide.toml"], 2, "overflows to infinity"),
    ("compare: box blows up", [*COMPARE, *PAPER, "--bounds", "runaway.json", "--db", "b.sqlite"], 2, "blows up"),
    (
        "compare: a limit that is not a number",
        [*COMPARE, "--db", "x.sqlite"],
        2,
        "BWBENCH_MAX_SEEDS='many'",
        {"BWBENCH_MAX_SEEDS": "many"},
    ),
    (
        "compare: an existing run[1].csv",
        [
            "compare",
            "--specimens",
            "run[1].csv",
            "--optimizers",
            "random",
            "--seeds",
            "1",
            "--budget",
            "20",
            "--workers",
            "1",
            "--db",
            "g.sqlite",
        ],
        0,
        "1/1 runs",
    ),
    ("report: db a FIFO", ["report", "--db", "fifo.csv", "--out", "rep"], 2, "named pipe (FIFO), not a study database"),
    (
        "report: a specimen edited since the study",
        ["report", "--db", "edited/study.sqlite", "--out", "rep"],
        2,
        "changed since the study ran (SHA-256 differs)",
    ),
    (
        "identifiability: zero force, --json",
        ["identifiability", "zero.csv", "--params", "p.json", "--formulation", "identifiable", "--json"],
        2,
        "force_N is 0 in every row",
    ),
    ("identifiability: params a FIFO", ["identifiability", NAME, "--params", "fifo.csv"], 2, "named pipe"),
    ("predict: --fit a FIFO", ["predict", "--fit", "fifo.csv", NAME], 2, "named pipe"),
    ("predict: --fit a parameter file", ["predict", "--fit", "p.json", NAME], 2, "not a fit result"),
    ("predict: data a FIFO", ["predict", "--fit", "r0.json", "fifo.csv"], 2, "named pipe"),
    (
        "predict: --plot a FIFO nothing reads",
        ["predict", "--fit", "r0.json", NAME, "--plot", "fifo.png"],
        2,
        "a named pipe (FIFO) that nothing reads",
    ),
    (
        "evaluate: a fit result and another model",
        ["evaluate", "--params", "r0.json", "--specimen", NAME, "--model", "spencer"],
        2,
        "--model spencer does not match",
    ),
    (
        "fit: --fix-mass a word",
        [*FIT, "--formulation", "identifiable", "--fix-mass", "heavy"],
        2,
        "--fix-mass must be 'auto', 'fit' or a mass",
    ),
    (
        "fit: --fix-mass in the paper formulation",
        [*FIT, *PAPER, "--fix-mass", "0"],
        2,
        "--fix-mass applies to the identifiable",
    ),
    (
        "compare: --validate a training file",
        [*COMPARE, "--validate", NAME, "--db", "v.sqlite"],
        2,
        "is also a training specimen",
    ),
    ("compare: --validate a FIFO", [*COMPARE, "--validate", "fifo.csv", "--db", "v.sqlite"], 2, "named pipe"),
    # -- the third sweep (dead channels, interrupts, hand-edited files, flags, identity, the environment)
    (
        "fit: a dead velocity channel",
        ["fit", "dead_v.csv", "--optimizer", "random", "--budget", "20", "--out", "r.json"],
        2,
        "dead_v.csv: column velocity_mm_s is 0 in every row",
    ),
    (
        "fit: a dead velocity channel, Spencer",
        ["fit", "dead_v.csv", "--model", "spencer", "--optimizer", "random", "--budget", "5", "--out", "r.json"],
        2,
        "a dead channel",
    ),
    (
        "fit: a dead channel in a joint fit",
        ["fit", NAME, "dead_v.csv", "--optimizer", "random", "--budget", "5", "--out", "r.json"],
        2,
        "dead_v.csv: column velocity_mm_s",
    ),
    (
        "identifiability: a dead velocity channel",
        ["identifiability", "dead_v.csv", "--params", "p.json"],
        2,
        "dead_v.csv: column velocity_mm_s is 0",
    ),
    (
        "compare: a dead velocity channel",
        [
            "compare",
            "--specimens",
            "dead_v.csv",
            "--optimizers",
            "random",
            "--seeds",
            "1",
            "--budget",
            "20",
            "--workers",
            "1",
            "--db",
            "d.sqlite",
        ],
        2,
        "dead_v.csv: column velocity_mm_s is 0",
    ),
    ("predict: a dead velocity channel", ["predict", "--fit", "r0.json", "dead_v.csv"], 2, "a dead channel"),
    ("data check: a dead velocity channel", ["data", "check", "dead_v.csv"], 0, "a dead channel"),
    (
        "fit: zero force",
        ["fit", "zero.csv", "--optimizer", "random", "--budget", "5", "--out", "r.json"],
        2,
        "force_N is 0 in every row",
    ),
    (
        "fit: a force of 1e300 N",
        ["fit", "huge_f.csv", "--optimizer", "random", "--budget", "5", "--out", "r.json"],
        2,
        "no test machine records that",
    ),
    ("fit: a velocity of the opposite sign", [*FIT[:1], "flipped_v.csv", *FIT[2:]], 0, "the opposite sign convention"),
    ("data check: time in ms with a velocity", ["data", "check", "ms_v.csv"], 0, "time_s in milliseconds"),
    ("data check: CR-only line ends", ["data", "check", "cr.csv"], 2, "carriage return (CR) only"),
    (
        "fit: one file twice through a symlink",
        ["fit", NAME, "same.csv", "--optimizer", "random", "--budget", "5", "--out", "r.json"],
        2,
        "a specimen is named twice",
    ),
    (
        "fit: one file twice as ./",
        ["fit", NAME, f"./{NAME}", "--optimizer", "random", "--budget", "5", "--out", "r.json"],
        2,
        "a specimen is named twice",
    ),
    (
        "fit: --fix-mass with Spencer",
        [*FIT, "--model", "spencer", "--fix-mass", "0"],
        2,
        "--fix-mass does not apply to model 'spencer'",
    ),
    ("fit: --offsets with Spencer", [*FIT, "--model", "spencer", "--offsets", "branch"], 2, "--offsets applies to"),
    ("fit: --model ''", [*FIT, "--model", ""], 2, "--model must be a model name"),
    (
        "compare: --fix-mass with Spencer",
        [*COMPARE, "--model", "spencer", "--fix-mass", "0", "--db", "m.sqlite"],
        2,
        "--fix-mass applies to the identifiable formulation of a model with a mass term",
    ),
    (
        "compare: --offsets with Spencer",
        [*COMPARE, "--model", "spencer", "--offsets", "continuous", "--db", "m.sqlite"],
        2,
        "--offsets applies to the identifiable formulation",
    ),
    ("predict: units a list", ["predict", "--fit", "units_list.json", NAME], 2, '"units" is a JSON list'),
    (
        "predict: an unknown excitation",
        ["predict", "--fit", "excitation.json", NAME],
        2,
        "excitation.json: \"excitation\" is 'chirp'",
    ),
    ("predict: n- = -3", ["predict", "--fit", "n_negative.json", NAME], 2, "params.n- is -3"),
    ("predict: a parameter null", ["predict", "--fit", "not_finite.json", NAME], 2, "params.eta+ is nan"),
    (
        "compare --csv: params_json edited",
        [*COMPARE, "--db", "bad_params.sqlite", "--csv", "o.csv"],
        2,
        "column params_json: not JSON",
    ),
    (
        "compare --csv: mse edited",
        [*COMPARE, "--db", "bad_mse.sqlite", "--csv", "o.csv"],
        2,
        "column mse: 'abc' is not a number",
    ),
    (
        "report: config_json edited",
        ["report", "--db", "bad_config.sqlite", "--out", "rep"],
        2,
        "key config_json: not JSON",
    ),
    (
        "data generate: --out a folder with a manifest",
        ["data", "generate", "--out", "mine"],
        2,
        "holds manifest.json, which this command would replace",
    ),
    ("NUMBA_NUM_THREADS=0", ["models"], 2, "NUMBA_NUM_THREADS='0' in the environment", {"NUMBA_NUM_THREADS": "0"}),
    ("OMP_NUM_THREADS=lots", [*FIT], 2, "OMP_NUM_THREADS='lots'", {"OMP_NUM_THREADS": "lots"}),
    (
        "identifiability: a billion grid points",
        ["identifiability", NAME, "--params", "p.json", "--grid", "1000000000"],
        2,
        "--grid must be 2 to 1000",
    ),
]


def snapshot(folder: Path) -> dict:
    """Every regular file's bytes (the sparse 300 MiB file by size only)."""
    return {
        p: (p.stat().st_size if p.name == "huge.csv" else p.read_bytes())
        for p in folder.rglob("*")
        if p.is_file() and not p.is_symlink()
    }


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_a_hostile_input_ends_as_stated_with_no_traceback_and_every_input_unchanged(lab, case):
    name, argv, status, fragment, *env = case
    before = snapshot(lab)
    process = subprocess.run(
        [sys.executable, "-m", "bwbench.cli", *argv],
        cwd=lab,
        capture_output=True,
        text=True,
        timeout=HANG,
        stdin=subprocess.DEVNULL,
        env={**os.environ, **(env[0] if env else {})},
    )
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


def test_ctrl_c_ends_a_fit_with_one_line_exit_130_and_nothing_written(lab):
    """SIGINT once the fit runs: one line, exit 130, no result file, no traceback."""
    before = snapshot(lab)
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "bwbench.cli",
            "fit",
            NAME,
            "--optimizer",
            "random",
            "--budget",
            "1000000",
            "--out",
            "interrupted.json",
        ],
        cwd=lab,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        stdin=subprocess.DEVNULL,
        env={**os.environ, "BWBENCH_MAX_BUDGET": "1000000"},
    )
    child = psutil.Process(process.pid)
    # into the evaluations: 4 s of CPU is past the imports and the set-up, and a million evaluations
    # take far more (HANG bounds the wait: a hang detector, no speed is asserted)
    waited = 0.0
    while sum(child.cpu_times()[:2]) < 4.0 and process.poll() is None and waited < HANG:
        time.sleep(0.1)
        waited += 0.1
    assert process.poll() is None, "the fit ended before it could be interrupted"
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=HANG)
    assert process.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines() == ["interrupted: bwbench fit stopped (Ctrl-C); no output is left half-written"]
    assert not (lab / "interrupted.json").exists()
    assert snapshot(lab) == before
