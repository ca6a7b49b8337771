"""The Python API, for notebooks: the calls the command line is built on.

::

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
from bwbench.problems.hysteresis.findings import FitBoxWarning, FitFailure, FitFinding, FitNote, FitWarning
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
    "FitNote",
    "FitFinding",
    "FitBoxWarning",
    "FitFailure",
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
    control: str | None = None,
    control_levels: dict | None = None,
    laws: dict | str | None = None,
    control_filter: bool = False,
    initial_state: str = "auto",
    warmup: float = 0.0,
) -> FitResult:
    """Fit one test, or several jointly (one parameter set for all), as ``bwbench fit`` does.

    Parameters
    ----------
    *data : str, pathlib.Path, Specimen or pandas.DataFrame
        One or more tests, each a specimen CSV's path, a ``Specimen`` or a pandas DataFrame with the
        file's columns (``time_s``, ``displacement_mm``, ``force_N``, optionally ``velocity_mm_s``,
        ``acceleration_mm_s2``); a list of them counts as several.
    optimizer : str, default "lsq-trf"
        A backend name (``bwbench optimizers``).
    budget : int, default 4100
        Exactly this many evaluations (one evaluation = one simulation of every file).
    seed : int, default 0
        The run's seed.
    model : str or None, default None
        A registered model (default: the switched Bouc-Wen).
    formulation : str or None, default None
        "paper"/"direct" or "identifiable" (default: chosen from the data — the switched model's
        paper formulation for the paper's synthetic specimens, identifiable for any other data; the
        first finding says which and why).
    state : str or None, default None
        "shared"/"split" (switched model).
    excitation : str, default "measured"
        "measured" or "sine".
    fix_mass : str, float or None, default "auto"
        Identifiable formulation: "auto" (the inertia rule), None or "fit" (always fitted) or a mass
        in N·s²/mm.
    offsets : str or None, default None
        Identifiable formulation, switched model: "branch" or "continuous".
    weighting : str, default "equal"
        "equal" (each file's MSE counts the same) or "samples".
    bounds : dict, str, pathlib.Path or None, default None
        {name: (lower, upper)} or a JSON file of them; searched names set the search box, solved
        coefficients bound the linear solve.
    options : dict or None, default None
        The backend's options.
    threads : int, default 1
        numba/BLAS threads.
    name : str or None, default None
        A DataFrame's name (default: its ``attrs["name"]`` or "data").
    stop : str, default "agreed"
        "agreed" (a backend that restarts local searches, lsq-trf, may stop before the budget once
        its searches agree on the optimum; ``nfev`` and the result's message say so) or "budget"
        (spend it all, as a study does).
    workers : int, default 1
        Threads for the files of a joint fit, else for the points of a batch; the result is the same
        as with one.
    initial_state : str, default "auto"
        How every model starts each test: "auto" (from rest when the test starts from rest, else after
        a pre-roll of one cycle of its own motion), "rest" or "pre-roll"
        (docs/fitting.md#the-start-of-a-record).
    warmup : float, default 0
        Seconds at the start of each test simulated but left out of the loss.
    control : str or None, default None
        One model across a control range (docs/control.md): the control column (``"current_A"``), or
        a level for files without it (``"current_A=0.5"``). ``.model`` is then a ``ControlledModel``
        (``.at(level)``, ``.predict(data)`` at any level).
    control_levels : dict or None, default None
        The files' levels ({path, file name or DataFrame name: level}).
    laws : dict, str or None, default None
        {parameter: law} (``"linear"``, ``"quadratic"``, ``"exponential"``, ``"constant"`` or a
        ``CallableLaw``), or ``"auto"``.
    control_filter : bool, default False
        Spencer's first-order lag between command and control, its rate fitted.

    Returns
    -------
    FitResult
        ``.ok`` (False for a failed fit, ``.failure`` says why: no finite loss, or further from the
        data than the best constant force), ``.findings`` (everything ``bwbench fit`` prints beside
        the loss, each with its severity), ``.summary()``, ``.report()``, ``.correlation()``,
        ``.plot()``, ``.params``, ``.rmse_N``, ``.table()``, ``.model``, ``.predict(data)``,
        ``.save(path)``.

    Raises
    ------
    bwbench.UserError
        With the command line's message for bad input, before any file is read.

    Warns
    -----
    bwbench.FitWarning
        Every finding but the facts ("info"), as a subclass: ``FitNote``, ``FitFinding``,
        ``FitBoxWarning``, ``FitFailure``.

    Examples
    --------
    >>> fit = bwbench.fit("mytest.csv", model="spencer", optimizer="lsq-trf", budget=4100, seed=1)
    >>> fit.summary()
    >>> fit.rmse_N
    """
    import bwbench.limits as limits
    import bwbench.threads as threads_mod
    from bwbench.api.arguments import count
    from bwbench.engine import registry as backends
    from bwbench.problems.hysteresis import findings
    from bwbench.problems.hysteresis.fit_result import run_fit
    from bwbench.problems.hysteresis.setup import setup_fit

    # Every argument checked as the command line checks it, with its words, before any file is read.
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
    from bwbench.models import start

    start.check(initial_state, warmup, ("initial_state", "warmup"))  # the API's own words for the start
    with threads_mod.limited(threads_mod.check(threads)):
        setup = setup_fit(
            list(data),
            model=model,
            formulation=formulation,
            state=state,
            excitation=excitation,
            fix_mass=fix_mass,
            offsets=offsets,
            weighting=weighting,
            bounds=bounds,
            name=name,
            control=control,
            control_levels=control_levels,
            laws=laws,
            control_filter=control_filter,
            law_search=(optimizer, budget, seed),
            initial_state=initial_state,
            warmup=warmup,
        )
    extra: dict = {"formulation_reason": setup.formulation_reason, "bounds_file": setup.bounds_file}
    if setup.box_probe_s is not None:
        extra["box_probe_s"] = setup.box_probe_s
    with threads_mod.for_workers(setup.problem, max(workers, threads)):
        result = run_fit(setup.problem, optimizer, budget, seed, options, setup.synthetic, extra=extra, stop=stop)
    findings.issue(result.findings)
    return result


def load_fit(path) -> FittedModel:
    """Read the ``FittedModel`` of a result JSON (``bwbench fit --out``, ``FitResult.save``).

    A fit across a control (``laws=``) gives a ``ControlledModel``: ``.predict(file)`` at the file's
    level, ``.at(level)``.

    Parameters
    ----------
    path : str or pathlib.Path
        The result JSON.

    Returns
    -------
    FittedModel
        ``.predict(file)`` gives a ``Prediction`` (RMSE in N, NRMSE, the forces), ``.simulate(file)``
        a DataFrame.

    Raises
    ------
    bwbench.UserError
        When ``path`` is not a path, or the file is not a readable fit result.

    Examples
    --------
    >>> model = bwbench.load_fit("fit.json")
    >>> model.predict("othertest.csv").rmse_N
    """
    if not isinstance(path, (str, Path)):
        raise UserError(f"load_fit needs the path of a fit result JSON, got {path!r}")
    from bwbench.data.json_input import read_json_file
    from bwbench.problems.hysteresis.control.fitted import model_of_result

    data = read_json_file(Path(path))
    if isinstance(data, dict) and isinstance(data.get("control"), dict):
        return model_of_result(data, str(path))
    return FittedModel.read(path)


def load_study(db, data_dir=None):
    """Read a study database (``bwbench compare``, ``bwbench.compare``) as a ``Study``.

    Parameters
    ----------
    db : str or pathlib.Path
        The study's SQLite database.
    data_dir : str or pathlib.Path or None, default None
        Where the study's files are now, if they moved.

    Returns
    -------
    Study
        ``.runs`` (one row per run, typed: backend, formulation, model, nfev, finished, mse N², rmse_N
        N, every parameter by name), ``.traces`` (best-so-far MSE, N², against evaluations),
        ``.ranking()``, ``.recommendation``, ``.report(out_dir)``, ``.posterior(specimen)``.

    Raises
    ------
    bwbench.UserError
        When an argument is not a path, or the database cannot be read as a study.

    Examples
    --------
    >>> study = bwbench.load_study("study.sqlite")
    >>> study.ranking()
    """
    from bwbench.api.study import load

    for name, value in (("db", db), ("data_dir", data_dir)):
        if not (isinstance(value, (str, Path)) or (name == "data_dir" and value is None)):
            raise UserError(f"load_study: {name} must be a path, got {value!r}")
    return load(db, data_dir)


def compare(config=None, **settings):
    """Run (or resume) a study as ``bwbench compare`` does.

    Parameters
    ----------
    config : str or pathlib.Path or None, default None
        A study TOML; or give ``specimens`` and ``optimizers`` instead.
    **settings
        The keywords of ``bwbench.api.study.compare`` (specimens=, optimizers=, seeds=, budget=,
        model=, formulation=, db=, workers=, ...).

    Returns
    -------
    Study

    Raises
    ------
    bwbench.UserError
        With the command line's message for bad input.

    Examples
    --------
    >>> study = bwbench.compare(specimens=["a.csv", "b.csv"], optimizers=["cmaes", "random"], seeds=3, budget=500)
    >>> study.ranking(), study.recommendation
    """
    from bwbench.api.study import compare as run

    return run(config, **settings)
