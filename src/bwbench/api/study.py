"""A study from Python: run one, or read one.

``bwbench.compare(...)`` runs one (as ``bwbench compare`` does) and ``bwbench.load_study(db)`` reads
one; both give a ``Study``:

- ``runs``: one row per run with typed columns: ``backend``, ``formulation``, ``model`` and the
  ``optimizer`` label ("cmaes [identifiable]"), ``nfev`` and ``budget`` integers, ``finished`` (the
  run ended with a finite loss; an error or a model that blew up everywhere is not), mse N²,
  rmse_N N, every parameter by name; ``traces``: best-so-far MSE (N²) against evaluations;
- ``ranking()``: the report's ranking table in the decision rule's order, with a ``verdict`` column
  (recommended / as good / less reliable / behind / avoid / baseline);
- ``recommendation``: what the report recommends (``label``, ``backend``, ``formulation``,
  ``model``, ``budget``, ``sentence``, ``text``), from ``bwbench.report.recommend``;
- ``report(out_dir)``: the report of ``bwbench report`` (report.html, report.md, figures, CSVs);
- ``posterior(specimen)`` / ``to_inference_data(specimen)`` / ``posterior_verdict(specimen)``: a
  posterior run's draws in physical units with its verdict (``bwbench.api.posterior``).

Anything else of the stored study (``settings``, ``chains``, ``specimen_path``, ...) is read through.
"""

from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from bwbench.errors import UserError


@dataclass(frozen=True)
class Recommendation:
    """The report's recommendation, as ``Study.recommendation`` gives it.

    ``str()`` of it is ``sentence``.

    Parameters
    ----------
    label : str or None
        The run label to use ("cmaes [identifiable]"); None when nothing can be recommended (only the
        baseline ran).
    backend, formulation, model : str or None
        The label's backend, formulation and model.
    budget : int or None
        The budget (evaluations) it was judged at.
    sentence : str
        The "Use ..." sentence, plain text.
    text : str
        The whole paragraph, markdown.
    line : str, default ""
        The recommendation in one line, as ``bwbench compare`` prints it.

    Examples
    --------
    >>> rec = bwbench.load_study("study.sqlite").recommendation
    >>> rec.backend, rec.formulation
    ('lsq-trf', 'identifiable')
    """

    label: str | None
    backend: str | None
    formulation: str | None
    model: str | None
    budget: int | None
    sentence: str
    text: str
    line: str = ""

    def __str__(self) -> str:
        return self.sentence


