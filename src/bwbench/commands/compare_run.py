"""``bwbench compare`` (and ``python studies/run_compare.py``): run or resume a study, print the ranking."""

from __future__ import annotations

import math
import os
import sqlite3
import sys
from contextlib import closing
from pathlib import Path

import numpy as np

import bwbench.problems as problems
import bwbench.threads as threads
from bwbench.data.output_paths import refuse_inputs, same_file, try_writing
from bwbench.errors import UserError
from bwbench.study import failures
from bwbench.study.config import config_from_arguments, load_study_config
from bwbench.study.execute import run_study
from bwbench.study.inputs import refuse_blowing_box, screen_specimens, study_inputs
from bwbench.study.stop import Interrupted, StudyStopped, say, signals_raise


def read_runs(db):
    """The ``runs`` table joined with ``timings`` as a DataFrame, ordered by key, each cell checked
    (``store.reader.read_runs``): a cell edited by hand is one ``UserError`` naming the run and column."""
    import pandas as pd

    from bwbench.database.reader import connect_read_only
    from bwbench.database.reader import read_runs as read_all

    with closing(connect_read_only(Path(db))) as conn:
        try:
            return read_all(conn)
        except (sqlite3.DatabaseError, pd.errors.DatabaseError, KeyError, ValueError, TypeError) as err:
            raise UserError(f"{db}: unreadable study database: {err}") from None


def refuse_edited_runs(db) -> None:
    """``UserError`` naming the run and column when an existing study database holds a cell edited by hand:
    before any run, not after them. A file that is no study database yet is left to ``run_study``."""
    from bwbench.database.reader import connect_read_only

    if not Path(db).is_file():
        return
    try:
        connect_read_only(Path(db)).close()
    except UserError:
        return
    read_runs(db)


def export_csv(db, path) -> None:
    """Write one row per run as CSV: the ``runs`` table with timings, and a column per parameter of
    each run's model (from ``params_json``; empty where a run's model has no such parameter)."""
    from bwbench.data.output_paths import write_frame

    write_frame(read_runs(db), path, index=False)


def summary_table(db, problem_type=None) -> str:
    """Per label (ranking runs only), lowest median loss ratio first: runs, how
    many finished (a finite loss, no error), how many reached the report's target (within 1 % of
    the best known loss of their specimen), the median final loss over the best known (each run
    against its own specimen's best, so specimens of different force levels can share one median),
    the median RMSE in the problem's residual unit (one specimen: the median; several: the lowest
    and highest of the per-specimen medians, never pooled), median evaluations, errors, and the
    problem's own summary columns."""
    from bwbench.analysis import statistics
    from bwbench.report.verdict import TARGET

    runs = read_runs(db)
    runs = runs[runs["kind"] == "ranking"]
    if runs.empty:
        return "no ranking runs recorded"
    if problem_type is None:
        problem_type = problems.get(
            str(runs["problem"].dropna().iloc[0]) if runs["problem"].notna().any() else problems.DEFAULT
        )
    unit = problem_type.residual_unit
    number = "{:.3g}" if unit != "N" else "{:.3f}"
    all_runs = read_runs(db)
    best = statistics.best_known(all_runs)
    final = statistics.final_mse(runs)
    ratio = final / runs["specimen"].map(best).astype(float)
    reached = final <= runs["specimen"].map(best).astype(float) * (1 + TARGET)
    n_specimens = runs["specimen"].nunique()
    rmse_name = (
        f"median RMSE ({unit})" if n_specimens == 1 else f"median RMSE ({unit}), range over {n_specimens} specimens"
    )
    stats = []
    for optimizer, group in runs.groupby("optimizer", sort=False):
        mse = group["mse"].astype(float)
        ok = group[(group["status"] == "ok") & np.isfinite(mse)]
        rmse = np.sqrt(ok["mse"].astype(float))
        medians = rmse.groupby(ok["specimen"]).median()
        median_ratio = float(ratio[group.index].median())
        stats.append(
            (
                median_ratio,
                optimizer,
                {
                    "runs": str(len(group)),
                    "finished": str(len(ok)),
                    f"within {TARGET:.0%} of best": f"{int(reached[group.index].sum())}",
                    "median loss / best known": (f"{median_ratio:.4g}" if math.isfinite(median_ratio) else "-"),
                    rmse_name: (
                        "-"
                        if not len(ok)
                        else number.format(medians.iloc[0])
                        if n_specimens == 1
                        else f"{number.format(medians.min())}–{number.format(medians.max())}"
                    ),
                    "median evaluations": f"{ok['nfev'].median():.0f}" if len(ok) else "-",
                    "errors": str(int((group["status"] == "error").sum())),
                    **problem_type.summary_columns(group),
                },
            )
        )
    stats.sort(key=lambda r: (r[0], r[1]))
    header = ("label", *stats[0][2])
    lines = [(optimizer, *cells.values()) for _, optimizer, cells in stats]
    widths = [max(len(r[i]) for r in [header, *lines]) for i in range(len(header))]

    def fmt(cells):  # first column left-aligned, numbers right-aligned
        padded = (c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True)))
        return "  ".join(padded)

    note = (
        f"per label, summed over its specimens; 'finished': a finite loss, no error; 'within {TARGET:.0%} of best': "
        f"final loss within {TARGET:.0%} of the best known loss of its specimen (the report's target)"
    )
    return "\n".join([fmt(header), *map(fmt, lines), note])


