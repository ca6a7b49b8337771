"""The Python API, for notebooks: the calls the command line is built on.

    import bwbench

    fit = bwbench.fit("a.csv", "b.csv", model="spencer", optimizer="lsq-trf", budget=4100, seed=1)
    fit.summary()                  # every parameter: value, standard error, unit, role, at its box's edge
    print(fit.report())            # like lmfit's fit_report: χ², AIC/BIC, errors, correlations, notes
    fit.plot()                     # a matplotlib Figure: loops, force and residual against time
    fit.table()                    # each file's RMSE (N) and NRMSE (RMSE / max|F|)
    p = fit.predict("c.csv")       # another test, every coefficient as stored
    p.rmse_N, p.nrmse, p.frame()   # numbers, and a DataFrame of measured and predicted force
    fit.save("fit.json")           # the result JSON of `bwbench fit --out`
    model = bwbench.load_fit("fit.json")   # a FittedModel: .predict(file), .simulate(file)
    study = bwbench.load_study("study.sqlite")   # .runs and .traces as pandas DataFrames
    study = bwbench.compare(specimens=["a.csv", "b.csv"], optimizers=["cmaes", "random"], seeds=3, budget=500)
    study.ranking(), study.recommendation, study.report("out")

Units are the specimen files': mm, s, N (MSE in N²).
"""

from __future__ import annotations

from pathlib import Path

from bwbench.api.study import Study
from bwbench.errors import UserError
from bwbench.problems.hysteresis.fit_notes import FitWarning
from bwbench.problems.hysteresis.fit_result import FitResult
from bwbench.problems.hysteresis.fitted_model import FittedModel, Prediction

__all__ = [
    "fit",
    "load_fit",
    "load_study",
    "compare",
    "FitResult",
    "FittedModel",
    "Prediction",
    "Study",
    "UserError",
    "FitWarning",
]