class Study:
    """A study database read for Python (see the module docstring).

    Made by ``bwbench.load_study`` and ``bwbench.compare``; anything else of the stored study
    (``settings``, ``chains``, ``specimen_path``, ...) is read through.

    Parameters
    ----------
    stored : bwbench.database.reader.Study
        The study as the database reader gives it.

    Examples
    --------
    >>> study = bwbench.load_study("study.sqlite")
    >>> study.runs[["optimizer", "rmse_N"]].head()
    >>> study.ranking()
    >>> print(study.recommendation.line)
    """

    def __init__(self, stored):
        self._stored = stored  # bwbench.database.reader.Study

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return getattr(self._stored, name)

    # -- tables -------------------------------------------------------------------------------------
    @cached_property
    def runs(self):
        """One row per run, typed.

        Returns
        -------
        pandas.DataFrame
            ``backend``, ``formulation``, ``model`` and the ``optimizer`` label ("cmaes
            [identifiable]"), ``nfev`` and ``budget`` integers, ``finished`` (the run ended with a
            finite loss; an error or a model that blew up everywhere is not), ``mse`` (N²),
            ``rmse_N`` (N), every parameter by name.

        Examples
        --------
        >>> runs = bwbench.load_study("study.sqlite").runs
        >>> runs[runs["finished"]].groupby("optimizer")["rmse_N"].median()
        """
        from bwbench.render.labels import split_label

        runs = self._stored.runs.copy()
        runs.insert(
            runs.columns.get_loc("optimizer") + 1, "backend", [split_label(label)[0] for label in runs["optimizer"]]
        )
        for column in ("nfev", "budget"):
            runs[column] = runs[column].round().astype("Int64")
        runs["finished"] = (runs["status"] == "ok") & runs["mse"].map(lambda m: math.isfinite(float(m)))
        return runs.drop(columns=["success"], errors="ignore")

    @property
    def traces(self):
        """The best-so-far curves of the runs.

        Returns
        -------
        pandas.DataFrame
            Best-so-far MSE (N²) against evaluations, per run.

        Examples
        --------
        >>> bwbench.load_study("study.sqlite").traces.head()
        """
        return self._stored.traces

    @cached_property
    def decision(self):
        """The study's answer: the one the report and ``bwbench compare`` give, measured times included.

        Returns
        -------
        bwbench.report.decision.StudyDecision

        Raises
        ------
        bwbench.errors.UserError
            When the study has no ranking runs yet.
        """
        from bwbench.report.decision import decide_study

        s = self._stored
        if s.ranking.empty:
            raise UserError(f"{s.path}: the study has no ranking runs yet: nothing to rank")
        return decide_study(s)

    def ranking(self):
        """The report's ranking table in the decision rule's order.

        Returns
        -------
        pandas.DataFrame
            One row per run label (``optimizer``), with ``backend``, ``variant`` and ``verdict``
            columns (recommended, tied on time, as good, less reliable, behind, avoid, baseline) and
            the statistics (median/best RMSE in N, success rates, ERT, times).

        Raises
        ------
        bwbench.errors.UserError
            When the study has no ranking runs yet.

        Examples
        --------
        >>> bwbench.load_study("study.sqlite").ranking()[["optimizer", "verdict"]]
        """
        from bwbench.render.labels import split_label

        out = self.decision.ranking()
        verdict = out.pop("verdict")
        out.insert(1, "backend", [split_label(label)[0] for label in out["optimizer"]])
        out.insert(2, "variant", [split_label(label)[1] for label in out["optimizer"]])
        out.insert(3, "verdict", verdict)
        return out

    @cached_property
    def recommendation(self) -> Recommendation:
        """The report's recommendation.

        Returns
        -------
        Recommendation
            Its ``line`` is what ``bwbench compare`` prints.

        Raises
        ------
        bwbench.errors.UserError
            When the study has no ranking runs yet.
        """
        from bwbench.render.labels import split_label

        decision = self.decision
        label, text = decision.choice, decision.text
        budget = self._stored.settings.get("budget")
        budget = int(budget) if isinstance(budget, (int, float)) else None
        if label is None:
            return Recommendation(None, None, None, None, budget, _plain(text), text, decision.line())
        facts = decision.facts.get(label, {})
        found = re.search(r"\*\*Use.*?\.(?=\s+[A-Z*]|\s*$)", text, re.S)
        use = found.group(0) if found else text
        return Recommendation(
            label,
            split_label(label)[0],
            facts.get("formulation"),
            facts.get("model"),
            budget,
            _plain(use),
            text,
            decision.line(),
        )

    # -- outputs ----------------------------------------------------------------------------------
    def report(self, out_dir, *, data_dir=None, profiles: int = 2, log=None) -> Path:
        """Write the report of ``bwbench report`` into ``out_dir``.

        Parameters
        ----------
        out_dir : str or pathlib.Path
            The folder of report.html, report.md, figures and CSVs.
        data_dir : str or pathlib.Path or None, default None
            Where the study's files are now, if they moved.
        profiles : int, default 2
            Profile likelihoods on the first specimen; 0 = none.
        log : file-like or None, default None
            Where progress goes (default: nowhere).

        Returns
        -------
        pathlib.Path
            report.html's path.

        Raises
        ------
        bwbench.errors.UserError
            For a bad ``profiles``, or a study the report cannot read.

        Examples
        --------
        >>> html = bwbench.load_study("study.sqlite").report("out", profiles=0)
        """
        from bwbench.api.arguments import count as check_count

        check_count("profiles", profiles, "0 or more", minimum=0)
        with untouched():
            from bwbench.report.build import build_report

            return build_report(
                self._stored.path,
                out_dir,
                data_dir=data_dir,
                profile_params=profiles,
                log=io.StringIO() if log is None else log,
            )

    def posterior(self, specimen: str, thin: int | None = None):
        """The posterior draws of ``specimen`` as a DataFrame in physical units.

        Parameters
        ----------
        specimen : str
            The specimen whose posterior run to read.
        thin : int or None, default None
            Keep every thin-th step (default: about 4,000 draws).

        Returns
        -------
        pandas.DataFrame
            ``walker``, ``step`` (after burn-in), one column per parameter; units in
            ``.attrs["units"]``.

        Raises
        ------
        bwbench.errors.UserError
            When the study has no posterior run of ``specimen``, or ``thin`` is not a positive integer.

        Examples
        --------
        >>> draws = bwbench.load_study("study.sqlite").posterior("mytest")
        >>> draws.attrs["units"]
        """
        from bwbench.api import posterior as posterior_api

        with untouched():
            return posterior_api.frame(self._stored, specimen, thin)

    def to_inference_data(self, specimen: str, thin: int | None = None):
        """The same draws as ArviZ ``InferenceData``, for ``arviz.summary``, plots, R-hat.

        Parameters
        ----------
        specimen : str
            The specimen whose posterior run to read.
        thin : int or None, default None
            Keep every thin-th step (default: about 4,000 draws).

        Returns
        -------
        arviz.InferenceData
            Chains = walkers, draws = kept steps; the log-posterior under ``sample_stats.lp`` when
            stored; units in the posterior group's attrs.

        Raises
        ------
        bwbench.errors.UserError
            As ``posterior``.

        Examples
        --------
        >>> import arviz as az
        >>> az.summary(bwbench.load_study("study.sqlite").to_inference_data("mytest"))
        """
        from bwbench.api import posterior as posterior_api

        with untouched():
            return posterior_api.inference_data(self._stored, specimen, thin)

    def posterior_verdict(self, specimen: str):
        """The verdict on the posterior of ``specimen``, the report's and the terminal's.

        ``converged``, ``reasons``, ``line`` (``bwbench.api.posterior.verdict``).
        """
        from bwbench.api import posterior as posterior_api

        with untouched():
            return posterior_api.verdict(self._stored, specimen)

    # -- display ----------------------------------------------------------------------------------
    def _counts(self) -> str:
        runs = self.runs
        ranking = runs[runs["kind"] == "ranking"]
        labels = ranking["optimizer"].nunique()
        specimens = ranking["specimen"].nunique()
        return (
            f"{len(runs)} runs ({int(runs['finished'].sum())} finished): {labels} labels on {specimens} "
            f"specimen{'s' if specimens != 1 else ''}"
        )

    def __repr__(self) -> str:
        return f"<Study {self._stored.name} at {self._stored.path}: {self._counts()}; .ranking(), .recommendation>"

    def _repr_html_(self) -> str:
        import html

        from bwbench.render.reprs import table_html

        runs = self.runs[self.runs["kind"] == "ranking"]
        rows = []
        for label, g in runs.groupby("optimizer", sort=True):
            done = g[g["finished"]]
            rows.append((label, len(g), len(done), f"{done['rmse_N'].median():.4g}" if len(done) else "–"))
        return (
            f"<div><b>Study</b> {html.escape(self._stored.name)} ({html.escape(str(self._stored.path))}): "
            f"{html.escape(self._counts())}"
            + table_html(rows, ["label", "runs", "finished", "median RMSE (N)"])
            + "<small>.ranking() and .recommendation apply the report's rule</small></div>"
        )


