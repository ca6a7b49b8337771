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
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from bwbench.data.strict_json import finite_or_null
from bwbench.engine.result import Result
from bwbench.problems.hysteresis.model_problem import start_settings

# Two normalisations of the RMSE: by the largest force magnitude (bwbench's ``nrmse``, symmetric in the
# sign of F) and by the largest force (``nrmse_max_F``), the one the MR-damper literature reports (e.g.
# per-test fits of Spencer's model); they differ where the compression peak exceeds the tension peak.
NRMSE_DEFINITIONS = {
    "nrmse": "RMSE / max|F measured| (bwbench's)",
    "nrmse_max_F": "RMSE / max F measured (the MR-damper literature's)",
}
# Units of the result JSON's own numbers (the parameters' units come from the problem).
METRIC_UNITS = {
    "mse": "N²",
    "f_err": "N² (−MSE, the paper's eq 6)",
    "rmse_N": "N",
    "nrmse": "– (RMSE / max|F measured|)",
    "nrmse_max_F": "– (RMSE / max F measured, the literature's)",
    "box_probe_s": "s",
    "inputs.size_bytes": "bytes",
    "nfev": "evaluations (one evaluation = one simulation of every file)",
    "budget": "evaluations",
    "wall_s": "s",
    "trace.nfev": "evaluations",
    "trace.mse": "N²",
    "energy_per_cycle_Nmm": "N·mm",
    "files.n": "samples",
    "files.weight": "– (share of the loss)",
    "files.mse": "N²",
    "files.rmse_N": "N",
    "files.nrmse": "–",
    "files.nrmse_max_F": "–",
    "bounds": "the unit of each parameter",
}


