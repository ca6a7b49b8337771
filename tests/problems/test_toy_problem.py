"""A third problem is one module: a toy ``ProblemType`` registered from this test runs through
``bwbench compare`` and ``bwbench report`` with nothing else changed."""

from __future__ import annotations

import re
import sqlite3
from contextlib import closing
from pathlib import Path

import numpy as np

from bwbench import problems
from bwbench.cli import main
from bwbench.problems.base import ProblemSetup, ProblemType, SpecimenEntry


class DecayProblem:
    """Fit y = a·exp(−b·t) to one data set: two parameters, loss = MSE (mV²)."""

    param_names = ("a", "b")
    lower = np.array([0.1, 0.01])
    upper = np.array([10.0, 5.0])
    dim = 2

    def __init__(self, t, y, name):
        self.t, self.y = t, y
        self.info = {"specimen": name}

    @property
    def n_data(self) -> int:
        return self.t.size

    def from_unit(self, U):
        return self.lower + np.asarray(U, dtype=float) * (self.upper - self.lower)

    def to_unit(self, P):
        return (np.asarray(P, dtype=float) - self.lower) / (self.upper - self.lower)

    def loss_batch(self, P):
        P = np.atleast_2d(P)
        model = P[:, :1] * np.exp(-P[:, 1:] * self.t[None, :])
        return np.mean((model - self.y[None, :]) ** 2, axis=1)


class Decay(ProblemType):
    name = "toy-decay"
    description = "a toy: y = a·exp(−b·t) fitted to two made-up decays (loss: MSE in mV²)"
    loss_unit = "mV²"
    residual_unit = "mV"
    study_keys = ("noise_mV",)
    tables = ()

    def configure(self, fail, study, document, base_dir, data_override=None) -> ProblemSetup:
        noise = study.get("noise_mV", 0.01)
        if not isinstance(noise, (int, float)) or noise < 0:
            fail("[study] noise_mV must be a non-negative number")
        entries = (SpecimenEntry("decay-1", "made-up", {"a": 2.0, "b": 0.7}),
                   SpecimenEntry("decay-2", "made-up", {"a": 5.0, "b": 1.9}))
        return ProblemSetup(settings={"noise_mV": noise}, study_json={"problem": self.name, "noise_mV": noise},
                            specimens_json={"files": [e.name for e in entries]}, specimens=entries,
                            available={e.name: e for e in entries})

    def make_problem(self, settings, entry):
        t = np.linspace(0.0, 4.0, 80)
        rng = np.random.default_rng(len(entry.name))
        y = entry.meta["a"] * np.exp(-entry.meta["b"] * t) + rng.normal(0.0, settings["noise_mV"], t.size)
        return DecayProblem(t, y, entry.name)

    def run_metrics(self, problem, result) -> dict:
        return {"a_error": abs(result.params["a"] - problem.y[0])}

    def report_sections(self, report) -> None:
        report.doc.h(2, "Decay constants")
        report.doc.p(f"Best backend: {report.best_backend}; a toy section added by the problem itself.")


def test_a_toy_problem_runs_through_compare_and_report(tmp_path, capsys):
    problems.register(Decay())
    config = tmp_path / "toy.toml"
    config.write_text("""
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
""", encoding="utf-8")
    db = tmp_path / "toy.sqlite"
    assert main(["compare", "--config", str(config), "--db", str(db), "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "median RMSE (mV)" in out
    with closing(sqlite3.connect(db)) as conn:
        rows = conn.execute("SELECT problem, specimen, status, params_json, metrics_json, material FROM runs").fetchall()
    assert len(rows) == 2 * 3 * 2 and {r[0] for r in rows} == {"toy-decay"} and {r[2] for r in rows} == {"ok"}
    assert all('"a":' in r[3] and '"a_error":' in r[4] and r[5] is None for r in rows)

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