def recommendation_line(db) -> str:
    """The report's recommendation in one line (``StudyDecision.line``), or why there is none."""
    from bwbench.database.reader import load_study
    from bwbench.report.decision import decide_study

    try:
        study = load_study(db)
        finished = study.ranking[(study.ranking["status"] == "ok") & study.ranking["mse"].map(float).lt(math.inf)]
        if finished.empty:
            return "Recommendation: none (no ranking run finished)."
        return decide_study(study).line()
    except UserError as err:
        return f"Recommendation: see the report ({err})."


def posterior_lines(db) -> list[str]:
    """The verdict of each posterior in the study, one line each, in the report's words."""
    from bwbench.api.posterior import verdict_lines
    from bwbench.database.reader import load_study

    try:
        return verdict_lines(load_study(db))
    except UserError:
        return []


# ------------------------------------------------------------------------------------ entry point


def main(args) -> int:
    """``bwbench compare``: run (or resume) a study, print the ranking, optionally export CSV.

    Exit status 0 when every run succeeded; 1 when some failed (their errors are listed: those
    recorded as errors are not retried, the others are retried by running the same command again)
    or the Dask scheduler was lost; 2 for a user's mistake or a database that cannot be written (one
    line ``error: ...``); 130 on Ctrl-C, 143 on SIGTERM (the runs finished so far stay recorded).
    Raises ``UserError`` for a bad configuration or option.
    """
    if args.workers is not None and args.scheduler:
        raise UserError("--workers and --scheduler exclude each other: a cluster brings its own workers")
    threads.check(getattr(args, "threads", 1))
    db = None
    try:
        with signals_raise():
            config = study_config(args)
            db = Path(args.db) if args.db else config.default_db
            refuse_inputs({"--db": db, "--csv": args.csv}, study_inputs(config, args.bounds))
            refuse_blowing_box(config, args.bounds)
            refuse_edited_runs(db)
            screened = screen_specimens(config)
            if args.csv:
                check_csv_path(args.csv, db)
            outcome = run_study(
                config, db, workers=args.workers, scheduler=args.scheduler, threads=getattr(args, "threads", 1)
            )
            if args.csv:
                try:
                    export_csv(db, args.csv)
                except OSError as err:
                    raise UserError(
                        f"{args.csv}: cannot write the CSV: {err.strerror or err} (the runs are in {db})"
                    ) from None
            _print_results(config, db, outcome, args.csv)
            from bwbench.data import plausibility

            plausibility.print_warnings(screened)  # data check's words, once every refusal is behind
    except (KeyboardInterrupt, Interrupted) as stop:
        what = "interrupted" if isinstance(stop, KeyboardInterrupt) else f"terminated ({stop})"
        # Only a database that exists holds runs: a stop while the study is planned names none.
        where = f"finished runs are in {db}" if db is not None and Path(db).is_file() else "no run had started"
        say(f"{what}: {where}; run the same command again to resume")  # a closed terminal: no traceback
        return 130 if isinstance(stop, KeyboardInterrupt) else stop.status
    except StudyStopped as stop:
        print(f"error: {stop}", file=sys.stderr)
        return stop.status
    lines = failures.summarize(outcome.failed, outcome.lost)
    for line in lines:
        print(line, file=sys.stderr)
    return 1 if lines else 0


