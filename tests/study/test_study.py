"""The comparison study runner: resumable after SIGKILL, identical results on any number of workers
or a Dask cluster, failed runs recorded, bad configurations refused with one line."""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import sys
import time
from contextlib import closing
from pathlib import Path

import pandas as pd
import pytest

import robustness_helpers
from bwbench.commands.compare import run_cli
from bwbench.commands.compare_run import export_csv
from bwbench.engine import registry
from bwbench.errors import UserError
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study
from bwbench.study.tasks import plan_tasks, task_seed
from robustness_helpers import REPO, RUN_COMPARE

KEY_ORDER = "ORDER BY kind, specimen, optimizer, replicate"


def write_config(path: Path, *, budget=400, seeds=2, **options) -> Path:
    """A tiny study: 3 specimens × 2 backends × 2 seeds = 12 runs of 400 evaluations by default."""
    return robustness_helpers.write_config(path, budget=budget, seeds=seeds, **options)


def rows(db, table="runs") -> list:
    order = KEY_ORDER + (", nfev" if table == "traces" else "")
    with closing(sqlite3.connect(db)) as conn:
        return conn.execute(f"SELECT * FROM {table} {order}").fetchall()


def run_compare(*args, **kwargs) -> subprocess.Popen | subprocess.CompletedProcess:
    command = [sys.executable, str(RUN_COMPARE), *map(str, args)]
    if kwargs.pop("background", False):
        return subprocess.Popen(command, cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    return subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    """The tiny study's configuration and its uninterrupted, in-process reference database."""
    folder = tmp_path_factory.mktemp("tiny")
    config_path = write_config(folder / "tiny.toml")
    db = folder / "reference.sqlite"
    outcome = run_study(load_study_config(config_path), db, workers=1, log=io.StringIO())
    assert outcome.complete and outcome.recorded == 12 and outcome.errors == 0
    return config_path, db


def test_sigkill_then_resume_gives_the_uninterrupted_rows(tiny, tmp_path):
    config_path, reference = tiny
    db = tmp_path / "killed.sqlite"
    process = run_compare("--config", config_path, "--db", db, "--workers", "1", background=True)
    try:
        committed = 0
        deadline = time.monotonic() + 60
        while committed < 2 and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.01)
            if db.exists():
                try:
                    with closing(sqlite3.connect(db, timeout=5)) as conn:
                        committed = conn.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
                except sqlite3.OperationalError:  # tables not created yet
                    pass
        os.kill(process.pid, signal.SIGKILL)
    finally:
        process.wait(timeout=30)
        process.stderr.close()
    assert process.returncode == -signal.SIGKILL
    killed_at = len(rows(db))
    assert 2 <= killed_at < 12, "the study must be killed part-way for this test to mean anything"

    resumed = run_compare("--config", config_path, "--db", db, "--workers", "1")
    assert resumed.returncode == 0, resumed.stderr
    assert f"{killed_at} already in" in resumed.stderr
    with closing(sqlite3.connect(db)) as conn:
        counts = conn.execute("SELECT COUNT(*) FROM runs GROUP BY kind, specimen, optimizer, replicate").fetchall()
        n_timings = conn.execute("SELECT COUNT(*) FROM timings").fetchone()[0]
    assert counts == [(1,)] * 12 and n_timings == 12
    assert rows(db) == rows(reference)
    assert rows(db, "traces") == rows(reference, "traces")


def test_one_two_workers_and_a_dask_cluster_give_identical_rows(tiny, tmp_path):
    from distributed import LocalCluster

    config_path, reference = tiny
    config = load_study_config(config_path)
    quiet = io.StringIO()
    two = tmp_path / "two.sqlite"
    assert run_study(config, two, workers=2, log=quiet).complete
    cluster_db = tmp_path / "cluster.sqlite"
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        assert run_study(config, cluster_db, scheduler=cluster.scheduler_address, log=quiet).complete
    expected = rows(reference)
    assert rows(two) == expected
    assert rows(cluster_db) == expected
    assert rows(cluster_db, "traces") == rows(reference, "traces")
    with closing(sqlite3.connect(two)) as conn:  # the work was really spread over two processes
        assert conn.execute("SELECT COUNT(DISTINCT worker) FROM timings").fetchone()[0] == 2


def test_a_run_does_not_depend_on_the_other_runs_of_the_study(tiny, tmp_path):
    _, reference = tiny
    config = load_study_config(
        write_config(tmp_path / "one.toml", seeds=1, optimizers="random = {}", underpressures="[0.05]")
    )
    db = tmp_path / "one.sqlite"
    run_study(config, db, workers=1, log=io.StringIO())
    (row,) = rows(db)
    assert row in rows(reference)


