"""``bwbench compare`` (and ``python studies/run_compare.py``): run or resume a study, print the ranking."""

from __future__ import annotations

import argparse
import math
import sqlite3
import sys
from contextlib import closing
from pathlib import Path

import numpy as np

from bwbench import problems
from bwbench.errors import UserError
from bwbench.study.config import config_from_arguments, load_study_config
from bwbench.study.execute import run_study


def read_runs(db):
    """The ``runs`` table joined with ``timings`` as a DataFrame, ordered by key."""
    import pandas as pd

    path = Path(db)
    if not path.is_file():
        raise UserError(f"{path}: no such study database")
    with closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as conn:
        return pd.read_sql(
            "SELECT runs.*, timings.wall_s, timings.worker, timings.finished_utc FROM runs "
            "LEFT JOIN timings USING (kind, specimen, optimizer, replicate) "
            "ORDER BY kind, specimen, optimizer, replicate", conn)


def export_csv(db, path) -> None:
    """Write the tidy table of ``read_runs`` as CSV (one row per run)."""
    read_runs(db).to_csv(path, index=False)


def summary_table(db, problem_type=None) -> str:
    """Per backend (ranking runs only): median and best RMSE (in the problem's residual unit), success
    rate, median evaluations, errors, and the problem's own summary columns. Best median RMSE first."""
    runs = read_runs(db)
    runs = runs[runs["kind"] == "ranking"]
    if runs.empty:
        return "no ranking runs recorded"
    if problem_type is None:
        problem_type = problems.get(str(runs["problem"].dropna().iloc[0]) if runs["problem"].notna().any()
                                    else problems.DEFAULT)
    unit = problem_type.residual_unit
    number = "{:.3g}" if unit != "N" else "{:.3f}"
    stats = []
    for optimizer, group in runs.groupby("optimizer", sort=False):
        mse = group["mse"].astype(float)
        ok = group[(group["status"] == "ok") & np.isfinite(mse)]
        rmse = np.sqrt(ok["mse"].astype(float))
        stats.append((rmse.median() if len(ok) else math.inf, optimizer, {
            "runs": str(len(group)),
            f"median RMSE ({unit})": number.format(rmse.median()) if len(ok) else "-",
            f"best RMSE ({unit})": number.format(rmse.min()) if len(ok) else "-",
            "success": f"{len(ok) / len(group):.0%}",
            "median nfev": f"{ok['nfev'].median():.0f}" if len(ok) else "-",
            "errors": str(int((group["status"] == "error").sum())),
            **problem_type.summary_columns(group)}))
    stats.sort(key=lambda r: (r[0], r[1]))
    header = ("optimizer", *stats[0][2])
    lines = [(optimizer, *cells.values()) for _, optimizer, cells in stats]
    widths = [max(len(r[i]) for r in [header, *lines]) for i in range(len(header))]

    def fmt(cells):  # first column left-aligned, numbers right-aligned
        padded = (c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True)))
        return "  ".join(padded)

    return "\n".join([fmt(header), *map(fmt, lines)])


# ------------------------------------------------------------------------------------ entry point

