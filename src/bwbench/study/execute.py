"""Running a study: every unfinished run, in a local process pool, in-process or on a Dask cluster.

Tasks run in a local process pool (default: all cores; ``bwbench.study.pool``), in-process
(``workers=1``) or on a Dask cluster (``scheduler="tcp://HOST:PORT"``; ``bwbench.study.cluster``;
start its workers with ``--nthreads 1``, one per core: the backends are partly Python and hold the
GIL). Only the main process writes the SQLite database, one transaction per finished run, and only
one process at a time (``bwbench.study.lock``). Running the same command again skips the finished
runs (those that succeeded and those that failed deterministically, ``bwbench.study.failures``), so
a killed study loses at most the runs that were in flight.
"""

from __future__ import annotations

import math
import os
import sqlite3
import sys
import time
from contextlib import closing
from dataclasses import dataclass

import bwbench.limits as limits
from bwbench.database.writer import (
    database_fault,
    failed_runs,
    finished_keys,
    open_database,
    prepare_database_path,
    record_run,
)
from bwbench.errors import UserError
from bwbench.study.cluster import SchedulerLost, on_cluster, reach
from bwbench.study.config import StudyConfig
from bwbench.study.lock import StudyLock
from bwbench.study.pool import in_pool
from bwbench.study.stop import StudyStopped
from bwbench.study.tasks import plan_tasks, refuse_plugins_only_here, run_task


@dataclass(frozen=True)
class StudyOutcome:
    total: int  # runs in the study
    already: int  # finished before this call
    recorded: int  # finished by this call
    errors: int  # of those, runs that failed deterministically (status "error")
    lost: tuple  # (key, why) of runs with no result (dead worker, fault of the environment): retried next call
    failed: tuple = ()  # (key, error) of every run of the study recorded as an error, this call's included

    @property
    def complete(self) -> bool:
        return self.already + self.recorded == self.total


def run_study(
    config: StudyConfig, db, *, workers: int | None = None, scheduler: str | None = None, log=None, threads: int = 1
) -> StudyOutcome:
    """Run every unfinished run of ``config`` and record it in the database ``db``.

    ``workers``: local processes (default ``os.cpu_count()``; 1 runs in this process);
    ``scheduler``: a Dask scheduler address instead; ``threads``: numba/BLAS threads of each local run
    (``bwbench.threads``; a Dask worker runs one). Progress goes to ``log`` (default stderr).
    Raises ``UserError`` before any run starts if ``db`` cannot be used (another study's, read-only,
    being written by another ``compare``, ...), and ``StudyStopped`` if the study cannot go on (the
    database fails mid-study, the cluster is lost): the runs recorded so far stay.
    """
    log = sys.stderr if log is None else log
    if workers is not None and workers < 1:
        raise UserError(f"--workers must be at least 1, got {workers}")
    if workers is not None:
        limits.check(
            "--workers",
            workers,
            "BWBENCH_MAX_WORKERS",
            f" (4 per core: more processes only compete for the {os.cpu_count()} cores, ~0.15 GB each)",
        )
    tasks = plan_tasks(config)
    if scheduler or (workers or os.cpu_count() or 1) > 1:  # other processes run the tasks: can they load them?
        refuse_plugins_only_here(tasks, f"the Dask cluster at {scheduler}" if scheduler else "its worker processes")
    if scheduler:  # before the database is touched: a scheduler that is not there is one line, nothing written
        reach(scheduler)
    db = prepare_database_path(db)
    resume = f"finished runs are in {db}, run the same command again to resume"
    with (
        StudyLock(db),
        closing(open_database(db, config, planned_runs=len(tasks), backends=backend_facts(config))) as conn,
    ):
        try:
            return _run_pending(config, db, conn, tasks, workers, scheduler, log, threads)
        except sqlite3.Error as err:  # a full disk, an I/O error: what was committed stays
            raise StudyStopped(f"{database_fault(db, err)}; {resume}", status=2) from None
        except SchedulerLost as err:
            raise StudyStopped(f"{err}; {resume}", status=1) from None


