"""The study runner when its processes go wrong: killed (SIGKILL, SIGTERM), run twice on one
database, its Dask scheduler gone, its output pipe closed. Timeouts are hang detectors only."""

from __future__ import annotations

import io
import os
import re
import signal
import sqlite3
import subprocess
import sys
import time
from contextlib import closing

import psutil
import pytest

from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study
from bwbench.study.lock import StudyLock, lock_path
from robustness_helpers import (
    HANG,
    KEYS,
    REPO,
    RUN_COMPARE,
    alive,
    count_runs,
    run_compare,
    start_compare,
    wait_for,
    write_config,
)

# ------------------------------------------------------------------------------ 1. no orphans


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_a_killed_study_leaves_no_process_behind_and_resumes(tmp_path, sig):
    config = write_config(tmp_path / "kill.toml")
    db = tmp_path / "kill.sqlite"
    process = start_compare("--config", config, "--db", db, "--workers", "2")
    try:
        wait_for(lambda: count_runs(db) >= 1, process, "committed run")
        study = psutil.Process(process.pid)
        started = study.children(recursive=True)  # the two workers and the resource tracker
        commands = [" ".join(p.cmdline()) for p in started]
        assert sum("spawn_main" in c for c in commands) == 2 and sum("resource_tracker" in c for c in commands) == 1
        process.send_signal(sig)
        process.wait(timeout=HANG)
        stderr = process.stderr.read()
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
        process.stderr.close()

    deadline = time.monotonic() + 60  # a grace period for the kernel to deliver the death signals
    while any(alive(p) for p in started) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = [" ".join(p.cmdline()) for p in started if alive(p)]
    assert not left, f"left behind: {left}"
    assert not [p.pid for p in psutil.process_iter() if alive(p) and str(db) in " ".join(_cmdline(p))]
    if sig == signal.SIGTERM:
        assert process.returncode == 128 + signal.SIGTERM
        assert stderr.splitlines()[-1] == (
            f"terminated (SIGTERM): finished runs are in {db}; run the same command again to resume"
        )
        assert "Traceback" not in stderr and "leaked" not in stderr
        assert not lock_path(db).exists()  # a clean exit removes its lock file
    else:
        assert process.returncode == -signal.SIGKILL

    killed_at = count_runs(db)
    assert 1 <= killed_at < 24, "the study must be killed part-way for this test to mean anything"
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone() == ("ok",)
    outcome = run_study(load_study_config(config), db, workers=1, log=io.StringIO())
    assert (outcome.already, outcome.recorded, outcome.complete) == (killed_at, 24 - killed_at, True)
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute(f"SELECT COUNT(*) FROM (SELECT DISTINCT {KEYS} FROM runs)").fetchone() == (24,)


def _cmdline(process) -> list:
    try:
        return process.cmdline()
    except (psutil.NoSuchProcess, psutil.AccessDenied, psutil.ZombieProcess):
        return []


def test_a_worker_dies_with_its_parent_and_so_does_what_it_forks(tmp_path):
    """The pool initializer's guarantee, without a pool: a process that called ``die_with_parent``
    is killed when its parent is, and a child it forked afterwards too."""
    pids = tmp_path / "pids"
    parent_code = f"""
import os, subprocess, sys, time
child = subprocess.Popen([sys.executable, "-c", '''
import os, time
from bwbench.study.pool import die_with_parent
die_with_parent(os.getppid())
grandchild = os.fork()
if grandchild == 0:
    time.sleep(600)
    os._exit(0)
open({str(pids)!r}, "w").write(f"{{os.getpid()}} {{grandchild}}")
time.sleep(600)
'''])
time.sleep(600)
"""
    parent = subprocess.Popen([sys.executable, "-c", parent_code])
    try:
        wait_for(lambda: pids.exists() and len(pids.read_text().split()) == 2, parent, "pids")
        child, grandchild = (psutil.Process(int(p)) for p in pids.read_text().split())
        assert alive(child) and alive(grandchild)
        parent.kill()
    finally:
        parent.kill()
        parent.wait()
    deadline = time.monotonic() + 60
    while (alive(child) or alive(grandchild)) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not alive(child) and not alive(grandchild)


# ------------------------------------------------------------------------------ 2. one writer