def fit(
    *data,
    optimizer: str = "lsq-trf",
    budget: int = 4100,
    seed: int = 0,
    model: str | None = None,
    formulation: str | None = None,
    state: str | None = None,
    excitation: str = "measured",
    fix_mass="auto",
    offsets: str | None = None,
    weighting: str = "equal",
    bounds: dict | str | Path | None = None,
    options: dict | None = None,
    threads: int = 1,
    name: str | None = None,
    stop: str = "agreed",
    workers: int = 1,
) -> FitResult:
    """Fit one test, or several jointly (one parameter set for all), as ``bwbench fit`` does.

    ``data``: one or more tests, each a specimen CSV's path, a ``Specimen`` or a pandas DataFrame with
    the file's columns (``time_s``, ``displacement_mm``, ``force_N``, optionally ``velocity_mm_s``,
    ``acceleration_mm_s2``); a list of them counts as several (``name``: a DataFrame's name, default
    its ``attrs["name"]`` or "data"). ``optimizer``: a backend name (``bwbench optimizers``), run on
    exactly ``budget`` evaluations (one evaluation = one simulation of every file) from ``seed``.
    ``model``: a registered model (default: the switched Bouc-Wen); ``formulation``: "paper"/"direct"
    or "identifiable" (default: the model's own); ``state``: "shared"/"split" (switched model);
    ``excitation``: "measured" or "sine". ``fix_mass`` (identifiable): "auto" (the inertia rule),
    None or "fit" (always fitted) or a mass in N·s²/mm; ``offsets`` (identifiable, switched model):
    "branch" or "continuous". ``weighting``: "equal" (each file's MSE counts the same) or "samples".
    ``bounds``: {name: (lower, upper)} or a JSON file of them; searched names set the search box,
    solved coefficients bound the linear solve. ``options``: the backend's options. ``threads``:
    numba/BLAS threads. ``stop``: "agreed" (a backend that restarts local searches, lsq-trf, may stop
    before the budget once its searches agree on the optimum; ``nfev`` and the result's message say
    so) or "budget" (spend it all, as a study does). ``workers``: threads for the files of a joint
    fit, else for the points of a batch; the result is the same as with one.

    Returns a ``FitResult``: ``.summary()`` (every parameter with its standard error), ``.report()``,
    ``.correlation()``, ``.plot()``, ``.params``, ``.rmse_N``, ``.table()``, ``.model``,
    ``.predict(data)``, ``.save(path)``. The notes ``bwbench fit`` prints (what the data do not
    determine, a parameter on its box's edge) are issued as ``bwbench.FitWarning`` warnings and kept
    in ``.notes``. Raises ``bwbench.UserError`` with the command line's message for bad input.
    """
    import bwbench.limits as limits
    import bwbench.threads as threads_mod
    from bwbench.api.arguments import count
    from bwbench.data import manifest, plausibility
    from bwbench.data.specimen import Specimen
    from bwbench.data.specimen_input import as_specimen
    from bwbench.optimize import registry as backends
    from bwbench.problems.hysteresis import fit_notes
    from bwbench.problems.hysteresis.fit_result import run_fit
    from bwbench.problems.hysteresis.formulations import make_problem
    from bwbench.problems.hysteresis.settings import refuse_same_file

    # Every argument checked as the command line checks it, with its words, before any file is read.
    items = [d for item in data for d in (item if isinstance(item, (list, tuple)) else [item])]
    if not items:
        raise UserError("bwbench.fit needs at least one test (a specimen CSV's path, a Specimen or a DataFrame)")
    if any(isinstance(d, (str, Path)) and not str(d).strip() for d in items):
        raise UserError("a specimen must be a path to a specimen CSV, a Specimen or a DataFrame, got ''")
    count("--budget", budget, "a positive number of evaluations")
    limits.check("--budget", budget, "BWBENCH_MAX_BUDGET")
    count("--seed", seed, "a non-negative integer", minimum=0)
    for flag, value in (("--threads", threads), ("--workers", workers)):
        count(flag, value, "an integer", minimum=-(2**63))  # the type here; the range, as the CLI says it, below
        threads_mod.check(value, flag)
    if not isinstance(optimizer, str):
        raise UserError(f"--optimizer must be a backend name (see `bwbench optimizers`), got {optimizer!r}")
    if options is not None and not isinstance(options, dict):
        raise UserError(f"options must be a dict of backend options, got {options!r}")
    if stop not in ("agreed", "budget"):
        raise UserError(f"--stop must be 'agreed' or 'budget', got {stop!r}")
    options = backends.resolve_options(optimizer, dict(options or {}))
    settings = settings_of(
        model=model,
        formulation=formulation,
        state=state,
        excitation=excitation,
        fix_mass=fix_mass,
        offsets=offsets,
        weighting=weighting,
        bounds=bounds,
    )
    refuse_same_file([d.path if isinstance(d, Specimen) else d for d in items])
    if len(items) > 1:
        from bwbench.data.input_files import refuse_same_content

        refuse_same_content([d for d in items if isinstance(d, (str, Path))])  # a copy counted twice
    loaded = [as_specimen(d, name) for d in items]
    plausibility.screen(loaded)  # data check's checks: a dead channel or no force refused, the rest warned
    synthetic = all(isinstance(d, (str, Path)) and manifest.is_synthetic(d) for d in items)
    with threads_mod.limited(threads_mod.check(threads)):
        problem = make_problem(loaded if len(loaded) > 1 else loaded[0], settings)
        if "bounds" in settings:
            from bwbench.data import bounds as bounds_mod

            bounds_mod.refuse_if_blows_up(problem, "bounds")
    with threads_mod.for_workers(problem, max(workers, threads)):
        # the bounds file is an input, as with ``fit --bounds``: ``FitResult.save`` refuses to overwrite it
        extra = {"bounds_file": str(bounds)} if isinstance(bounds, (str, Path)) else None
        result = run_fit(problem, optimizer, budget, seed, options, synthetic, extra=extra, stop=stop)
    if not result.success:
        import warnings

        warnings.warn(
            f"none of the {result.nfev} evaluations gave a finite force: the model blows up everywhere "
            "in the search box on these data (check the units: mm, N, s; and the bounds)",
            fit_notes.FitWarning,
            stacklevel=2,
        )
    fit_notes.issue(result)
    return result


