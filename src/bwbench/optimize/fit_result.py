"""A fit of one or several specimens, as ``bwbench fit`` writes it and ``bwbench.fit`` returns it.

``run_fit(problem, ...)`` runs one backend on a problem (one specimen, or a ``JointProblem`` of
several) and returns a ``FitResult``: the backend's ``Result``, each file's errors at the best
parameters, the checks of the fit, and the ``FittedModel`` that predicts other tests with every
coefficient as stored. ``FitResult.write_json`` is the result JSON: everything needed to simulate
the model again (model, formulation, state, excitation, every parameter) and a unit for every
number (``units``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bwbench.optimize.result import Result, finite_or_null

# Units of the result JSON's own numbers (the parameters' units come from the problem).
METRIC_UNITS = {
    "mse": "N²", "f_err": "N² (−MSE, the paper's eq 6)", "rmse_N": "N", "nrmse": "– (RMSE / max|F measured|)",
    "nfev": "evaluations (one evaluation = one simulation of every file)", "budget": "evaluations",
    "wall_s": "s", "trace.nfev": "evaluations", "trace.mse": "N²", "energy_per_cycle_Nmm": "N·mm",
    "files.n": "samples", "files.weight": "– (share of the loss)", "files.mse": "N²", "files.rmse_N": "N",
    "files.nrmse": "–", "bounds": "the unit of each parameter",
}


@dataclass(frozen=True, eq=False)
class FitResult:
    """One fit: ``result`` (the backend's ``Result``: params by name in physical units, mse in N²,
    nfev, trace, ...), ``files`` (per file: specimen, n, weight, mse N², rmse_N N, nrmse –),
    ``checks`` (``fit_checks.FitChecks`` or None), ``problem`` (what was fitted)."""

    result: Result
    problem: Any  # the fitted problem (a model_problem or joint_problem object)
    files: tuple = ()
    checks: Any = None  # bwbench.problems.fit_checks.FitChecks
    extra: dict = field(default_factory=dict)  # more entries for the JSON (the search box, its file)

    # -- the numbers a notebook asks for first --------------------------------------------------
    @property
    def params(self) -> dict:
        return self.result.params

    @property
    def mse(self) -> float:
        return self.result.mse

    @property
    def rmse_N(self) -> float:
        return self.result.rmse_N

    @property
    def nfev(self) -> int:
        return self.result.nfev

    @property
    def units(self) -> dict:
        return self.result.units

    @property
    def success(self) -> bool:
        return math.isfinite(self.result.mse)

    @property
    def model(self):
        """The ``FittedModel`` of this fit: ``.predict(file)``, ``.simulate(file)``, ``.force(signal)``."""
        from bwbench.problems.fitted_model import FittedModel

        p = self.problem
        return FittedModel(p.model.name, p.formulation, dict(self.result.params), p.state, p.excitation,
                           dict(self.result.units))

    def predict(self, specimen):
        """``model.predict(specimen)``: the force on another test, nothing refitted (a ``Prediction``)."""
        return self.model.predict(specimen)

    def table(self):
        """The per-file errors as a pandas DataFrame (specimen, n, weight, mse, rmse_N, nrmse)."""
        import pandas as pd

        return pd.DataFrame(list(self.files))

    def __repr__(self) -> str:
        files = ", ".join(f"{f['specimen']} {f['rmse_N']:.4g} N ({f['nrmse']:.3g})" for f in self.files)
        return (f"<FitResult {self.problem.model.name} {self.problem.formulation} by {self.result.optimizer}, "
                f"{self.result.nfev} evaluations: RMSE {files}>")

    # -- the result JSON ------------------------------------------------------------------------
    def to_json_dict(self) -> dict:
        """The result JSON (strict: a value that is not finite is null)."""
        return finite_or_null(self._json_values())

    def _json_values(self) -> dict:
        """The result JSON's values, a loss that is not finite still as it is (``write_json`` says why)."""
        out = self.result.to_json_dict()
        if self.problem.state is None:
            out["state"] = None  # say it: this model has no state convention
        out.update(self.extra)
        checks = dict(self.checks.json) if self.checks is not None else {}
        by_file = checks.pop("files", {})  # a joint fit's checks, per file
        out.update(checks)
        out["files"] = [{**row, **by_file.get(row["specimen"], {})} for row in self.files]
        if len(self.files) == 1:
            out["nrmse"] = self.files[0]["nrmse"]
        out["units"] = {**self.result.units, **METRIC_UNITS}
        from bwbench.version import __version__

        out["bwbench_version"] = __version__
        return out

    def save(self, path) -> None:
        """The result JSON at ``path`` (``write_json``); ``bwbench.load_fit(path)`` reads its model back.
        ``UserError`` (as ``bwbench fit --out``) when ``path`` is one of the fit's inputs by any spelling,
        or cannot be written."""
        from bwbench.data.output_paths import check_outputs, writing
        from bwbench.errors import UserError

        if not isinstance(path, (str, Path)) or not str(path).strip():
            raise UserError(f"FitResult.save needs a file path, got {path!r}")
        check_outputs({"--out": path}, self.inputs())
        with writing(path):
            self.write_json(path)

    def inputs(self) -> list:
        """The files this fit read: each specimen's path and the bounds file, if any."""
        parts = getattr(self.problem, "parts", None) or [self.problem]
        return [*(p.specimen.path for p in parts), self.extra.get("bounds_file")]

    def write_json(self, path) -> None:
        """``to_json_dict`` written to ``path`` as strict JSON: null, never NaN or Infinity, and
        ``"not_finite"`` saying why (a fit that never found a finite loss)."""
        from bwbench.data import strict_json

        strict_json.write(path, self._json_values(), why=self.result.not_finite_reasons())


def per_file(problem, result: Result) -> tuple:
    """Each file's errors at the best parameters of ``result`` (see ``FitResult.files``)."""
    if hasattr(problem, "per_file"):
        params = np.array([result.params.get(n, np.nan) for n in problem.param_names])
        if np.all(np.isfinite(params)):
            return tuple(problem.per_file(params))
        names = [p.specimen.name for p in problem.parts]
        return tuple({"specimen": n, "n": p.n_data, "weight": float(w), "mse": math.inf, "rmse_N": math.inf,
                      "nrmse": math.inf} for n, p, w in zip(names, problem.parts, problem.file_weight))
    peak = float(np.max(np.abs(problem.specimen.f)))
    return ({"specimen": problem.specimen.name, "n": problem.n_data, "weight": 1.0, "mse": result.mse,
             "rmse_N": result.rmse_N, "nrmse": result.rmse_N / peak if peak > 0 else math.inf},)


def run_fit(problem, optimizer: str, budget: int, seed, options: dict | None = None,
            synthetic: bool = False, extra: dict | None = None) -> FitResult:
    """Fit ``problem`` with backend ``optimizer`` on exactly ``budget`` evaluations (``fitting.run``),
    then its per-file errors and checks. ``synthetic``: the data are the manifest's synthetic
    specimens (changes the wording of a check). Raises ``UserError`` for a bad option or seed."""
    from bwbench.optimize import fitting

    result = fitting.run(problem, optimizer, budget, seed, options)
    checks = problem.fit_checks(result, synthetic) if hasattr(problem, "fit_checks") else None
    box = {name: [float(lo), float(hi)] for name, lo, hi in zip(problem.param_names, problem.lower, problem.upper)}
    return FitResult(result, problem, per_file(problem, result), checks, {**(extra or {}), "bounds": box})