def _run_pending(config, db, conn, tasks, workers, scheduler, log, threads=1) -> StudyOutcome:
    done = finished_keys(conn)
    pending = [t for t in tasks if t.key not in done]
    already = len(tasks) - len(pending)
    if not pending:
        print(f"study {config.name}: all {len(tasks)} runs already in {db}", file=log)
        return StudyOutcome(len(tasks), already, 0, 0, (), tuple(failed_runs(conn)))
    workers = min(workers or os.cpu_count() or 1, len(pending))
    where = (
        f"the Dask cluster at {scheduler}"
        if scheduler
        else "this process"
        if workers == 1
        else f"{workers} local processes"
    )
    print(
        f"study {config.name}: {len(tasks)} runs, {already} already in {db}, {len(pending)} to run on {where}", file=log
    )
    recorded = errors = 0
    lost = []
    # closing(): leaving early (an error, Ctrl-C, SIGTERM) stops the workers at once.
    with (
        closing(execute_tasks(pending, workers=workers, scheduler=scheduler, threads=threads)) as outcomes,
        _Progress(len(pending), config.name, log) as progress,
    ):
        for outcome in outcomes:
            if "retried" in outcome:  # not a result: its run is queued again
                progress.note(
                    f"a worker died ({outcome['retried']}) during run {_describe(outcome['key'])}; running it again"
                )
                continue
            if "lost" in outcome:
                lost.append((outcome["key"], outcome["lost"]))
            elif record_run(conn, outcome):
                recorded += 1
                errors += outcome["row"]["status"] == "error"
            progress.update(errors, len(lost))
    return StudyOutcome(len(tasks), already, recorded, errors, tuple(lost), tuple(failed_runs(conn)))


def _describe(key) -> str:
    kind, specimen, optimizer, replicate = key
    return f"{optimizer} on {specimen}, replicate {replicate}" + (f" ({kind})" if kind != "ranking" else "")


def execute_tasks(tasks, *, workers: int = 1, scheduler: str | None = None, threads: int = 1):
    """Yield ``run_task(task)`` of every task as it finishes, in completion order.

    On a Dask cluster if ``scheduler`` is given; else in this process (``workers=1``) or in a pool
    of ``workers`` spawned processes. A task with no result (its worker died, or a fault of the
    environment, ``bwbench.study.failures``) yields ``{"key": ..., "lost": why}``.
    """
    if scheduler:
        return on_cluster(tasks, scheduler)
    if workers == 1:
        return (run_task(t, threads) for t in tasks)  # a generator, like the others: closing() works on all
    return in_pool(tasks, workers, threads)


class _Progress:
    """A tqdm bar on a terminal; otherwise a plain line about every 10 % (logs, CI, nohup)."""

    def __init__(self, total: int, name: str, log):
        from tqdm import tqdm

        self.total, self.name, self.log = total, name, log
        self.interactive = hasattr(log, "isatty") and log.isatty()
        self.bar = tqdm(total=total, desc=name, unit="run", file=log, disable=not self.interactive, dynamic_ncols=True)
        self.count, self.next_line, self.started = 0, 0.1, time.monotonic()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.bar.close()

    def note(self, text: str) -> None:
        """A line between the progress updates (above the bar on a terminal)."""
        if self.interactive:
            self.bar.write(text, file=self.log)
        else:
            print(text, file=self.log, flush=True)

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
        print(
            f"{self.name}: {self.count}/{self.total} runs ({fraction:.0%}), {rate:.2f} runs/s, "
            f"ETA {_duration(eta)}, {errors} error{'s' if errors != 1 else ''}"
            + (f", {lost} not finished (retried on the next call)" if lost else ""),
            file=self.log,
            flush=True,
        )


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "?"
    seconds = int(round(seconds))
    return f"{seconds // 3600}:{seconds // 60 % 60:02d}:{seconds % 60:02d}"


def backend_facts(config) -> str:
    """JSON {backend: {"family", "batched"}} of the study's backends (ranking and posterior)."""
    from bwbench.engine import registry

    names = [*config.optimizers, *([config.posterior.optimizer] if config.posterior else [])]
    facts = {}
    for name in dict.fromkeys(names):
        backend = registry.get(name)
        facts[name] = {"family": backend.family, "batched": bool(backend.batched)}
    import json

    return json.dumps(facts, sort_keys=True)
