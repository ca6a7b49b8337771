"""An example bwbench problem plug-in: y = a·exp(−b·t) fitted to two made-up decays.

Found through the entry-point group ``bwbench.problems`` (see ``pyproject.toml``: the entry point's
name, "toy-decay", is the problem's name), so a study TOML with ``[study] problem = "toy-decay"``
runs it with every backend, in spawned workers and on Dask too: each process loads this module from
the installed package, nothing is sent from the study's process but the task's name and settings.

A problem plug-in provides two things (``bwbench.problems.base`` says what each member means):

- a ``Problem``: ``param_names``, ``lower``/``upper`` (physical bounds), ``dim``, ``n_data``, ``info``,
  ``from_unit``/``to_unit`` (the unit box ↔ physical units) and ``loss_batch`` (one loss per row,
  +inf where the model blows up, never NaN, never an exception);
- a ``ProblemType`` subclass instance, ``PROBLEM_TYPE``: its ``name``, the loss's unit, which
  ``[study]`` keys and tables it reads, ``configure`` (a study TOML → ``ProblemSetup``: JSON-able
  settings and the specimens) and ``make_problem`` (settings, specimen → ``Problem``, in a worker);
  optionally ``run_metrics`` (stored with each run) and the report's parts (``report_sections``...).

The module must import without side effects beyond defining these: a worker imports it to run one
task. Settings and ``SpecimenEntry.meta`` travel to the workers, so they must be plain JSON values.
"""

from __future__ import annotations

import numpy as np

from bwbench.problems import ProblemSetup, ProblemType, SpecimenEntry


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
        if isinstance(noise, bool) or not isinstance(noise, (int, float)) or not 0 <= noise < float("inf"):
            fail("[study] noise_mV must be a finite non-negative number")
        entries = (
            SpecimenEntry("decay-1", "made-up", {"a": 2.0, "b": 0.7}),
            SpecimenEntry("decay-2", "made-up", {"a": 5.0, "b": 1.9}),
        )
        return ProblemSetup(
            settings={"noise_mV": noise},
            study_json={"problem": self.name, "noise_mV": noise},
            specimens_json={"files": [e.name for e in entries]},
            specimens=entries,
            available={e.name: e for e in entries},
        )

    def make_problem(self, settings, entry):
        t = np.linspace(0.0, 4.0, 80)
        rng = np.random.default_rng(len(entry.name))  # fixed data: every worker builds the same set
        y = entry.meta["a"] * np.exp(-entry.meta["b"] * t) + rng.normal(0.0, settings["noise_mV"], t.size)
        return DecayProblem(t, y, entry.name)

    def run_metrics(self, problem, result) -> dict:
        return {"a_error": abs(result.params["a"] - problem.y[0])}

    def report_sections(self, report) -> None:
        report.doc.h(2, "Decay constants")
        report.doc.p(f"Best backend: {report.best_backend}; a toy section added by the problem itself.")


PROBLEM_TYPE = Decay()
