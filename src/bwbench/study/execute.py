"""Running a study: every unfinished run, in a local process pool, in-process or on a Dask cluster.

Tasks run in a local process pool (default: all cores), in-process (``workers=1``) or on a Dask
cluster (``scheduler="tcp://HOST:PORT"``; start its workers with ``--nthreads 1``, one per core:
the backends are partly Python and hold the GIL). Only the main process writes the SQLite database,
one transaction per finished run; running the same command again skips the finished runs (those
that succeeded and those that raised), so a killed study loses at most the runs that were in flight.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import closing
from dataclasses import dataclass

from bwbench.errors import UserError
from bwbench.study.config import StudyConfig
from bwbench.study.store import finished_keys, open_database, record_run
from bwbench.study.tasks import plan_tasks, run_task


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

