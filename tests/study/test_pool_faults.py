"""Faults of the local pool: a worker SIGKILLed mid-study costs only its own run, which is run again
in the same ``compare`` call; the study ends complete, and its results are those of an uninterrupted
study. Timeouts are hang detectors only."""

from __future__ import annotations

import io
import signal
import sqlite3
from contextlib import closing

import psutil

from bwbench.study import pool
from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study
from robustness_helpers import HANG, KeyOnly, count_runs, die_or_echo, rows, start_compare, wait_for, write_config


def _workers(process) -> list:
    return [p for p in psutil.Process(process.pid).children() if "spawn_main" in " ".join(p.cmdline())]


def test_a_killed_worker_costs_only_its_run_and_the_results_are_an_uninterrupted_studys(tmp_path):
    # 6 runs of ~2 s each: a worker is caught between two runs (its idle time is milliseconds) so rarely
    # that the kill lands on a run in flight, as the retry message below checks.
    config = write_config(tmp_path / "kill.toml", budget=3000, seeds=1)
    reference = tmp_path / "reference.sqlite"
    assert run_study(load_study_config(config), reference, workers=1, log=io.StringIO()).complete

    db = tmp_path / "killed.sqlite"
    process = start_compare("--config", config, "--db", db, "--workers", "2")
    try:
        wait_for(lambda: count_runs(db) >= 1, process, "a committed run")
        victim, other = _workers(process)
        victim.send_signal(signal.SIGKILL)
        _, stderr = process.communicate(timeout=HANG)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()

    assert process.returncode == 0, stderr  # every run recorded: nothing lost, nothing failed
    assert "Traceback" not in stderr
    assert "a worker died (killed by SIGKILL) during run" in stderr and "running it again" in stderr, stderr
    with closing(sqlite3.connect(db)) as conn:
        pids = {int(w.rsplit(":", 1)[1]) for (w,) in conn.execute("SELECT worker FROM timings")}
    assert other.pid in pids and len(pids - {victim.pid, other.pid}) == 1  # one new worker replaced the dead one
    assert count_runs(db) == 6
    assert rows(db) == rows(reference)  # the runs table holds no time: identical, byte for byte
    assert rows(db, "traces") == rows(reference, "traces")


def test_a_run_that_kills_every_worker_it_gets_is_lost_after_two_tries_and_the_others_finish():
    """The pool, without a study: a task whose worker dies each time is given up after ``TRIES``."""
    killer = ("ranking", "s", "killer", 0)
    tasks = [KeyOnly(("ranking", "s", "ok", i)) for i in range(3)] + [KeyOnly(killer)]
    outcomes = list(pool.in_pool(tasks, workers=2, run=die_or_echo))
    assert sorted(o["key"] for o in outcomes if "echo" in o) == [("ranking", "s", "ok", i) for i in range(3)]
    assert [o["key"] for o in outcomes if "retried" in o] == [killer] * (pool.TRIES - 1)
    lost = [o for o in outcomes if "lost" in o]
    assert [o["key"] for o in lost] == [killer] and "killed by SIGKILL" in lost[0]["lost"]