@dataclass(frozen=True, eq=False)
class FitResult:
    """One fit of one or several specimens: what ``bwbench.fit`` returns.

    Made by ``run_fit``. Its first numbers (``params``, ``mse``, ``rmse_N``, ``nfev``, ``units``) are
    the backend's result's; ``findings`` is everything it says beside them.

    Parameters
    ----------
    result : bwbench.engine.result.Result
        The backend's result: params by name in physical units, mse in N², nfev, trace, ...
    problem : object
        What was fitted (a model problem or a joint problem of several files).
    files : tuple of dict, default ()
        Per file: specimen, n, weight, mse (N²), rmse_N (N), nrmse (–), nrmse_max_F (–).
    checks : bwbench.problems.hysteresis.fit_checks.FitChecks or None, default None
        The checks of the fit.
    extra : dict, default {}
        More entries for the result JSON (the search box, its file).
    budget : int or None, default None
        The evaluations asked for (``nfev`` may be fewer: an early stop).
    synthetic : bool, default False
        The files are a manifest's synthetic specimens (the wording of a check).

    Examples
    --------
    >>> fit = bwbench.fit("mytest.csv", model="spencer")
    >>> fit.ok, fit.rmse_N
    >>> fit.summary()
    >>> print(fit.report())
    >>> fit.save("fit.json")
    """

    result: Result
    problem: Any  # the fitted problem (a model_problem or joint_problem object)
    files: tuple = ()
    checks: Any = None  # bwbench.problems.hysteresis.fit_checks.FitChecks
    extra: dict = field(default_factory=dict)  # more entries for the JSON (the search box, its file)
    budget: int | None = None  # the evaluations asked for (``nfev`` may be fewer: an early stop)
    synthetic: bool = False  # the files are a manifest's synthetic specimens (the wording of a check)

    # -- the numbers a notebook asks for first --------------------------------------------------
    @property
    def params(self) -> dict:
        """The best parameters by name, in physical units (``units``).

        Returns
        -------
        dict of str to float
        """
        return self.result.params

    @property
    def mse(self) -> float:
        """The best loss: the mean squared force error (N²), weighted over the files.

        Returns
        -------
        float
            +inf when no evaluation gave a finite loss.
        """
        return self.result.mse

    @property
    def rmse_N(self) -> float:
        """The root of the best loss (N).

        Returns
        -------
        float
        """
        return self.result.rmse_N

    @property
    def nfev(self) -> int:
        """The evaluations spent (one evaluation = one simulation of every file).

        Returns
        -------
        int
        """
        return self.result.nfev

    @property
    def units(self) -> dict:
        """The unit of every parameter, by name.

        Returns
        -------
        dict of str to str
        """
        return self.result.units

    @property
    def success(self) -> bool:
        """Whether some evaluation gave a finite loss (see ``ok`` for whether the fit is any good).

        Returns
        -------
        bool
        """
        return math.isfinite(self.result.mse)

    @property
    def ok(self) -> bool:
        """Whether the fit did not fail.

        Returns
        -------
        bool
            True for a finite loss and, on every file, a fit closer to the data than the best constant
            force; ``failure`` says why when it is False.
        """
        return not any(f.severity == "failure" for f in self.findings)

    @property
    def failure(self) -> str | None:
        """Why the fit failed.

        Returns
        -------
        str or None
            Its ``failure`` findings, joined by "; "; None when it did not fail.
        """
        reasons = [f.text for f in self.findings if f.severity == "failure"]
        return "; ".join(reasons) if reasons else None

    @cached_property
    def findings(self) -> list:
        """Everything the fit says beside its numbers.

        Returns
        -------
        list of bwbench.problems.hysteresis.findings.Finding
            (severity, text): what ``bwbench fit`` prints and ``bwbench.fit`` issues as
            ``FitWarning`` subclasses.

        Examples
        --------
        >>> [f.line for f in bwbench.fit("mytest.csv").findings]
        """
        from bwbench.problems.hysteresis.findings import fit_findings

        return fit_findings(self)

    @property
    def model(self):
        """The fitted model of this fit, every coefficient as stored.

        Returns
        -------
        FittedModel
            ``.predict(file)``, ``.simulate(file)``, ``.force(signal)``.
        """
        from bwbench.problems.hysteresis.fitted_model import FittedModel

        p = self.problem
        if hasattr(p, "laws_json"):  # one model across the control range: its laws with it
            from bwbench.problems.hysteresis.control.fitted import of_problem

            return of_problem(p, dict(self.result.params))
        initial_state, warmup_s = start_settings(p)
        return FittedModel(
            p.model.name,
            p.formulation,
            dict(self.result.params),
            p.state,
            p.excitation,
            dict(self.result.units),
            initial_state,
            warmup_s,
        )

    def predict(self, specimen, refit_offset: bool = False):
        """The force on another test, nothing refitted: ``model.predict(specimen)``.

        Parameters
        ----------
        specimen : str, pathlib.Path, Specimen or pandas.DataFrame
            A specimen CSV's path, a ``Specimen`` or a DataFrame with the file's columns.
        refit_offset : bool, default False
            Re-solve the constant force on that test (``FittedModel.predict``).

        Returns
        -------
        Prediction
            RMSE (N), NRMSE, the measured and predicted forces.

        Examples
        --------
        >>> fit.predict("othertest.csv").rmse_N
        """
        return self.model.predict(specimen, refit_offset=refit_offset)

    def table(self):
        """The per-file errors.

        Returns
        -------
        pandas.DataFrame
            specimen, n, weight, mse (N²), rmse_N (N), nrmse (–), nrmse_max_F (–).

        Examples
        --------
        >>> bwbench.fit("a.csv", "b.csv").table()[["specimen", "rmse_N", "nrmse"]]
        """
        import pandas as pd

        return pd.DataFrame(list(self.files))

    # -- what a notebook reads next: uncertainty, notes, the figure (bwbench.problems.hysteresis.fit_summary, fit_plots) --
    @property
    def specimens(self) -> list:
        """The fitted specimens.

        Returns
        -------
        list of Specimen
            One, or a joint fit's several.
        """
        p = self.problem
        return list(p.specimens) if hasattr(p, "specimens") else [p.specimen]

    @property
    def notes(self) -> list[str]:
        """The text of every finding (``findings``).

        Returns
        -------
        list of str
            One line each.
        """
        return [f.text for f in self.findings]

    @cached_property
    def uncertainty(self):
        """The linearised covariance of the free parameters.

        Returns
        -------
        bwbench.problems.hysteresis.fit_summary.Uncertainty
        """
        from bwbench.problems.hysteresis import fit_summary

        if hasattr(self.problem, "covariance"):  # one model across a control range: its laws' coefficients
            from bwbench.problems.hysteresis.control.uncertainty import uncertainty

            return uncertainty(self.problem, self.result.params)
        return fit_summary.uncertainty(self)

    def summary(self):
        """Every parameter with its standard error, unit, role and box.

        Standard errors from the Jacobian at the optimum, the solved linear coefficients included
        through the variable-projection covariance; inf where the data do not determine a parameter.

        Returns
        -------
        pandas.DataFrame
            Indexed by parameter: value, stderr (standard error, the same unit), unit, role (searched /
            solved / held / derived), at_edge (on an edge of its box or bound), lower, upper.

        Examples
        --------
        >>> bwbench.fit("mytest.csv").summary()
        """
        from bwbench.problems.hysteresis import fit_summary

        return fit_summary.summary(self, self.uncertainty)

    def correlation(self):
        """The correlation matrix of the free (searched and solved) parameters.

        Returns
        -------
        pandas.DataFrame

        Examples
        --------
        >>> bwbench.fit("mytest.csv").correlation().round(2)
        """
        from bwbench.problems.hysteresis import fit_summary

        return fit_summary.correlation(self.uncertainty)

    def report(self, min_correlation: float = 0.1) -> str:
        """A text report like lmfit's ``fit_report``.

        Parameters
        ----------
        min_correlation : float, default 0.1
            The correlations listed are those above this.

        Returns
        -------
        str
            Data points, variables, χ², RMSE (N), NRMSE, AIC/BIC, every parameter with its standard
            error, the correlations above ``min_correlation``, the notes.

        Examples
        --------
        >>> print(bwbench.fit("mytest.csv").report())
        """
        from bwbench.problems.hysteresis import fit_summary

        return fit_summary.report(self, self.uncertainty, self.findings, min_correlation)

    def plot(self, ax=None):
        """Plot the fit: per file the loops F–x and F–v, force and residual against time, measured and fitted.

        The global backend and rcParams are left as they were.

        Parameters
        ----------
        ax : matplotlib.axes.Axes or sequence of Axes or None, default None
            Draw into it instead (one Axes: the F–x loops; four: every panel).

        Returns
        -------
        matplotlib.figure.Figure

        Examples
        --------
        >>> bwbench.fit("mytest.csv").plot().savefig("fit.png")
        """
        from bwbench.render import fit_plots

        model = self.model
        title = f"{model.describe()}: {self.result.optimizer}, {self.result.nfev} evaluations" + (
            " of every file" if len(self.files) > 1 else ""
        )
        return fit_plots.figure([model.predict(s) for s in self.specimens], title, ax)

    def __repr__(self) -> str:
        from bwbench.render import reprs

        return reprs.fit_repr(self)

    def _repr_html_(self) -> str:
        from bwbench.render import reprs

        return reprs.fit_html(self)

    # -- the result JSON ------------------------------------------------------------------------
    def to_json_dict(self) -> dict:
        """The result JSON as a dict.

        Returns
        -------
        dict
            Strict: a value that is not finite is null (None).

        Examples
        --------
        >>> bwbench.fit("mytest.csv").to_json_dict()["units"]["rmse_N"]
        'N'
        """
        return finite_or_null(self._json_values())

    def _json_values(self) -> dict:
        """The result JSON's values, a loss that is not finite still as it is (``write_json`` says why)."""
        out = self.result.to_json_dict()
        if self.problem.state is None:
            out["state"] = None  # say it: this model has no state convention
        out.update(self.extra)
        if hasattr(self.problem, "result_json") and self.success:  # one model across a control range
            out.update(self.problem.result_json(self.result.params))
        checks = dict(self.checks.json) if self.checks is not None else {}
        by_file = checks.pop("files", {})  # a joint fit's checks, per file
        out.update(checks)
        out["files"] = [{**row, **by_file.get(row["specimen"], {})} for row in self.files]
        if len(self.files) == 1:
            out["nrmse"] = self.files[0]["nrmse"]
            out["nrmse_max_F"] = self.files[0]["nrmse_max_F"]
        out["nrmse_definitions"] = dict(NRMSE_DEFINITIONS)
        out["start"] = start_json(self.problem)
        out["units"] = {**self.result.units, **METRIC_UNITS}
        from bwbench.version import __version__

        out["bwbench_version"] = __version__
        return out

    def save(self, path) -> None:
        """Write the result JSON at ``path`` (``write_json``); ``bwbench.load_fit(path)`` reads its model back.

        Parameters
        ----------
        path : str or pathlib.Path
            The JSON file to write.

        Raises
        ------
        bwbench.UserError
            As ``bwbench fit --out``: when ``path`` is one of the fit's inputs by any spelling, or
            cannot be written.

        Examples
        --------
        >>> bwbench.fit("mytest.csv").save("fit.json")
        """
        from bwbench.data.output_paths import check_outputs, writing
        from bwbench.errors import UserError

        if not isinstance(path, (str, Path)) or not str(path).strip():
            raise UserError(f"FitResult.save needs a file path, got {path!r}")
        check_outputs({"--out": path}, self.inputs())
        with writing(path):
            self.write_json(path)

    def inputs(self) -> list:
        """The files this fit read.

        Returns
        -------
        list
            Each specimen's path, then the bounds file (None when there is none).
        """
        parts = getattr(self.problem, "parts", None) or [self.problem]
        return [*(p.specimen.path for p in parts), self.extra.get("bounds_file")]

    def write_json(self, path) -> None:
        """Write ``to_json_dict`` to ``path`` as strict JSON.

        Null, never NaN or Infinity, and ``"not_finite"`` saying why (a fit that never found a finite
        loss).

        Parameters
        ----------
        path : str or pathlib.Path
            The JSON file to write.
        """
        from bwbench.data import strict_json

        strict_json.write(path, self._json_values(), why=self.result.not_finite_reasons())


