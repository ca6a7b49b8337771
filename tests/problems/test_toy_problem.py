"""A third problem is one module: the toy ``ProblemType`` of the example plug-in package
(examples/problem_plugin), registered from this test, runs through ``bwbench compare`` and
``bwbench report`` with nothing else changed. Installed as a package it also runs in spawned workers
and on Dask (tests/system/test_plugin_packages.py); registered in this process only, a study with more
workers is refused before anything runs."""

from __future__ import annotations

import importlib.util
import re
import sqlite3
from contextlib import closing
from pathlib import Path

import pytest

from bwbench import problems
from bwbench.cli import main

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "problem_plugin" / "bwbench_toy_problem.py"
TOML = """
[study]
name = "toy"
problem = "toy-decay"
seed = 5
budget = 120
seeds = 2
noise_mV = 0.02

[optimizers]
random = {}
cmaes = {}
nlopt-bobyqa = {}
"""


@pytest.fixture(scope="module")
def registered():
    """The example's problem type, registered in this process only (its package is not installed here)."""
    spec = importlib.util.spec_from_file_location("bwbench_toy_problem_example", EXAMPLE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return problems.register(module.PROBLEM_TYPE)


def test_a_toy_problem_runs_through_compare_and_report(registered, tmp_path, capsys):
    config = tmp_path / "toy.toml"
    config.write_text(TOML, encoding="utf-8")
    db = tmp_path / "toy.sqlite"
    assert main(["compare", "--config", str(config), "--db", str(db), "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "median RMSE (mV)" in out
    with closing(sqlite3.connect(db)) as conn:
        rows = conn.execute(
            "SELECT problem, specimen, status, params_json, metrics_json, meta_json FROM runs"
        ).fetchall()
    assert len(rows) == 2 * 3 * 2 and {r[0] for r in rows} == {"toy-decay"} and {r[2] for r in rows} == {"ok"}
    assert all('"a":' in r[3] and '"a_error":' in r[4] and r[5] == "{}" for r in rows)  # no specimen facts

    assert main(["report", "--db", str(db), "--out", str(tmp_path / "report")]) == 0
    md = (tmp_path / "report" / "report.md").read_text(encoding="utf-8")
    assert "# Optimiser comparison: toy" in md and "## Decay constants" in md and "SYNTHETIC" not in md
    assert re.search(r"\*\*Use (cmaes|nlopt-bobyqa)\*\* at a budget of 120 evaluations", md)
    assert "median RMSE (mV)" in md and "Friedman test" in md
    for name in ("convergence", "ecdf", "waterfall"):
        assert (tmp_path / "report" / f"{name}.png").is_file()
    # the problem's own noise floor is unknown: no floor line, and no invented values
    assert "noise floor" not in (tmp_path / "report" / "convergence.csv").read_text()
    assert Path(tmp_path / "report" / "report.html").stat().st_size > 10_000


@pytest.mark.parametrize("where", [["--workers", "2"], ["--scheduler", "tcp://127.0.0.1:9"]], ids=["workers", "dask"])
def test_a_problem_registered_in_this_process_only_is_refused_with_other_processes(registered, tmp_path, capsys, where):
    """Spawned or Dask workers cannot see it: one line naming the fix, before any database is made
    (it used to lose every run with "unknown problem 'toy-decay'" and retry them on every rerun)."""
    assert not problems.only_in_this_process("switched-bouc-wen")
    assert problems.only_in_this_process("toy-decay")
    config = tmp_path / "toy.toml"
    config.write_text(TOML, encoding="utf-8")
    db = tmp_path / "toy.sqlite"
    assert main(["compare", "--config", str(config), "--db", str(db), *where]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: problem 'toy-decay' is registered in this process only (register()), so ")
    assert "install it as a plug-in package (entry-point group 'bwbench.problems'" in err
    assert "run the study in this process (--workers 1)" in err and len(err.splitlines()) == 1
    assert not db.exists()
