"""The comparison study: specimens × backends × seeds on one budget, parallel and resumable.

Every (kind, specimen, optimizer, replicate) is a ``Task`` with its own seed,
``SeedSequence(study seed, spawn_key=(crc32(kind), crc32(specimen), crc32(optimizer), replicate))``,
so a run's result depends neither on the number of workers nor on which other runs the study has.
Tasks run in a local process pool (default: all cores), in-process (``workers=1``) or on a Dask
cluster (``scheduler="tcp://HOST:PORT"``; start its workers with ``--nthreads 1``, one per core:
the backends are partly Python and hold the GIL). Only the main process writes the SQLite database, one
transaction per finished run; running the same command again skips the finished runs (those that
succeeded and those that raised), so a killed study loses at most the runs that were in flight.

Database schema (the report reads it; names are a contract):

- ``study(key, value)``: ``name``, ``config_json``, ``config_hash``, ``created_utc``, ``bwbench_version``.
- ``study`` also holds ``data_dir`` for a ``bouc-wen-benchmark`` study: the benchmark folder of
  the latest run (where ``bwbench report`` looks first); it is not part of the configuration.
- ``runs``: one row per finished run, keyed by (kind, specimen, optimizer, replicate); no wall
  time, so rows are identical whoever ran them and when. Columns for any problem: ``problem``,
  ``params_json`` (the physical parameters by name) and ``metrics_json`` (the problem's own
  metrics of the best point: ``{}`` for the switched model; for the benchmark
  ``test_multisine_erms_m``, ``test_sinesweep_erms_m`` and ``train_rmse_m``, null where the
  model blows up; NULL for a run that raised). The 14 switched-model parameter columns, ``state``,
  ``excitation``, ``material``, ``underpressure_MPa``, ``repeat`` and ``rmse_N`` are NULL for the
  benchmark (its MSE is in m²). Databases written before these three columns existed get them
  (NULL) when a study is resumed.
- ``timings``: wall time (s), worker (``host:pid``) and finish time (UTC) of each run.
- ``traces``: the best-so-far improvements (evaluation count, MSE in the problem's unit²) of each run.
- ``chains``: MCMC chains (float64, unit coordinates, shape (steps, walkers, dim)) of runs that
  return one (emcee).
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import os
import socket
import sqlite3
import sys
import time
import zlib
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import closing
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from bwbench import __version__
from bwbench.errors import UserError
from bwbench.models.switched_bouc_wen import PARAM_NAMES
from bwbench.study.config import (
    BENCHMARK_PROBLEM,
    DEFAULT_PROBLEM,
    StudyConfig,
    canonical_json,
    describe_differences,
    load_study_config,
)

GENERIC_COLUMNS = ("problem", "params_json", "metrics_json")  # usable by any problem
RUN_COLUMNS = (
    "kind", "specimen", "optimizer", "replicate", "seed_entropy", "status", "error", "budget",
    "nfev", "mse", "f_err", "rmse_N", "success", "message", "state", "excitation", "material",
    "underpressure_MPa", "repeat", "options_json", *PARAM_NAMES, *GENERIC_COLUMNS,
)
_KEY_SQL = "kind TEXT, specimen TEXT, optimizer TEXT, replicate INTEGER"
_PK_SQL = "PRIMARY KEY (kind, specimen, optimizer, replicate)"
SCHEMA = f"""
CREATE TABLE IF NOT EXISTS study (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS runs (
    {_KEY_SQL}, seed_entropy TEXT, status TEXT, error TEXT, budget INTEGER, nfev INTEGER,
    mse REAL, f_err REAL, rmse_N REAL, success INTEGER, message TEXT, state TEXT, excitation TEXT,
    material TEXT, underpressure_MPa REAL, repeat INTEGER, options_json TEXT,
    {", ".join(f'"{name}" REAL' for name in PARAM_NAMES)},
    problem TEXT, params_json TEXT, metrics_json TEXT,
    {_PK_SQL});
CREATE TABLE IF NOT EXISTS timings ({_KEY_SQL}, wall_s REAL, worker TEXT, finished_utc TEXT, {_PK_SQL});
CREATE TABLE IF NOT EXISTS traces ({_KEY_SQL}, nfev INTEGER, mse REAL);
CREATE INDEX IF NOT EXISTS traces_key ON traces (kind, specimen, optimizer, replicate);
CREATE TABLE IF NOT EXISTS chains (
    {_KEY_SQL}, steps INTEGER, walkers INTEGER, dim INTEGER, chain BLOB, log_prob BLOB,
    acceptance_fraction REAL, autocorr_json TEXT, {_PK_SQL});
"""


# ----------------------------------------------------------------------------------------- tasks

@dataclass(frozen=True)
class Task:
    """One run: everything a worker needs, picklable, no reference to the configuration file."""

    kind: str
    specimen: str  # file stem
    optimizer: str
    replicate: int  # 0-based
    entropy: int  # the study seed
    path: str  # specimen CSV
    state: str
    excitation: str
    budget: int
    options: dict  # resolved (defaults merged)
    material: str | None
    underpressure_MPa: float | None
    repeat: int | None
    problem: str = DEFAULT_PROBLEM  # for the benchmark, ``path`` is its data folder

    @property
    def key(self) -> tuple:
        return (self.kind, self.specimen, self.optimizer, self.replicate)


def task_seed(entropy: int, kind: str, specimen: str, optimizer: str, replicate: int) -> np.random.SeedSequence:
    """The seed of one run: a function of the study seed and the run's key only."""
    spawn_key = (zlib.crc32(kind.encode()), zlib.crc32(specimen.encode()),
                 zlib.crc32(optimizer.encode()), int(replicate))
    return np.random.SeedSequence(entropy=entropy, spawn_key=spawn_key)


def plan_tasks(config: StudyConfig) -> list[Task]:
    """Every run of the study: posterior runs first (the longest), then the ranking, replicate by
    replicate, so a study stopped early has every backend on the same specimens."""
    def task(kind, entry, optimizer, replicate, budget, options):
        return Task(kind, entry.name, optimizer, replicate, config.seed, entry.path, config.state,
                    config.excitation, budget, options, entry.material, entry.underpressure_MPa, entry.repeat,
                    config.problem)

    tasks = []
    p = config.posterior
    if p is not None:
        tasks += [task("posterior", entry, p.optimizer, r, p.budget, p.options)
                  for r in range(p.seeds) for entry in p.specimens]
    tasks += [task("ranking", entry, optimizer, r, config.budget, options)
              for r in range(config.seeds) for entry in config.specimens
              for optimizer, options in config.optimizers.items()]
    return tasks


def run_task(task: Task) -> dict:
    """Run one task; never raises for a failed run (status "error" with a one-line message).

    Returns a plain dict: ``key``, ``row`` (the ``runs`` columns), ``timing``, ``trace``
    (list of (nfev, mse)) and ``chain`` (None, or the ``chains`` columns).
    """
    import numba

    from bwbench.optimize import fitting

    row = dict.fromkeys(RUN_COLUMNS)
    row.update(kind=task.kind, specimen=task.specimen, optimizer=task.optimizer, replicate=task.replicate,
               seed_entropy=str(task.entropy), budget=task.budget, state=task.state,
               excitation=task.excitation, material=task.material,
               underpressure_MPa=task.underpressure_MPa, repeat=task.repeat,
               options_json=canonical_json(task.options), success=0, problem=task.problem)
    trace, chain = [], None
    # One numba thread per worker: the workers already fill the cores.
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    started = time.perf_counter()
    try:
        problem = make_problem(task)
        seed = task_seed(task.entropy, task.kind, task.specimen, task.optimizer, task.replicate)
        result = fitting.run(problem, task.optimizer, task.budget, seed, task.options)
        chain = _chain_columns(result.extras)
        metrics = problem_metrics(task.problem, problem, result)
    except Exception as err:  # a failed run is a result: record it, keep the study going
        row.update(status="error", error=" ".join(f"{type(err).__name__}: {err}".split()))
    else:
        row.update(status="ok", nfev=result.nfev, mse=result.mse, f_err=result.f_err,
                   success=int(result.success), message=result.message,
                   params_json=canonical_json({k: _json_number(v) for k, v in result.params.items()}),
                   metrics_json=canonical_json(metrics))
        if task.problem == DEFAULT_PROBLEM:
            row["rmse_N"] = result.rmse_N
            row.update({name: result.params.get(name) for name in PARAM_NAMES})
        trace = list(zip(result.trace_nfev, result.trace_mse, strict=True))
    finally:
        wall = time.perf_counter() - started
        numba.set_num_threads(threads)
    timing = {"wall_s": wall, "worker": f"{socket.gethostname()}:{os.getpid()}", "finished_utc": _utc_now()}
    return {"key": task.key, "row": row, "timing": timing, "trace": trace, "chain": chain}


def make_problem(task: Task):
    """The problem object of a task (what ``Objective`` wraps)."""
    if task.problem == BENCHMARK_PROBLEM:
        from bwbench.problems.noel_schoukens.problem import BoucWenBenchmarkProblem

        return BoucWenBenchmarkProblem(task.path)
    from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem
    from bwbench.data.specimen import read_specimen

    return SwitchedBoucWenProblem(read_specimen(task.path), task.state, task.excitation)


def problem_metrics(problem_name: str, problem, result) -> dict:
    """The problem-specific metrics of a run's best point (``metrics_json``); None = not finite.

    Benchmark: the e_RMS (m) of the best point on ``test_multisine`` and ``test_sinesweep`` and
    the training RMSE (m); the test files are used here only, never by the optimiser.
    """
    if problem_name != BENCHMARK_PROBLEM:
        return {}
    from bwbench.problems.noel_schoukens.problem import TEST_SETS

    params = np.array([result.params[name] for name in problem.param_names])
    metrics = {"train_rmse_m": _json_number(result.rmse_N)}  # sqrt(MSE): metres for this problem
    for which in TEST_SETS:
        error = problem.test_error(params, which) if np.all(np.isfinite(params)) else math.inf
        metrics[f"{which}_erms_m"] = _json_number(error)
    return metrics


def _json_number(x):
    x = float(x)
    return x if math.isfinite(x) else None  # JSON has no inf/NaN: null = not finite


def _chain_columns(extras: dict) -> dict | None:
    if extras.get("chain") is None:
        return None
    chain = np.ascontiguousarray(extras["chain"], dtype=np.float64)
    if chain.ndim != 3:
        raise ValueError(f"backend returned a chain of shape {chain.shape}, expected (steps, walkers, dim)")
    log_prob = extras.get("log_prob")
    acceptance = extras.get("acceptance_fraction")
    autocorr = extras.get("autocorr", extras.get("autocorr_time"))
    if autocorr is not None:
        autocorr = [float(a) if math.isfinite(a) else None for a in np.atleast_1d(np.asarray(autocorr, float))]
    steps, walkers, dim = chain.shape
    return {
        "steps": steps, "walkers": walkers, "dim": dim, "chain": chain.tobytes(),
        "log_prob": None if log_prob is None else np.ascontiguousarray(log_prob, dtype=np.float64).tobytes(),
        "acceptance_fraction": None if acceptance is None else float(np.mean(acceptance)),
        "autocorr_json": None if autocorr is None else json.dumps(autocorr),
    }


def _utc_now() -> str:
    return datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


# -------------------------------------------------------------------------------------- database

def open_database(path, config: StudyConfig) -> sqlite3.Connection:
    """Create the study database, or reopen it after checking it holds this very configuration.

    Raises ``UserError`` if the file is not a study database or was made by another configuration.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    conn = sqlite3.connect(path, timeout=60, isolation_level=None)  # transactions are explicit
    try:
        # One write transaction for check-and-create: two studies started at once on one new file
        # cannot both create it with different configurations.
        conn.execute("BEGIN IMMEDIATE")
        tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if tables and "study" not in tables:
            raise UserError(f"{path}: not a bwbench study database (no 'study' table); choose another --db")
        if "study" in tables:
            _check_same_study(conn, path, config)
            _add_generic_columns(conn)
        else:
            for statement in SCHEMA.split(";"):
                if statement.strip():
                    conn.execute(statement)
            conn.executemany("INSERT INTO study (key, value) VALUES (?, ?)", [
                ("name", config.name), ("config_json", config.canonical_json()),
                ("config_hash", config.config_hash), ("created_utc", _utc_now()),
                ("bwbench_version", __version__),
            ])
        if config.problem == BENCHMARK_PROBLEM:  # where the data are now: for the report, not the hash
            conn.execute("INSERT OR REPLACE INTO study (key, value) VALUES ('data_dir', ?)",
                         (str(Path(config.data_dir).resolve()),))
        conn.execute("COMMIT")
    except sqlite3.DatabaseError as err:
        conn.close()
        raise UserError(f"{path}: cannot use as a study database: {err}") from None
    except BaseException:
        conn.close()
        raise
    return conn


def _add_generic_columns(conn) -> None:
    """Give a database from before the generic columns existed those columns (NULL in old rows)."""
    present = {r[1] for r in conn.execute("PRAGMA table_info(runs)")}
    for column in GENERIC_COLUMNS:
        if column not in present:
            conn.execute(f"ALTER TABLE runs ADD COLUMN {column} TEXT")


def _check_same_study(conn, path, config: StudyConfig) -> None:
    stored = dict(conn.execute("SELECT key, value FROM study"))
    if stored.get("config_hash") == config.config_hash:
        if stored.get("bwbench_version") != __version__:
            print(f"note: {path} was started with bwbench {stored.get('bwbench_version')}, "
                  f"this is {__version__}", file=sys.stderr)
        return
    try:
        changes = describe_differences(json.loads(stored["config_json"]), config.to_json_dict())
    except (KeyError, TypeError, ValueError):
        changes = ["the stored configuration is unreadable"]
    shown = "; ".join(changes[:4]) + (f"; and {len(changes) - 4} more" if len(changes) > 4 else "")
    raise UserError(
        f"{config.path} differs from the study in {path} ({shown}): pass --db with another path "
        f"to keep both, or delete {path} to start over"
    )


def finished_keys(conn) -> set:
    return {tuple(r) for r in conn.execute("SELECT kind, specimen, optimizer, replicate FROM runs")}


def record_run(conn, outcome: dict) -> bool:
    """Write one finished run in one transaction; False (and nothing written) if already there."""
    key = outcome["key"]
    placeholders = ", ".join("?" * len(RUN_COLUMNS))
    columns = ", ".join(f'"{c}"' for c in RUN_COLUMNS)
    conn.execute("BEGIN IMMEDIATE")
    try:
        cursor = conn.execute(f"INSERT OR IGNORE INTO runs ({columns}) VALUES ({placeholders})",
                              [outcome["row"][c] for c in RUN_COLUMNS])
        if cursor.rowcount == 0:
            conn.execute("ROLLBACK")
            return False
        t = outcome["timing"]
        conn.execute("INSERT OR REPLACE INTO timings VALUES (?, ?, ?, ?, ?, ?, ?)",
                     (*key, t["wall_s"], t["worker"], t["finished_utc"]))
        conn.executemany("INSERT INTO traces VALUES (?, ?, ?, ?, ?, ?)",
                         [(*key, int(n), float(m)) for n, m in outcome["trace"]])
        c = outcome["chain"]
        if c is not None:
            conn.execute("INSERT OR REPLACE INTO chains VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
                         (*key, c["steps"], c["walkers"], c["dim"], c["chain"], c["log_prob"],
                          c["acceptance_fraction"], c["autocorr_json"]))
        conn.execute("COMMIT")
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    return True


# ------------------------------------------------------------------------------------- executing

@dataclass(frozen=True)
class StudyOutcome:
    total: int  # runs in the study
    already: int  # finished before this call
    recorded: int  # finished by this call
    errors: int  # of those, runs that raised
    lost: tuple  # (key, why) of runs whose worker died: not recorded, retried on the next call

    @property
    def complete(self) -> bool:
        return self.already + self.recorded == self.total


def run_study(config: StudyConfig, db, *, workers: int | None = None, scheduler: str | None = None,
              log=None) -> StudyOutcome:
    """Run every unfinished run of ``config`` and record it in the database ``db``.

    ``workers``: local processes (default ``os.cpu_count()``; 1 runs in this process);
    ``scheduler``: a Dask scheduler address instead. Progress goes to ``log`` (default stderr).
    """
    log = sys.stderr if log is None else log
    if workers is not None and workers < 1:
        raise UserError(f"--workers must be at least 1, got {workers}")
    tasks = plan_tasks(config)
    with closing(open_database(db, config)) as conn:
        done = finished_keys(conn)
        pending = [t for t in tasks if t.key not in done]
        already = len(tasks) - len(pending)
        if not pending:
            print(f"study {config.name}: all {len(tasks)} runs already in {db}", file=log)
            return StudyOutcome(len(tasks), already, 0, 0, ())
        workers = min(workers or os.cpu_count() or 1, len(pending))
        where = (f"the Dask cluster at {scheduler}" if scheduler
                 else "this process" if workers == 1 else f"{workers} local processes")
        print(f"study {config.name}: {len(tasks)} runs, {already} already in {db}, "
              f"{len(pending)} to run on {where}", file=log)
        outcomes = execute_tasks(pending, workers=workers, scheduler=scheduler)
        recorded = errors = 0
        lost = []
        with _Progress(len(pending), config.name, log) as progress:
            for outcome in outcomes:
                if "lost" in outcome:
                    lost.append((outcome["key"], outcome["lost"]))
                elif record_run(conn, outcome):
                    recorded += 1
                    errors += outcome["row"]["status"] == "error"
                progress.update(errors, len(lost))
    return StudyOutcome(len(tasks), already, recorded, errors, tuple(lost))


def execute_tasks(tasks, *, workers: int = 1, scheduler: str | None = None):
    """Yield ``run_task(task)`` of every task as it finishes, in completion order.

    On a Dask cluster if ``scheduler`` is given; else in this process (``workers=1``) or in a pool
    of ``workers`` spawned processes. A task whose worker died yields ``{"key": ..., "lost": why}``.
    """
    if scheduler:
        return _on_cluster(tasks, scheduler)
    if workers == 1:
        return map(run_task, tasks)
    return _in_pool(tasks, workers)


def _in_pool(tasks, workers):
    # spawn, not fork: numba's OpenMP threading layer kills a child forked from a process that has
    # already run parallel code (a test session, a notebook). It costs each worker ~2.5 s of imports.
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"))
    try:
        futures = {pool.submit(run_task, t): t for t in tasks}
        for future in as_completed(futures):
            yield _result_or_lost(future, futures.pop(future))  # pop: don't keep every result
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _on_cluster(tasks, address):
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise UserError("--scheduler needs the 'distributed' package (pip install distributed)") from None
    try:
        client = Client(address, timeout="20s")
    except (OSError, TimeoutError, ValueError) as err:
        raise UserError(f"cannot connect to the Dask scheduler at {address}: {err}") from None
    try:
        futures = {client.submit(run_task, t, pure=False): t for t in tasks}
        for future in dask_completed(futures):
            outcome = _result_or_lost(future, futures.pop(future))
            future.release()
            yield outcome
    finally:
        client.close()


def _result_or_lost(future, task) -> dict:
    # run_task never raises for a failed run: an exception here is the infrastructure's (a worker
    # died, a cluster went away). Such a run is not a result: leave it for the next call.
    try:
        return future.result()
    except Exception as err:
        return {"key": task.key, "lost": " ".join(f"{type(err).__name__}: {err}".split()) or type(err).__name__}


class _Progress:
    """A tqdm bar on a terminal; otherwise a plain line about every 10 % (logs, CI, nohup)."""

    def __init__(self, total: int, name: str, log):
        from tqdm import tqdm

        self.total, self.name, self.log = total, name, log
        self.interactive = hasattr(log, "isatty") and log.isatty()
        self.bar = tqdm(total=total, desc=name, unit="run", file=log, disable=not self.interactive,
                        dynamic_ncols=True)
        self.count, self.next_line, self.started = 0, 0.1, time.monotonic()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.bar.close()

    def update(self, errors: int, lost: int) -> None:
        self.count += 1
        self.bar.update(1)
        self.bar.set_postfix(errors=errors, **({"lost": lost} if lost else {}), refresh=False)
        fraction = self.count / self.total
        if self.interactive or (fraction < self.next_line and self.count < self.total):
            return
        while self.next_line <= fraction:
            self.next_line += 0.1
        elapsed = time.monotonic() - self.started
        rate = self.count / elapsed if elapsed > 0 else math.inf
        eta = (self.total - self.count) / rate if rate > 0 else math.inf
        print(f"{self.name}: {self.count}/{self.total} runs ({fraction:.0%}), {rate:.2f} runs/s, "
              f"ETA {_duration(eta)}, {errors} error{'s' if errors != 1 else ''}"
              + (f", {lost} lost (worker died)" if lost else ""), file=self.log, flush=True)


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


# --------------------------------------------------------------------------------------- reading

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


def summary_table(db) -> str:
    """Per backend (ranking runs only): median and best RMSE (N, or m for the benchmark), success
    rate, median evaluations, errors; for the benchmark also the median test_multisine e_RMS and
    the number of runs below the 1e-5 m target. Best median RMSE first."""
    runs = read_runs(db)
    runs = runs[runs["kind"] == "ranking"]
    if runs.empty:
        return "no ranking runs recorded"
    benchmark = "problem" in runs and (runs["problem"] == BENCHMARK_PROBLEM).any()
    unit, number = ("m", "{:.2e}") if benchmark else ("N", "{:.3f}")
    header = ("optimizer", "runs", f"median RMSE ({unit})", f"best RMSE ({unit})", "success", "median nfev", "errors")
    if benchmark:
        header += ("median test e_RMS (m)", f"test < {TARGET_ERMS_M:g} m")
    stats = []
    for optimizer, group in runs.groupby("optimizer", sort=False):
        mse = group["mse"].astype(float)
        ok = group[(group["status"] == "ok") & np.isfinite(mse)]
        rmse = np.sqrt(ok["mse"].astype(float))
        extra = ()
        if benchmark:
            test = _metric(group, "test_multisine_erms_m")
            extra = ("-" if not np.isfinite(test).any() else f"{np.nanmedian(test):.2e}",
                     f"{int((test < TARGET_ERMS_M).sum())}/{len(group)}")
        stats.append((rmse.median() if len(ok) else math.inf, optimizer, len(group), rmse.min() if len(ok) else None,
                      len(ok) / len(group), ok["nfev"].median() if len(ok) else None,
                      int((group["status"] == "error").sum()), extra))
    stats.sort(key=lambda r: (r[0], r[1]))
    lines = [(optimizer, str(n), "-" if best is None else number.format(median),
              "-" if best is None else number.format(best), f"{success:.0%}", "-" if nfev is None else f"{nfev:.0f}",
              str(n_errors), *extra)
             for median, optimizer, n, best, success, nfev, n_errors, extra in stats]
    widths = [max(len(r[i]) for r in [header, *lines]) for i in range(len(header))]

    def fmt(cells):  # first column left-aligned, numbers right-aligned
        padded = (c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(cells, widths, strict=True)))
        return "  ".join(padded)

    return "\n".join([fmt(header), *map(fmt, lines)])


TARGET_ERMS_M = 1e-5  # the benchmark's target: below the best published black-box e_RMS (1.2e-5 m)


def _metric(runs, name: str) -> np.ndarray:
    """One metric of ``metrics_json`` per run (NaN where absent or not finite)."""
    def value(text):
        if not isinstance(text, str):
            return math.nan
        x = json.loads(text).get(name)
        return math.nan if x is None else float(x)

    return np.array([value(t) for t in runs["metrics_json"]], dtype=float)


# ------------------------------------------------------------------------------------ entry point

def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", required=True, help="study TOML (e.g. studies/quick.toml)")
    parser.add_argument("--db", help="SQLite database (default: reports/<name>/study.sqlite under the repository)")
    parser.add_argument("--workers", type=int, help="local worker processes (default: all cores; 1 = in-process)")
    parser.add_argument("--scheduler", help="Dask scheduler address (tcp://HOST:PORT) instead of local workers")
    parser.add_argument("--csv", help="also write the runs (with timings) as a CSV file")
    parser.add_argument("--data", help="data folder, replacing the configuration's [study] data (relative to the "
                                       "current directory); for bouc-wen-benchmark the folder of its three CSVs")


def main(args) -> int:
    """``bwbench compare``: run (or resume) a study, print the ranking, optionally export CSV.

    Exit status 0 when every run is recorded (including runs that raised: status "error"),
    1 when some runs were lost to a dead worker (run again to retry them), 130 on Ctrl-C.
    Raises ``UserError`` for a bad configuration or option.
    """
    if args.workers is not None and args.scheduler:
        raise UserError("--workers and --scheduler exclude each other: a cluster brings its own workers")
    config = load_study_config(args.config, data=getattr(args, "data", None))
    db = Path(args.db) if args.db else config.default_db
    try:
        outcome = run_study(config, db, workers=args.workers, scheduler=args.scheduler)
    except KeyboardInterrupt:
        print(f"interrupted: finished runs are in {db}; run the same command again to resume", file=sys.stderr)
        return 130
    print(f"\nstudy {config.name}: {outcome.already + outcome.recorded}/{outcome.total} runs in {db}")
    print(summary_table(db))
    if args.csv:
        export_csv(db, args.csv)
        print(f"wrote {args.csv}")
    if outcome.lost:
        key, why = outcome.lost[0]
        print(f"error: {len(outcome.lost)} run(s) lost to a failed worker (first: {'/'.join(map(str, key))}: "
              f"{why}); run the same command again to retry them", file=sys.stderr)
        return 1
    return 0


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