def test_task_seed_depends_on_the_key_only():
    a = task_seed(11, "ranking", "s", "random", 0).generate_state(4)
    assert (a == task_seed(11, "ranking", "s", "random", 0).generate_state(4)).all()
    for other in [
        task_seed(12, "ranking", "s", "random", 0),
        task_seed(11, "posterior", "s", "random", 0),
        task_seed(11, "ranking", "t", "random", 0),
        task_seed(11, "ranking", "s", "pso", 0),
        task_seed(11, "ranking", "s", "random", 1),
    ]:
        assert (other.generate_state(4) != a).any()


def test_finished_study_is_skipped_and_exports_a_tidy_table(tiny, tmp_path):
    config_path, reference = tiny
    db = tmp_path / "copy.sqlite"
    shutil.copy(reference, db)
    outcome = run_study(load_study_config(config_path), db, workers=1, log=io.StringIO())
    assert (outcome.already, outcome.recorded) == (12, 0)
    assert rows(db) == rows(reference)

    runs = pd.read_sql("SELECT * FROM runs", sqlite3.connect(db))
    # parameters live in params_json, not in columns named after one model
    assert len(runs) == 12 and not set(PARAM_NAMES) & set(runs.columns) and "wall_s" not in runs.columns
    assert set(json.loads(runs["params_json"][0])) == set(PARAM_NAMES)
    csv = tmp_path / "runs.csv"
    export_csv(db, csv)
    table = pd.read_csv(csv)
    assert len(table) == 12 and {"wall_s", "worker", "finished_utc", "rmse_N", "A+"} <= set(table.columns)
    assert (table["status"] == "ok").all() and (table["nfev"] == 400).all()


def test_a_changed_configuration_is_refused_naming_what_changed(tiny, tmp_path):
    _, reference = tiny
    db = tmp_path / "study.sqlite"
    shutil.copy(reference, db)
    changed = write_config(tmp_path / "changed.toml", budget=300, optimizers="random = {}\npaper-ga = {}")
    result = run_compare("--config", changed, "--db", db, "--workers", "1")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), result.stderr
    assert "study.budget: 400 -> 300" in lines[0]
    # a removed backend is a conflict; an added one alone would extend the study (tests/study/test_own_data.py)
    assert "optimizers.firefly removed" in lines[0] and "paper-ga" not in lines[0]
    assert "--db" in lines[0] and "delete" in lines[0]
    assert rows(db) == rows(reference)  # nothing written


def test_unknown_backend_exits_2_with_one_line_listing_the_available(tmp_path):
    config = write_config(tmp_path / "bad.toml", optimizers="random = {}\nno-such-backend = {}")
    result = run_compare("--config", config, "--db", tmp_path / "x.sqlite")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "[optimizers]: unknown optimiser 'no-such-backend'; available:" in lines[0]
    assert "random" in lines[0]
    assert not (tmp_path / "x.sqlite").exists()


@pytest.fixture
def raising_backend(monkeypatch):
    """A test-only backend that raises ValueError after a few evaluations (in this process only)."""

    def minimize(objective, *, rng):
        objective.batch(rng.random((5, objective.dim)))
        raise ValueError("boom\nsecond line")

    registry.available()  # load the built-ins first, so this entry is removed cleanly afterwards
    monkeypatch.setitem(
        registry.REGISTRY.items, "test-raises", registry.Backend("test-raises", "test", "raises", minimize, {})
    )
    return "test-raises"


def test_a_run_that_raises_is_recorded_and_the_study_goes_on(raising_backend, tmp_path):
    config = load_study_config(
        write_config(
            tmp_path / "raises.toml",
            budget=100,
            underpressures="[0.01]",
            optimizers=f"{raising_backend} = {{}}\nrandom = {{}}",
        )
    )
    db = tmp_path / "raises.sqlite"
    outcome = run_study(config, db, workers=1, log=io.StringIO())
    assert outcome.complete and (outcome.recorded, outcome.errors) == (4, 2)
    with closing(sqlite3.connect(db)) as conn:
        got = conn.execute(f"SELECT optimizer, status, error, nfev, mse FROM runs {KEY_ORDER}").fetchall()
    assert got == [
        ("random", "ok", None, 100, got[0][4]),
        ("random", "ok", None, 100, got[1][4]),
        ("test-raises", "error", "ValueError: boom second line", None, None),
        ("test-raises", "error", "ValueError: boom second line", None, None),
    ]
    # Errors are finished runs: a rerun does not retry them.
    assert run_study(config, db, workers=1, log=io.StringIO()).recorded == 0