def settings_of(
    *,
    model=None,
    formulation=None,
    state=None,
    excitation="measured",
    fix_mass="auto",
    offsets=None,
    weighting="equal",
    bounds=None,
) -> dict:
    """The problem settings of a fit's keywords, each checked (``UserError`` with the CLI's wording)."""
    from bwbench.data import bounds as bounds_mod
    from bwbench.problems.hysteresis.formulations import bound_names
    from bwbench.problems.hysteresis.joint_problem import WEIGHTINGS
    from bwbench.problems.hysteresis.settings import check_fit_flags, checked_settings

    settings: dict = checked_settings(model, formulation, state, excitation)
    if weighting not in WEIGHTINGS:
        raise UserError(f"--weighting must be one of {', '.join(map(repr, WEIGHTINGS))}, got {weighting!r}")
    settings["weighting"] = weighting
    mass = _fix_mass(fix_mass)
    check_fit_flags(settings, mass, offsets, weighting)
    if mass != "auto":
        settings["fix_mass"] = mass
    if offsets is not None:
        settings["offsets"] = offsets
    if bounds is not None:
        names = bound_names([settings["formulation"]], settings["state"], [settings["model"]])
        if isinstance(bounds, (str, Path)):
            settings["bounds"] = bounds_mod.read_json(bounds, names)
        elif isinstance(bounds, dict):
            settings["bounds"] = bounds_mod.validate(dict(bounds), names, "bounds")
        else:
            raise UserError(f"bounds must be a dict of name -> (lower, upper) or a JSON file, got {bounds!r}")
    return settings


def _fix_mass(value):
    """The API's fix_mass ("auto", None or a mass ≥ 0) checked with the words of ``--fix-mass``."""
    from bwbench.problems.hysteresis.settings import fix_mass_value

    if value == "auto" or value is None:
        return value
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        return fix_mass_value(repr(value))  # refused, naming what was given
    return fix_mass_value(str(value))


def load_fit(path) -> FittedModel:
    """The ``FittedModel`` of a result JSON (``bwbench fit --out``, ``FitResult.save``): ``.predict(file)``
    gives a ``Prediction`` (RMSE in N, NRMSE, the forces), ``.simulate(file)`` a DataFrame."""

    if not isinstance(path, (str, Path)):
        raise UserError(f"load_fit needs the path of a fit result JSON, got {path!r}")
    return FittedModel.read(path)


def load_study(db, data_dir=None):
    """A study database (``bwbench compare``, ``bwbench.compare``) as a ``Study``: ``.runs`` (one row per
    run, typed: backend, formulation, model, nfev, finished, mse N², rmse_N N, every parameter by
    name), ``.traces`` (best-so-far MSE, N², against evaluations), ``.ranking()``,
    ``.recommendation``, ``.report(out_dir)``, ``.posterior(specimen)``. ``data_dir``: where the
    study's files are now, if they moved."""
    from bwbench.api.study import load

    for name, value in (("db", db), ("data_dir", data_dir)):
        if not (isinstance(value, (str, Path)) or (name == "data_dir" and value is None)):
            raise UserError(f"load_study: {name} must be a path, got {value!r}")
    return load(db, data_dir)


def compare(config=None, **settings):
    """Run (or resume) a study as ``bwbench compare`` does; returns its ``Study``. See
    ``bwbench.api.study.compare`` for the keywords (specimens=, optimizers=, seeds=, budget=, model=,
    formulation=, db=, workers=, ...)."""
    from bwbench.api.study import compare as run

    return run(config, **settings)