def _print_results(config, db, outcome, csv) -> None:
    try:
        print(f"\nstudy {config.name}: {outcome.already + outcome.recorded}/{outcome.total} runs in {db}")
        print(summary_table(db, problems.get(config.problem)))
        if csv:
            print(f"wrote {csv}")
        print(f"the statistics behind the recommendation: bwbench report --db {db} --out reports/{config.name}")
        print(recommendation_line(db))
        for line in posterior_lines(db):
            print(line)
        sys.stdout.flush()
    except BrokenPipeError:  # `compare ... | head`: the reader left, the study is recorded all the same
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit


def check_csv_path(csv, db) -> None:
    """Check, before any run starts, that the CSV file ``csv`` can be written (creating its folder);
    ``UserError`` naming the file if not."""
    path = Path(csv)
    if path.is_dir():
        raise UserError(f"{path}: is a directory; --csv needs a file name")
    if same_file(path, db):
        raise UserError(f"{path}: is the study database; --csv needs another file name")
    blocking = next((p for p in [path.parent, *path.parent.parents] if p.exists() and not p.is_dir()), None)
    if blocking is not None:
        raise UserError(f"{path}: cannot create its folder: {blocking} is a file")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UserError(f"{path}: cannot create its folder: {err.strerror or err}") from None
    try_writing(path)  # changes nothing; written for real once the runs are done


OWN_FLAGS = (
    "optimizers",
    "seeds",
    "budget",
    "seed",
    "name",
    "model",
    "state",
    "excitation",
    "formulation",
    "bounds",
    "fix_mass",
    "offsets",
    "initial_state",
    "warmup",
    "validate",
)


def study_config(args):
    """The study of ``--config`` or of ``--specimens`` (validated; ``UserError`` for any mistake)."""
    if args.config is not None:
        own = [f"--{flag.replace('_', '-')}" for flag in OWN_FLAGS if getattr(args, flag, None) is not None]
        if own:
            raise UserError(
                f"{own[0]} goes with --specimens; with --config the TOML says it (edit "
                f"{args.config}, or pass --db with another path to run a variant)"
            )
        return load_study_config(args.config, data=getattr(args, "data", None))
    if args.optimizers is None:
        raise UserError("--specimens needs --optimizers NAME,NAME (see `bwbench optimizers`)")
    if getattr(args, "data", None) is not None:
        raise UserError("--data goes with --config; with --specimens the files are given")
    return config_from_arguments(
        args.specimens,
        args.optimizers,
        _given(args.seeds, 5),
        _given(args.budget, 4100),
        name=_given(args.name, "study"),
        seed=_given(args.seed, 0),
        state=args.state,
        excitation=_given(args.excitation, "measured"),
        bounds_file=args.bounds,
        formulation=args.formulation,
        model=args.model,
        fix_mass=_given(args.fix_mass, "auto"),
        offsets=_given(args.offsets, "branch"),
        validate=args.validate,
        initial_state=_given(getattr(args, "initial_state", None), "auto"),
        warmup_s=_given(getattr(args, "warmup", None), 0.0),
    )


def _given(value, default):
    return default if value is None else value