def start_json(problem) -> dict:
    """The result JSON's "start": the rule as asked and, per file, what it resolved to.

    Each file's as ``bwbench.models.start.Start.to_json`` writes it.
    """
    parts = getattr(problem, "parts", None)
    if not parts:
        return problem.start.to_json()
    initial_state, warmup_s = start_settings(problem)
    first = parts[0].start.to_json()
    return {
        "initial_state": initial_state,
        "warmup_s": warmup_s,
        "rule": first["rule"],
        "files": {p.specimen.name: p.start.to_json() for p in parts},
        "units": first["units"],
    }


def per_file(problem, result: Result) -> tuple:
    """Each file's errors at the best parameters of ``result``.

    Parameters
    ----------
    problem : object
        The fitted problem (one specimen, or a joint problem of several).
    result : bwbench.engine.result.Result
        The backend's result.

    Returns
    -------
    tuple of dict
        Per file (see ``FitResult.files``), with both NRMSEs (``NRMSE_DEFINITIONS``).
    """
    if hasattr(problem, "per_file"):
        params = np.array([result.params.get(n, np.nan) for n in problem.param_names])
        scored = [p.f_loss for p in problem.parts]  # the force after each file's warm-up
        if np.all(np.isfinite(params)):
            rows = list(problem.per_file(params))
        else:
            rows = [
                {
                    "specimen": p.specimen.name,
                    "n": p.n_data,
                    "weight": float(w),
                    "mse": math.inf,
                    "rmse_N": math.inf,
                    "nrmse": math.inf,
                }
                for p, w in zip(problem.parts, problem.file_weight)
            ]
        return tuple({**row, "nrmse_max_F": _over_max_force(row["rmse_N"], f)} for row, f in zip(rows, scored))
    peak = float(np.max(np.abs(problem.f_loss)))
    return (
        {
            "specimen": problem.specimen.name,
            "n": problem.n_data,
            "weight": 1.0,
            "mse": result.mse,
            "rmse_N": result.rmse_N,
            "nrmse": result.rmse_N / peak if peak > 0 else math.inf,
            "nrmse_max_F": _over_max_force(result.rmse_N, problem.f_loss),
        },
    )