def add_arguments(parser: argparse.ArgumentParser) -> None:
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--config", help="study TOML (e.g. studies/quick.toml)")
    source.add_argument("--specimens", nargs="+", metavar="FILE",
                        help="your own specimen CSVs (paths or quoted globs): a study without a TOML")
    own = parser.add_argument_group("with --specimens")
    own.add_argument("--optimizers", help="backends, comma-separated (e.g. cmaes,de,random)")
    own.add_argument("--seeds", type=int, default=5, help="replicates per (specimen, backend) (default 5)")
    own.add_argument("--budget", type=int, default=4100, help="evaluations per run (default 4100)")
    own.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    own.add_argument("--name", default="study", help="study name (default 'study': database ./study.sqlite)")
    own.add_argument("--state", default="shared", help="hysteretic state convention: shared (default) or split")
    own.add_argument("--excitation", default="measured", help="measured (default) or sine")
    own.add_argument("--formulation", default="paper",
                     help="paper (default), identifiable, or paper,identifiable to compare both side by side")
    own.add_argument("--bounds", metavar="FILE.json", help="search box: a JSON object of name -> [lower, upper]")
    parser.add_argument("--db", help="SQLite database (default: <name>.sqlite next to the TOML, or in the current "
                                     "folder with --specimens)")
    parser.add_argument("--workers", type=int, help="local worker processes (default: all cores; 1 = in-process)")
    parser.add_argument("--scheduler", help="Dask scheduler address (tcp://HOST:PORT) instead of local workers")
    parser.add_argument("--csv", help="also write the runs (with timings) as a CSV file")
    parser.add_argument("--data", help="data folder, replacing the configuration's [study] data (relative to the "
                                       "current directory); for bouc-wen-benchmark the folder of its three CSVs")
    parser.set_defaults(func=main)


def main(args) -> int:
    """``bwbench compare``: run (or resume) a study, print the ranking, optionally export CSV.

    Exit status 0 when every run is recorded (including runs that raised: status "error"),
    1 when some runs were lost to a dead worker (run again to retry them), 130 on Ctrl-C.
    Raises ``UserError`` for a bad configuration or option.
    """
    if args.workers is not None and args.scheduler:
        raise UserError("--workers and --scheduler exclude each other: a cluster brings its own workers")
    config = study_config(args)
    db = Path(args.db) if args.db else config.default_db
    try:
        outcome = run_study(config, db, workers=args.workers, scheduler=args.scheduler)
    except KeyboardInterrupt:
        print(f"interrupted: finished runs are in {db}; run the same command again to resume", file=sys.stderr)
        return 130
    print(f"\nstudy {config.name}: {outcome.already + outcome.recorded}/{outcome.total} runs in {db}")
    print(summary_table(db, problems.get(config.problem)))
    if args.csv:
        export_csv(db, args.csv)
        print(f"wrote {args.csv}")
    if outcome.lost:
        key, why = outcome.lost[0]
        print(f"error: {len(outcome.lost)} run(s) lost to a failed worker (first: {'/'.join(map(str, key))}: "
              f"{why}); run the same command again to retry them", file=sys.stderr)
        return 1
    return 0


def study_config(args):
    """The study of ``--config`` or of ``--specimens`` (validated; ``UserError`` for any mistake)."""
    if args.config is not None:
        own = [flag for flag, value in (("--optimizers", args.optimizers), ("--bounds", args.bounds))
               if value is not None]
        if own:
            raise UserError(f"{own[0]} goes with --specimens; with --config the TOML says it")
        return load_study_config(args.config, data=getattr(args, "data", None))
    if args.optimizers is None:
        raise UserError("--specimens needs --optimizers NAME,NAME (see `bwbench optimizers`)")
    if getattr(args, "data", None) is not None:
        raise UserError("--data goes with --config; with --specimens the files are given")
    bounds = None
    if args.bounds is not None:
        from bwbench.data import bounds as bounds_mod
        from bwbench.problems.switched_vpp.formulations import bound_names

        bounds = bounds_mod.read_json(args.bounds, bound_names(args.formulation.split(","), args.state))
    return config_from_arguments(args.specimens, args.optimizers, args.seeds, args.budget, name=args.name,
                                 seed=args.seed, state=args.state, excitation=args.excitation, bounds=bounds,
                                 formulation=args.formulation)


def run_cli(argv=None, prog: str | None = None) -> int:
    """Parse ``argv`` and run ``main``; a ``UserError`` becomes one line ``error: ...`` and status 2."""
    parser = argparse.ArgumentParser(prog=prog, description=main.__doc__.splitlines()[0])
    add_arguments(parser)
    args = parser.parse_args(argv)
    try:
        return main(args)
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
