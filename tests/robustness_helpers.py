"""Driving a real study for the robustness tests (``tests/study/test_robustness*.py``).

Timeouts here are hang detectors only (the machine may be slow and shared); nothing asserts how
fast anything is.
"""

from __future__ import annotations

import io
import os
import signal
import sqlite3
import subprocess
import sys
import time
from contextlib import closing
from pathlib import Path

import psutil
import pytest

from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study

REPO = Path(__file__).resolve().parents[1]
RUN_COMPARE = REPO / "studies" / "run_compare.py"
DATA = REPO / "data" / "specimens"
HANG = 300  # s: only to turn a hang into a failure, never a speed requirement
KEYS = "kind, specimen, optimizer, replicate"


def write_config(
    path: Path,
    *,
    budget=200,
    seeds=4,
    optimizers="random = {}\nfirefly = {}",
    underpressures="[0.01, 0.05, 0.09]",
    extra="",
) -> Path:
    """3 specimens x 2 backends x 4 seeds = 24 runs of 200 evaluations by default."""
    path.write_text(
        f"""
[study]
name = "tiny"
seed = 11
budget = {budget}
seeds = {seeds}
data = "{DATA.as_posix()}"

[specimens]
material = ["POM MT24u01"]
underpressure_MPa = {underpressures}
repeat = [1]

[optimizers]
{optimizers}
{extra}
""",
        encoding="utf-8",
    )
    return path


def start_compare(*args) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, str(RUN_COMPARE), *map(str, args)],
        cwd=REPO,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )


def run_compare(*args, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, str(RUN_COMPARE), *map(str, args)],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=HANG,
        **kwargs,
    )


def count_runs(db) -> int:
    try:
        with closing(sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5)) as conn:
            return conn.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    except sqlite3.Error:  # not created yet
        return 0


def wait_for(condition, process=None, what="the condition") -> None:
    deadline = time.monotonic() + HANG
    while not condition():
        assert process is None or process.poll() is None, f"the study ended before {what}: {process.stderr.read()}"
        assert time.monotonic() < deadline, f"hang: no {what} after {HANG} s"
        time.sleep(0.05)


def alive(process: psutil.Process) -> bool:
    try:  # a zombie holds no memory: it only waits for a reaper (this container's pid 1 may not be one)
        return process.is_running() and process.status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def rows(db, table="runs") -> list:
    with closing(sqlite3.connect(db)) as conn:
        return conn.execute(f"SELECT * FROM {table} ORDER BY {KEYS}").fetchall()


def one_error_line(err: str, *parts) -> str:
    """The one line ``error: ...`` that ``err`` must be, containing every one of ``parts``."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    for part in parts:
        assert part in lines[0], err
    return lines[0]


@pytest.fixture(scope="module")
def tiny_db(tmp_path_factory):
    """A small finished study (6 runs) and its configuration."""
    folder = tmp_path_factory.mktemp("tiny")
    config = write_config(folder / "tiny.toml", budget=100, seeds=1)
    db = folder / "tiny.sqlite"
    assert run_study(load_study_config(config), db, workers=1, log=io.StringIO()).complete
    return config, db


class KeyOnly:
    """A stand-in task for the pool's own tests: only a key."""

    def __init__(self, key):
        self.key = key


def die_or_echo(task, threads):
    """A stand-in ``run_task`` (module level, so a spawned worker can import it): SIGKILLs its own
    worker for a task whose optimizer is "killer", else returns the key after 0.1 s."""
    if task.key[2] == "killer":
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.1)
    return {"key": task.key, "echo": threads}
