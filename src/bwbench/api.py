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
        options: dict | None = None, threads: int = 1, stop: str = "agreed", workers: int = 1) -> FitResult:
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
    ``stop``: "agreed" (a backend that restarts local searches, lsq-trf, may stop before the budget
    once 3 of them ended at the same optimum; ``nfev`` and the result's message say so) or "budget"
    (spend it all, as a study does). ``workers``: threads for the files of a joint fit, else for the
    points of a batch; the result is the same as with one.

    Returns a ``FitResult`` (``.params``, ``.rmse_N``, ``.table()``, ``.model``, ``.predict(file)``,
    ``.save(path)``). Raises ``bwbench.errors.UserError`` for bad input (a file, a name, an option).
    """
    from bwbench import threads as threads_mod
    from bwbench.data import bounds as bounds_mod
    from bwbench.data import manifest
    from bwbench.data.specimen import read_specimen
    from bwbench.errors import UserError
    from bwbench.models import registry
    from bwbench.optimize.fit_result import run_fit
    from bwbench.problems.switched_vpp.formulations import bound_names, make_problem, resolve_formulation

    if not specimens:
        raise UserError("bwbench.fit needs at least one specimen file")
    chosen = registry.get(model or registry.DEFAULT)
    settings: dict = {"model": chosen.name, "formulation": resolve_formulation(chosen, formulation),
                "state": state or "shared", "excitation": excitation, "weighting": weighting}
    if fix_mass != "auto":
        settings["fix_mass"] = fix_mass
    if bounds is not None:
        names = bound_names([settings["formulation"]], settings["state"], [chosen.name])
        settings["bounds"] = (bounds_mod.read_json(bounds, names) if isinstance(bounds, (str, Path))
                              else bounds_mod.validate(dict(bounds), names, "bounds"))
    loaded = [read_specimen(s) if isinstance(s, (str, Path)) else s for s in specimens]
    synthetic = all(isinstance(s, (str, Path)) and manifest.is_synthetic(s) for s in specimens)
    workers = threads_mod.check(workers, "workers")
    with threads_mod.limited(threads_mod.check(threads)):
        problem = make_problem(loaded if len(loaded) > 1 else loaded[0], settings)
    with threads_mod.for_workers(problem, max(workers, threads)):
        return run_fit(problem, optimizer, budget, seed, options, synthetic, stop=stop)


def load_fit(path) -> FittedModel:
    """The ``FittedModel`` of a result JSON (``bwbench fit --out``, ``FitResult.save``): ``.predict(file)``
    gives a ``Prediction`` (RMSE in N, NRMSE, the forces), ``.simulate(file)`` a DataFrame."""
    return FittedModel.read(path)


def load_study(db, data_dir=None):
    """A study database (``bwbench compare``) as a ``Study``: ``.runs`` (one row per run: specimen,
    optimizer, replicate, variant, mse N², rmse_N N, nfev, every parameter by name, timings) and
    ``.traces`` (best-so-far MSE, N², against evaluations) as pandas DataFrames, ``.settings`` and
    ``.specimen_path(name)``. ``data_dir``: where the study's files are now, if they moved."""
    from bwbench.store.reader import load_study as load

    return load(db, data_dir)
