"""The Python API, for notebooks: the calls the command line is built on.

    import bwbench

    fit = bwbench.fit("a.csv", "b.csv", model="spencer", optimizer="lsq-trf", budget=4100, seed=1)
    fit.table()                    # each file's RMSE (N) and NRMSE (RMSE / max|F|)
    p = fit.predict("c.csv")       # another test, every coefficient as stored
    p.rmse_N, p.nrmse, p.frame()   # numbers, and a DataFrame of measured and predicted force
    fit.save("fit.json")           # the result JSON of `bwbench fit --out`
    model = bwbench.load_fit("fit.json")   # a FittedModel: .predict(file), .simulate(file)
    study = bwbench.load_study("study.sqlite")   # .runs and .traces as pandas DataFrames

Units are the specimen files': mm, s, N (MSE in N²).
"""

from __future__ import annotations

from pathlib import Path

from bwbench.optimize.fit_result import FitResult
from bwbench.problems.fitted_model import FittedModel, Prediction

__all__ = ["fit", "load_fit", "load_study", "FitResult", "FittedModel", "Prediction"]


def fit(*specimens, optimizer: str = "lsq-trf", budget: int = 4100, seed: int = 0, model: str | None = None,
        formulation: str | None = None, state: str | None = None, excitation: str = "measured",
        fix_mass="auto", weighting: str = "equal", bounds: dict | str | Path | None = None,
        options: dict | None = None, threads: int = 1) -> FitResult:
    """Fit one specimen, or several jointly (one parameter set for all), as ``bwbench fit`` does.

    ``specimens``: paths of specimen CSVs (or ``Specimen`` objects). ``optimizer``: a backend name
    (``bwbench optimizers``), run on exactly ``budget`` evaluations (one evaluation = one simulation
    of every file) from ``seed``. ``model``: a registered model (default: the switched Bouc-Wen);
    ``formulation``: "paper"/"direct" or "identifiable" (default: the model's own); ``state``:
    "shared"/"split" (switched model); ``excitation``: "measured" or "sine". ``fix_mass``
    (identifiable): "auto" (the inertia rule), None (always fitted) or a mass in N·s²/mm.
    ``weighting``: "equal" (each file's MSE counts the same) or "samples". ``bounds``: {name:
    (lower, upper)} or a JSON file of them; searched names set the search box, solved coefficients
    bound the linear solve. ``options``: the backend's options. ``threads``: numba/BLAS threads.

    Returns a ``FitResult`` (``.params``, ``.rmse_N``, ``.table()``, ``.model``, ``.predict(file)``,
    ``.save(path)``). Raises ``bwbench.errors.UserError`` for bad input (a file, a name, an option).
    """
    from bwbench import limits
    from bwbench import threads as threads_mod
    from bwbench.data import bounds as bounds_mod
    from bwbench.data import manifest, plausibility
    from bwbench.data.specimen import Specimen, read_specimen
    from bwbench.errors import UserError
    from bwbench.optimize import registry as backends
    from bwbench.optimize.fit_result import run_fit
    from bwbench.problems.switched_vpp.commands import check_fit_flags, checked_settings, refuse_same_file
    from bwbench.problems.switched_vpp.formulations import bound_names, make_problem

    # Every argument checked as the command line checks it, with its words, before any file is read.
    if not specimens:
        raise UserError("bwbench.fit needs at least one specimen file")
    bad = next((s for s in specimens if not isinstance(s, (str, Path, Specimen))), None)
    if bad is not None or any(isinstance(s, str) and not s.strip() for s in specimens):
        raise UserError(f"a specimen must be a path to a specimen CSV (or a Specimen), got {bad!r}")
    for name, value, low in (("--budget", budget, 1), ("--seed", seed, 0), ("--threads", threads, 1)):
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise UserError(f"{name} must be an integer ≥ {low}, got {value!r}")
    limits.check("--budget", budget, "BWBENCH_MAX_BUDGET")
    if not isinstance(optimizer, str):
        raise UserError(f"--optimizer must be a backend name (see `bwbench optimizers`), got {optimizer!r}")
    if options is not None and not isinstance(options, dict):
        raise UserError(f"options must be a dict of backend options, got {options!r}")
    backends.resolve_options(optimizer, dict(options or {}))
    settings: dict = {**checked_settings(model, formulation, state, excitation), "weighting": weighting}
    mass = _fix_mass(fix_mass)
    check_fit_flags(settings, mass, None, weighting)
    if mass != "auto":
        settings["fix_mass"] = mass
    if bounds is not None:
        names = bound_names([settings["formulation"]], settings["state"], [settings["model"]])
        if isinstance(bounds, (str, Path)):
            settings["bounds"] = bounds_mod.read_json(bounds, names)
        elif isinstance(bounds, dict):
            settings["bounds"] = bounds_mod.validate(dict(bounds), names, "bounds")
        else:
            raise UserError(f"bounds must be a dict of name -> (lower, upper) or a JSON file, got {bounds!r}")
    refuse_same_file([s.path if isinstance(s, Specimen) else s for s in specimens])
    loaded = [read_specimen(s) if isinstance(s, (str, Path)) else s for s in specimens]
    plausibility.screen(loaded)  # data check's checks: a dead channel or no force refused, the rest warned
    synthetic = all(isinstance(s, (str, Path)) and manifest.is_synthetic(s) for s in specimens)
    with threads_mod.limited(threads_mod.check(threads)):
        problem = make_problem(loaded if len(loaded) > 1 else loaded[0], settings)
        return run_fit(problem, optimizer, budget, seed, options, synthetic)


def _fix_mass(value):
    """The API's fix_mass ("auto", None or a mass ≥ 0) checked with the words of ``--fix-mass``."""
    from bwbench.problems.switched_vpp.commands import fix_mass_value

    if value == "auto" or value is None:
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        return fix_mass_value(repr(value))  # refused, naming what was given
    return fix_mass_value(str(value))


def load_fit(path) -> FittedModel:
    """The ``FittedModel`` of a result JSON (``bwbench fit --out``, ``FitResult.save``): ``.predict(file)``
    gives a ``Prediction`` (RMSE in N, NRMSE, the forces), ``.simulate(file)`` a DataFrame."""
    from bwbench.errors import UserError

    if not isinstance(path, (str, Path)):
        raise UserError(f"load_fit needs the path of a fit result JSON, got {path!r}")
    return FittedModel.read(path)


def load_study(db, data_dir=None):
    """A study database (``bwbench compare``) as a ``Study``: ``.runs`` (one row per run: specimen,
    optimizer, replicate, variant, mse N², rmse_N N, nfev, every parameter by name, timings) and
    ``.traces`` (best-so-far MSE, N², against evaluations) as pandas DataFrames, ``.settings`` and
    ``.specimen_path(name)``. ``data_dir``: where the study's files are now, if they moved."""
    from bwbench.errors import UserError
    from bwbench.store.reader import load_study as load

    for name, value in (("db", db), ("data_dir", data_dir)):
        if not (isinstance(value, (str, Path)) or (name == "data_dir" and value is None)):
            raise UserError(f"load_study: {name} must be a path, got {value!r}")
    return load(db, data_dir)