def nrmse_text(nrmse: float, nrmse_max_F: float, digits: int = 4) -> str:
    """The NRMSE of one record in words.

    RMSE/max F (the literature's) first where the force has a positive peak, else RMSE/max|F| alone,
    defined for any sign of force (a record whose force is all negative).
    """
    if nrmse_max_F is None or not math.isfinite(nrmse_max_F):
        return f"NRMSE {nrmse:.{digits}g} (RMSE/max|F|; the force is never positive, so RMSE/max F is undefined)"
    return f"NRMSE {nrmse_max_F:.{digits}g} (RMSE/max F, the literature's; {nrmse:.{digits}g} RMSE/max|F|)"


def _over_max_force(rmse: float, f) -> float:
    peak = float(np.max(np.asarray(f, dtype=float)))
    return rmse / peak if peak > 0 else math.inf


def provenance(specimens, bounds=None, argv=None) -> dict:
    """What the result JSON records of its inputs.

    Parameters
    ----------
    specimens : iterable of str or pathlib.Path
        The specimen files.
    bounds : str or pathlib.Path or None, default None
        The bounds file, if any.
    argv : list of str or None, default None
        The command line that made it (default ``sys.argv``).

    Returns
    -------
    dict
        ``inputs``: each file's role ("specimen" or "bounds"), path (absolute), size (bytes) and
        SHA-256 (of its bytes: ``sha256sum`` gives the same); ``command_line``.

    Examples
    --------
    >>> provenance(["mytest.csv"], argv=["bwbench", "fit", "mytest.csv"])["command_line"]
    'bwbench fit mytest.csv'
    """
    import hashlib
    import shlex
    import sys
    from pathlib import Path

    inputs = []
    for role, path in [("specimen", p) for p in specimens] + ([("bounds", bounds)] if bounds else []):
        p = Path(path)
        data = p.read_bytes()
        inputs.append(
            {
                "role": role,
                "path": str(p.resolve()),
                "size_bytes": len(data),
                "sha256": hashlib.sha256(data).hexdigest(),
            }
        )
    argv = sys.argv if argv is None else argv
    return {"inputs": inputs, "command_line": " ".join(shlex.quote(str(a)) for a in argv)}