def test_a_second_compare_on_a_database_being_written_is_refused(tmp_path):
    # A posterior run far longer than this test comes first: the study holds the database all along.
    config = write_config(
        tmp_path / "lock.toml",
        seeds=1,
        optimizers="random = {}",
        underpressures="[0.01]",
        extra='[posterior]\nspecimens = ["pom-mt24u01_0.01MPa_r1"]\noptimizer = "random"\nbudget = 100000000\n',
    )
    db = tmp_path / "lock.sqlite"
    first = start_compare("--config", config, "--db", db, "--workers", "1")
    try:
        wait_for(
            lambda: lock_path(db).is_file() and lock_path(db).read_text().strip() == str(first.pid), first, "lock file"
        )
        wait_for(lambda: db.is_file() and count_runs(db) == 0 and _has_study(db), first, "database")
        before = db.read_bytes()
        second = run_compare("--config", config, "--db", db, "--workers", "1")
        assert second.returncode == 2
        *said, refusal = second.stderr.splitlines()
        assert refusal == (
            f"error: {db}: another bwbench compare (pid {first.pid}) is writing this study; "
            "wait for it or pass another --db"
        )
        assert all(line.startswith("warning: [posterior]") for line in said), said  # the config's, read first
        assert db.read_bytes() == before  # nothing written
        assert first.poll() is None  # and the first study goes on
        first.kill()  # SIGKILL: the lock must die with it
        first.wait(timeout=HANG)
    finally:
        if first.poll() is None:
            first.kill()
            first.wait()
        first.stderr.close()
    assert lock_path(db).exists()  # left behind by SIGKILL, but not locked:
    with StudyLock(db):
        pass
    assert not lock_path(db).exists()


def _has_study(db) -> bool:
    try:
        with closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5)) as conn:
            return conn.execute("SELECT value FROM study WHERE key = 'planned_runs'").fetchone() == ("2",)
    except sqlite3.Error:
        return False


def test_the_lock_is_exclusive_within_one_process_too(tmp_path):
    db = tmp_path / "x.sqlite"
    with StudyLock(db):
        assert lock_path(db).read_text() == f"{os.getpid()}\n"
        with pytest.raises(Exception, match=rf"another bwbench compare \(pid {os.getpid()}\)"):
            with StudyLock(db):
                pass
    with StudyLock(db):  # released
        pass


# ------------------------------------------------------------------------------ 7. a lost Dask scheduler


def test_a_lost_dask_scheduler_ends_with_one_line_and_the_study_resumes(tmp_path):
    from distributed import LocalCluster

    config = write_config(tmp_path / "dask.toml")
    db = tmp_path / "dask.sqlite"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        address = cluster.scheduler_address
        process = start_compare("--config", config, "--db", db, "--scheduler", address)
        try:
            wait_for(lambda: count_runs(db) >= 1, process, "committed run")
            cluster.close()
            process.wait(timeout=HANG)
            stderr = process.stderr.read()
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
            process.stderr.close()
    assert process.returncode == 1, stderr
    lines = stderr.splitlines()
    assert lines[0] == f"study tiny: 24 runs, 0 already in {db}, 24 to run on the Dask cluster at {address}"
    assert lines[-1] == (
        f"error: lost the Dask scheduler at {address}: the connection closed; finished runs are "
        f"in {db}, run the same command again to resume"
    )
    # A LocalCluster retires its workers before its scheduler: a run in flight may be reported lost first.
    progress = re.compile(r"tiny: \d+/24 runs \(\d+%\), .* errors?(, \d+ not finished \(retried on the next call\))?$")
    assert all(progress.match(line) for line in lines[1:-1]), stderr  # nothing else: no traceback, no logging
    done = count_runs(db)
    assert 1 <= done < 24
    outcome = run_study(load_study_config(config), db, workers=1, log=io.StringIO())
    assert outcome.complete and outcome.already == done


# ------------------------------------------------------------------------------ 8. a closed pipe


def test_output_into_a_closed_pipe_is_not_an_error(tiny_db, tmp_path):
    """``compare ... | head -1``: the reader leaves early; the study is recorded, nothing is printed
    about the pipe, and the exit status is the study's."""
    config, reference = tiny_db
    db = tmp_path / "copy.sqlite"
    db.write_bytes(reference.read_bytes())
    process = subprocess.Popen(
        [sys.executable, str(RUN_COMPARE), "--config", str(config), "--db", str(db)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    process.stdout.close()  # the reader is gone before the first line
    _, stderr = process.communicate(timeout=HANG)
    assert process.returncode == 0, stderr
    assert stderr.strip() == f"study tiny: all 6 runs already in {db}"