def _plain(markdown: str) -> str:
    return markdown.replace("**", "").replace("*", "")


def load(db, data_dir=None) -> Study:
    """Read a study database (what ``bwbench.load_study`` does after checking its arguments).

    Parameters
    ----------
    db : str or pathlib.Path
        The study's SQLite database.
    data_dir : str or pathlib.Path or None, default None
        Where the study's files are now, if they moved.

    Returns
    -------
    Study

    Examples
    --------
    >>> load("study.sqlite", data_dir="moved/data").ranking()
    """
    from bwbench.database.reader import load_study

    return Study(load_study(db, data_dir))


def compare(
    config=None,
    *,
    specimens=None,
    optimizers=None,
    seeds: int = 5,
    budget: int = 4100,
    seed: int = 0,
    model=None,
    formulation=None,
    state=None,
    excitation: str = "measured",
    bounds=None,
    fix_mass="auto",
    offsets: str = "branch",
    validate=None,
    name: str = "study",
    db=None,
    workers: int | None = 1,
    threads: int = 1,
    data=None,
    log=None,
    initial_state=None,
    warmup=None,
) -> Study:
    """Run (or resume) a study as ``bwbench compare`` does and return its ``Study``.

    Give either ``config`` or ``specimens`` with ``optimizers``. A study that is already complete in
    ``db`` is read, not run again; runs that failed are in ``runs`` (``finished`` False).

    Parameters
    ----------
    config : str or pathlib.Path or None, default None
        A study TOML.
    specimens : list of str or None, default None
        Specimen CSV paths (or globs).
    optimizers : list of str or str or None, default None
        Backend names, as a list or one comma-separated string.
    seeds : int, default 5
        Replicates per backend and specimen.
    budget : int, default 4100
        Evaluations per run (one evaluation = one simulation of every file).
    seed : int, default 0
        The study's seed.
    model, formulation : str or list of str or None, default None
        A name, or a list of names compared side by side.
    state : str or None, default None
        The state convention ("shared"/"split", switched model).
    excitation : str, default "measured"
        "measured" or "sine".
    bounds : str or pathlib.Path or None, default None
        A JSON file of {name: [lower, upper]}.
    fix_mass : str, float or None, default "auto"
        As in ``bwbench.fit``.
    offsets : str, default "branch"
        "branch" or "continuous" (identifiable, switched model).
    validate : list of str or None, default None
        Held-out files every fit predicts.
    name : str, default "study"
        The study's name.
    db : str or pathlib.Path or None, default None
        The database (default: ``<name>.sqlite`` next to the TOML or in the current folder).
    workers : int or None, default 1
        Local processes (1: in this process).
    threads : int, default 1
        numba/BLAS threads per worker.
    data : str or pathlib.Path or None, default None
        Replaces the TOML's data folder.
    log : file-like or None, default None
        Where progress goes (default: nowhere).
    initial_state : str, default "auto"
        How every model starts each record: "auto", "rest" or "pre-roll" (with ``specimens``; a TOML
        says it under [study]).
    warmup : float, default 0
        Seconds at the start of each record simulated but left out of the loss.

    Returns
    -------
    Study

    Raises
    ------
    bwbench.errors.UserError
        With the command line's message for bad input.

    Examples
    --------
    >>> study = bwbench.compare(specimens=["a.csv", "b.csv"], optimizers=["cmaes", "random"], seeds=3, budget=500)
    >>> study.recommendation.sentence
    """
    with untouched():  # the study's report figures set their theme
        return _compare(
            config,
            specimens=specimens,
            optimizers=optimizers,
            seeds=seeds,
            budget=budget,
            seed=seed,
            model=model,
            formulation=formulation,
            state=state,
            excitation=excitation,
            bounds=bounds,
            fix_mass=fix_mass,
            offsets=offsets,
            validate=validate,
            name=name,
            db=db,
            workers=workers,
            threads=threads,
            data=data,
            log=log,
            initial_state=initial_state,
            warmup=warmup,
        )