@pytest.mark.parametrize(
    "body, message",
    [
        ("budget = 0", r"bad\.toml: \[study\] budget must be a positive integer"),
        ("budget = true", r"bad\.toml: \[study\] budget must be a positive integer"),
        ("budget = 10\nstate = 'both'", r"bad\.toml: \[study\] state must be one of 'shared', 'split'"),
        ("budget = 10\nbudgett = 3", r"bad\.toml: \[study\] unknown key 'budgett'"),
    ],
)
def test_bad_study_values_name_the_file_and_key(tmp_path, body, message):
    path = tmp_path / "bad.toml"
    path.write_text(f'[study]\nname = "x"\nseed = 1\nseeds = 1\n{body}\n[optimizers]\nrandom = {{}}\n')
    with pytest.raises(UserError, match=message):
        load_study_config(path)


def test_filters_and_posterior_are_resolved(tmp_path):
    config = load_study_config(
        write_config(
            tmp_path / "p.toml",
            extra="""
[posterior]
specimens = ["pom-c9021_0.05MPa_r2"]
optimizer = "random"
budget = 50
""",
        )
    )
    tasks = plan_tasks(config)
    assert [s.name for s in config.specimens] == [
        "pom-mt24u01_0.01MPa_r1",
        "pom-mt24u01_0.05MPa_r1",
        "pom-mt24u01_0.09MPa_r1",
    ]
    assert len(tasks) == 13 and tasks[0].kind == "posterior" and tasks[0].budget == 50
    assert config.optimizers["random"] == {"batch_size": 100}  # defaults merged in


def test_workers_must_be_positive(tmp_path, capsys):
    assert run_cli(["--config", str(write_config(tmp_path / "w.toml")), "--workers", "0"]) == 2
    assert capsys.readouterr().err.strip() == "error: --workers must be at least 1, got 0"


def test_a_database_from_before_the_generic_columns_resumes_and_reads(tmp_path):
    from bwbench.database import reader as results_db

    config = load_study_config(
        write_config(tmp_path / "old.toml", budget=50, seeds=1, optimizers="random = {}", underpressures="[0.01, 0.05]")
    )
    db = tmp_path / "old.sqlite"
    run_study(config, db, workers=1, log=io.StringIO())
    with closing(sqlite3.connect(db)) as conn:  # make it look like an old database, one run short
        for column in ("problem", "params_json", "metrics_json"):
            conn.execute(f"ALTER TABLE runs DROP COLUMN {column}")
        conn.execute("DELETE FROM runs WHERE specimen = 'pom-mt24u01_0.05MPa_r1'")
        conn.commit()
    old = results_db.load_study(db)
    # a database older than the problem column is the hysteresis problem's (its former name reads as it)
    assert (old.runs["problem"] == "hysteresis").all() and old.problem == "hysteresis"
    assert run_study(config, db, workers=1, log=io.StringIO()).recorded == 1
    with closing(sqlite3.connect(db)) as conn:
        got = conn.execute(f"SELECT specimen, problem, params_json FROM runs {KEY_ORDER}").fetchall()
    assert got[0][1:] == (None, None)
    assert got[1][1] == "hysteresis" and set(json.loads(got[1][2])) == set(PARAM_NAMES)
    assert len(results_db.load_study(db).runs) == 2


def test_a_worker_runs_each_task_on_one_thread(monkeypatch, tmp_path):
    """numba and every BLAS/OpenMP pool are limited to one thread inside a run, and restored after."""
    import numba
    from threadpoolctl import threadpool_info

    seen = {}

    def minimize(objective, *, rng):
        seen["numba"] = numba.get_num_threads()
        seen["pools"] = [pool["num_threads"] for pool in threadpool_info()]
        objective.batch(rng.random((3, objective.dim)))

    registry.available()
    monkeypatch.setitem(
        registry.REGISTRY.items,
        "test-threads",
        registry.Backend("test-threads", "test", "records its threads", minimize, {}),
    )
    config = load_study_config(
        write_config(tmp_path / "t.toml", budget=3, seeds=1, optimizers="test-threads = {}", underpressures="[0.01]")
    )
    before = [pool["num_threads"] for pool in threadpool_info()]
    outcome = run_study(config, tmp_path / "t.sqlite", workers=1, log=io.StringIO())
    assert outcome.complete and outcome.errors == 0
    assert seen["numba"] == 1 and seen["pools"] and set(seen["pools"]) == {1}
    assert set(pool["num_threads"] for pool in threadpool_info()) == set(before)  # restored (pools may be added)