# Local searches that must end at the same optimum before ``bwbench fit`` stops early (``stop="agreed"``).
AGREEING_SEARCHES = 3


def run_fit(
    problem,
    optimizer: str,
    budget: int,
    seed,
    options: dict | None = None,
    synthetic: bool = False,
    extra: dict | None = None,
    stop: str = "budget",
) -> FitResult:
    """Fit a problem with a backend (``fitting.run``), then its per-file errors and checks.

    Parameters
    ----------
    problem : object
        The problem (one specimen, or a ``JointProblem`` of several).
    optimizer : str
        The backend's name.
    budget : int
        At most this many evaluations.
    seed : int
        The run's seed.
    options : dict or None, default None
        The backend's options.
    synthetic : bool, default False
        The data are the manifest's synthetic specimens (changes the wording of a check).
    extra : dict or None, default None
        More entries for the result JSON.
    stop : str, default "budget"
        "budget" spends the whole budget (a study's rule); "agreed" lets a backend with a
        ``stop_agree`` option (lsq-trf) stop once ``AGREEING_SEARCHES`` of its independent local
        searches ended at the same optimum, unless ``options`` set it.

    Returns
    -------
    FitResult

    Raises
    ------
    bwbench.UserError
        For a bad option or seed.
    ValueError
        For a ``stop`` other than "budget" or "agreed".

    Examples
    --------
    >>> from bwbench.problems.hysteresis.setup import setup_fit
    >>> setup = setup_fit(["mytest.csv"], model="spencer")
    >>> run_fit(setup.problem, "lsq-trf", 4100, seed=0, stop="agreed").rmse_N
    """
    from bwbench.engine import fitting, registry

    if stop not in ("budget", "agreed"):
        raise ValueError(f"stop must be 'budget' or 'agreed', got {stop!r}")
    options = dict(options or {})
    if stop == "agreed" and "stop_agree" in registry.get(optimizer).options and not options.get("stop_agree"):
        options["stop_agree"] = AGREEING_SEARCHES
    result = fitting.run(problem, optimizer, budget, seed, options)
    from bwbench.problems.hysteresis.edges import widen

    result, widened = widen(problem, result, optimizer, budget, seed, options)  # a box too small, on the rest
    checks = problem.fit_checks(result, synthetic) if hasattr(problem, "fit_checks") else None
    if checks is not None:
        checks.notes[:0] = widened
    box = {name: [float(lo), float(hi)] for name, lo, hi in zip(problem.param_names, problem.lower, problem.upper)}
    return FitResult(
        result, problem, per_file(problem, result), checks, {**(extra or {}), "bounds": box}, budget, synthetic
    )