def _compare(
    config,
    *,
    specimens,
    optimizers,
    seeds,
    budget,
    seed,
    model,
    formulation,
    state,
    excitation,
    bounds,
    fix_mass,
    offsets,
    validate,
    name,
    db,
    workers,
    threads,
    data,
    log,
    initial_state=None,
    warmup=None,
) -> Study:
    import bwbench.threads as threads_mod
    from bwbench.api.arguments import count as check_count
    from bwbench.data.output_paths import refuse_inputs
    from bwbench.study.config import config_from_arguments, load_study_config
    from bwbench.study.execute import run_study
    from bwbench.study.inputs import refuse_blowing_box, study_inputs
    from bwbench.study.stop import StudyStopped

    if (config is None) == (specimens is None):
        raise UserError("bwbench.compare needs either config= (a study TOML) or specimens= (CSV files), not both")
    threads_mod.check(check_count("threads", threads, "a positive integer"))
    if workers is not None:
        check_count("workers", workers, "a positive integer")
    if config is not None:
        given = [
            k
            for k, v in (
                ("optimizers", optimizers),
                ("model", model),
                ("formulation", formulation),
                ("state", state),
                ("bounds", bounds),
                ("validate", validate),
                ("initial_state", initial_state),
                ("warmup", warmup),
            )
            if v is not None
        ]
        if given:
            raise UserError(f"{given[0]}= goes with specimens=; with config= the TOML says it")
        study_config = load_study_config(config, data=data)
    else:
        if data is not None:
            raise UserError("data= goes with config=; with specimens= the files are given")
        if optimizers is None:
            raise UserError("specimens= needs optimizers= (backend names, e.g. ['cmaes', 'random'])")
        files = [specimens] if isinstance(specimens, (str, Path)) else list(specimens)
        if not all(isinstance(f, (str, Path)) for f in files):
            raise UserError(
                "specimens= takes CSV paths (a study reads its files again in every worker and report): "
                "write a DataFrame with frame.to_csv(path, index=False) first"
            )
        study_config = config_from_arguments(
            [str(f) for f in files],
            _names(optimizers),
            seeds,
            budget,
            name=name,
            seed=seed,
            state=state,
            excitation=excitation,
            bounds_file=None if bounds is None else str(bounds),
            formulation=_names(formulation),
            model=_names(model),
            fix_mass=fix_mass,
            offsets=offsets,
            validate=None
            if validate is None
            else [str(v) for v in ([validate] if isinstance(validate, (str, Path)) else validate)],
            initial_state="auto" if initial_state is None else initial_state,
            warmup_s=0.0 if warmup is None else warmup,
        )
    path = Path(db) if db is not None else study_config.default_db
    refuse_inputs({"db": path}, study_inputs(study_config, bounds))
    refuse_blowing_box(study_config, bounds)
    try:
        run_study(study_config, path, workers=workers, threads=threads, log=io.StringIO() if log is None else log)
    except StudyStopped as stop:
        raise UserError(str(stop)) from None
    return load(path)


def _names(value):
    """None, or a comma-separated string of names (from a list or a string)."""
    if value is None or isinstance(value, str):
        return value
    return ",".join(str(v) for v in value)


def untouched():
    """A context in which matplotlib's rcParams are restored on exit: the report's figures set their theme.

    Returns
    -------
    contextlib.AbstractContextManager
        ``matplotlib.rc_context()``.

    Examples
    --------
    >>> with untouched():
    ...     study.report("out")
    """
    import matplotlib

    return matplotlib.rc_context()
