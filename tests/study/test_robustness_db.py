"""The study runner when runs or files go wrong: runs that fail (deterministically or not), what a
run costs in the database, a database or CSV that cannot be written, a report of an unfinished study."""

from __future__ import annotations

import io
import os
import sqlite3
import stat
import subprocess
import sys
from contextlib import closing
from pathlib import Path

import pytest

from bwbench.commands.compare import run_cli
from bwbench.database import reader
from bwbench.database.writer import open_database
from bwbench.engine import registry
from bwbench.study import execute, failures
from bwbench.study.config import load_study_config
from bwbench.study.execute import run_study
from bwbench.study.lock import lock_path
from robustness_helpers import (
    HANG,
    REPO,
    RUN_COMPARE,
    one_error_line,
    rows,
    write_config,
)

# ------------------------------------------------------------------------------ helpers for 3.


def test_failures_summary_groups_errors_with_counts_and_keys():
    key = ("ranking", "s1", "pso", 0)
    lines = failures.summarize(
        [
            (key, "ValueError: bad"),
            (("ranking", "s1", "pso", 1), "ValueError: bad"),
            (("posterior", "s2", "emcee", 0), "FloatingPointError: overflow"),
        ],
        [(("ranking", "s2", "de", 3), "BrokenProcessPool: a worker died")],
    )
    assert lines == [
        "error: 4 runs failed:",
        '  2 runs: "ValueError: bad", recorded as an error, not retried (it would fail the same way): '
        "(s1, pso, seed 0), (s1, pso, seed 1)",
        '  1 run: "FloatingPointError: overflow", recorded as an error, not retried (it would fail the same way): '
        "posterior (s2, emcee, seed 0)",
        '  1 run: "BrokenProcessPool: a worker died", not recorded (a fault of the environment; run the same '
        "command again to retry): (s2, de, seed 3)",
    ]
    assert failures.summarize([], []) == []


@pytest.mark.parametrize(
    "err, transient",
    [
        (ValueError("x"), False),
        (FloatingPointError("x"), False),
        (RuntimeError("x"), False),
        (ZeroDivisionError("x"), False),
        (OSError("x"), True),
        (FileNotFoundError("x"), True),
        (PermissionError("x"), True),
        (TimeoutError("x"), True),
        (MemoryError(), True),
        (ModuleNotFoundError("nlopt"), True),
    ],
)
def test_environment_faults_are_transient_and_the_rest_deterministic(err, transient):
    assert failures.is_transient(err) is transient
    assert reader.is_transient_text(failures.one_line(err)) is transient


# ------------------------------------------------------------------------------ 3. failed runs


@pytest.fixture
def flaky_backends(monkeypatch):
    """Test-only backends (in this process only): "test-raises" raises ValueError (deterministic);
    "test-flaky" raises the exception in ``state["raise"]`` (if any), else runs a few evaluations."""
    state = {"raise": None}

    def raises(objective, *, rng):
        objective.batch(rng.random((5, objective.dim)))
        raise ValueError("boom\nsecond line")

    def flaky(objective, *, rng):
        objective.batch(rng.random((5, objective.dim)))
        if state["raise"] is not None:
            raise state["raise"]

    registry.available()  # load the built-ins first, so these entries are removed cleanly afterwards
    for name, minimize in (("test-raises", raises), ("test-flaky", flaky)):
        monkeypatch.setitem(registry.REGISTRY.items, name, registry.Backend(name, "test", name, minimize, {}))
    return state


def test_deterministic_errors_are_listed_exit_1_and_are_not_retried(flaky_backends, tmp_path, capsys):
    config = write_config(
        tmp_path / "raises.toml",
        budget=50,
        seeds=2,
        underpressures="[0.01]",
        optimizers="test-raises = {}\nrandom = {}",
    )
    db = tmp_path / "raises.sqlite"
    argv = ["--config", str(config), "--db", str(db), "--workers", "1"]
    expected = [
        "error: 2 runs failed:",
        '  2 runs: "ValueError: boom second line", recorded as an error, not retried (it would fail the same '
        "way): (pom-mt24u01_0.01MPa_r1, test-raises, seed 0), (pom-mt24u01_0.01MPa_r1, test-raises, seed 1)",
    ]
    assert run_cli(argv) == 1
    err = capsys.readouterr().err.splitlines()
    assert err[-2:] == expected and "4 to run" in err[0]
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute("SELECT optimizer, status, COUNT(*) FROM runs GROUP BY optimizer, status").fetchall() == [
            ("random", "ok", 2),
            ("test-raises", "error", 2),
        ]
    assert run_cli(argv) == 1  # the study still has failed runs: still 1, and the same list
    err = capsys.readouterr().err.splitlines()
    assert err[0] == f"study tiny: all 4 runs already in {db}" and err[-2:] == expected


@pytest.mark.parametrize(
    "fault",
    [OSError(5, "Input/output error"), MemoryError(), PermissionError(13, "denied")],
    ids=["OSError", "MemoryError", "PermissionError"],
)
def test_a_transient_error_is_not_recorded_and_the_next_call_retries_it(flaky_backends, tmp_path, capsys, fault):
    config = write_config(
        tmp_path / "flaky.toml", budget=50, seeds=2, underpressures="[0.01]", optimizers="test-flaky = {}\nrandom = {}"
    )
    db = tmp_path / "flaky.sqlite"
    argv = ["--config", str(config), "--db", str(db), "--workers", "1"]
    flaky_backends["raise"] = fault
    assert run_cli(argv) == 1
    err = capsys.readouterr().err.splitlines()
    text = failures.one_line(fault)
    assert err[-2:] == [
        "error: 2 runs failed:",
        f'  2 runs: "{text}", not recorded (a fault of the environment; run the same command again to retry): '
        "(pom-mt24u01_0.01MPa_r1, test-flaky, seed 0), (pom-mt24u01_0.01MPa_r1, test-flaky, seed 1)",
    ]
    assert [r[2] for r in rows(db)] == ["random", "random"]  # the failed runs are not in the database

    flaky_backends["raise"] = None  # the environment is fixed
    assert run_cli(argv) == 0
    err = capsys.readouterr().err
    assert "4 runs, 2 already in" in err and "failed" not in err
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute("SELECT optimizer, status, nfev FROM runs ORDER BY optimizer, replicate").fetchall() == [
            ("random", "ok", 50),
            ("random", "ok", 50),
            ("test-flaky", "ok", 5),
            ("test-flaky", "ok", 5),
        ]


def test_an_old_transient_error_row_is_retried_and_replaced(tmp_path):
    """A database from before the distinction may hold "OSError: ..." rows: they are run again."""
    config = load_study_config(write_config(tmp_path / "old.toml", budget=50, seeds=1, optimizers="random = {}"))
    db = tmp_path / "old.sqlite"
    run_study(config, db, workers=1, log=io.StringIO())
    reference_runs, reference_traces = rows(db), rows(db, "traces")
    key = ("ranking", "pom-mt24u01_0.05MPa_r1", "random", 0)
    where = "kind = ? AND specimen = ? AND optimizer = ? AND replicate = ?"
    with closing(sqlite3.connect(db)) as conn:
        conn.execute(
            f"UPDATE runs SET status = 'error', error = 'OSError: [Errno 5] Input/output error', "
            f"nfev = NULL, mse = NULL WHERE {where}",
            key,
        )
        conn.execute(f"DELETE FROM traces WHERE {where}", key)
        conn.execute(
            "UPDATE runs SET status = 'error', error = 'ValueError: stays' WHERE specimen = ?",
            ("pom-mt24u01_0.09MPa_r1",),
        )
        conn.commit()
    outcome = run_study(config, db, workers=1, log=io.StringIO())
    assert (outcome.already, outcome.recorded) == (2, 1)
    assert outcome.failed == ((("ranking", "pom-mt24u01_0.09MPa_r1", "random", 0), "ValueError: stays"),)
    got = rows(db)
    assert got[:2] == reference_runs[:2]  # the retried run is the original run again, to the last digit
    assert rows(db, "traces") == reference_traces


# ------------------------------------------------------------------------------ 4. storage per run


def _vacuumed_size(db) -> int:
    with closing(sqlite3.connect(db)) as conn:
        conn.execute("VACUUM")
        return conn.execute("PRAGMA page_count").fetchone()[0] * conn.execute("PRAGMA page_size").fetchone()[0]


def test_ranking_runs_store_no_chain_and_take_under_20_kb_each(tmp_path):
    # The paper's budget, so emcee's trace is as long as in a real study; a short posterior run to
    # check that posterior runs still keep their chain.
    config = load_study_config(
        write_config(
            tmp_path / "size.toml",
            budget=4100,
            seeds=1,
            underpressures="[0.01, 0.05, 0.09]",
            optimizers="emcee = {}\nrandom = {}",
            extra='[posterior]\nspecimens = ["pom-mt24u01_0.01MPa_r1"]\noptimizer = "emcee"\nbudget = 600\n',
        )
    )
    db = tmp_path / "size.sqlite"
    open_database(db, config, planned_runs=7).close()
    empty = _vacuumed_size(db)
    outcome = run_study(config, db, workers=1, log=io.StringIO())
    assert outcome.complete and outcome.errors == 0 and outcome.recorded == 7
    with closing(sqlite3.connect(db)) as conn:
        chains = conn.execute("SELECT kind, optimizer, steps, walkers, dim, LENGTH(chain) FROM chains").fetchall()
        ((kind, optimizer, steps, walkers, dim, size),) = chains  # the posterior run's, and no other
        assert (kind, optimizer, walkers, dim) == ("posterior", "emcee", 3 * 30, 14)  # 3 ensembles by default
        assert steps >= 10 and size == steps * walkers * dim * 8
        for table in ("runs", "timings", "traces", "chains"):  # what is left: the 6 ranking runs
            conn.execute(f"DELETE FROM {table} WHERE kind = 'posterior'")
        conn.commit()
    per_run = (_vacuumed_size(db) - empty) / 6
    with closing(sqlite3.connect(db)) as conn:
        for table in ("runs", "timings", "traces"):
            conn.execute(f"DELETE FROM {table} WHERE optimizer = 'random'")
        conn.commit()
    per_emcee_run = (_vacuumed_size(db) - empty) / 3
    print(f"\nstorage per ranking run: {per_run / 1024:.1f} KiB; per emcee ranking run: {per_emcee_run / 1024:.1f} KiB")
    assert 0 < per_run < 20 * 1024
    assert 0 < per_emcee_run < 20 * 1024


# ------------------------------------------------------------------------------ 5. database faults


@pytest.mark.parametrize(
    "case",
    [
        "not a database",
        "directory",
        "parent is a file",
        "csv is a directory",
        "csv is the database",
        "csv folder is a file",
    ],
)
def test_a_database_or_csv_that_cannot_be_used_is_one_line_before_any_run(tmp_path, capsys, case):
    config = write_config(tmp_path / "c.toml")
    db, csv = tmp_path / "study.sqlite", None
    if case == "not a database":
        db.write_bytes(b"these are not the bytes of a SQLite database" * 100)
        expected = (str(db), "not a SQLite database")
    elif case == "directory":
        db.mkdir()
        expected = (str(db), "is a directory")
    elif case == "parent is a file":
        (tmp_path / "file").write_text("x")
        db = tmp_path / "file" / "study.sqlite"
        expected = (str(db), f"{tmp_path / 'file'} is a file")
    elif case == "csv is a directory":
        csv = tmp_path
        expected = (str(csv), "is a directory")
    elif case == "csv is the database":
        csv = db
        expected = (str(db), "is the study database")
    else:
        (tmp_path / "file").write_text("x")
        csv = tmp_path / "file" / "runs.csv"
        expected = (str(csv), f"{tmp_path / 'file'} is a file")
    before = db.read_bytes() if db.is_file() else None
    argv = ["--config", str(config), "--db", str(db), "--workers", "1"] + (["--csv", str(csv)] if csv else [])
    assert run_cli(argv) == 2
    one_error_line(capsys.readouterr().err, *expected)
    assert (db.read_bytes() if db.is_file() else None) == before  # nothing written, nothing created
    assert not lock_path(db).exists()


def _as_unprivileged(command: list) -> list:
    """``command`` run as an ordinary user: root may write to read-only files, so permissions are only
    tested as another user (``setpriv`` from util-linux)."""
    if os.geteuid() != 0:
        return command
    if not Path("/usr/bin/setpriv").exists():
        pytest.skip("running as root without setpriv: cannot test file permissions")
    private = [d for d in (REPO, *REPO.parents) if not d.stat().st_mode & stat.S_IXOTH]
    if private:  # e.g. a clone inside `mktemp -d` (mode 700): the other user cannot reach the code
        pytest.skip(f"{private[0]} is not reachable by another user: cannot test file permissions as one")
    return ["/usr/bin/setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", *command]


@pytest.fixture
def shared_tmp(tmp_path_factory):
    """A folder every user can reach (pytest's own is private to the user running the tests)."""
    import tempfile

    folder = Path(tempfile.mkdtemp(prefix="bwbench-ro-"))
    folder.chmod(0o777)
    yield folder
    for path in sorted(folder.rglob("*"), reverse=True):
        path.parent.chmod(0o777)
    import shutil

    shutil.rmtree(folder)


def test_a_read_only_folder_or_database_file_is_one_line_and_leaves_the_runs(tiny_db, shared_tmp):
    config_path, reference = tiny_db
    config = shared_tmp / "c.toml"
    config.write_text(config_path.read_text())
    (shared_tmp / "numba").mkdir()
    (shared_tmp / "numba").chmod(0o777)  # mkdir's mode is masked by the umask
    read_only_file = shared_tmp / "writable-folder" / "study.sqlite"
    read_only_folder = shared_tmp / "read-only-folder" / "study.sqlite"
    new_in_read_only_folder = shared_tmp / "read-only-folder" / "new.sqlite"
    for db in (read_only_file, read_only_folder):
        db.parent.mkdir()
        db.parent.chmod(0o777)
        db.write_bytes(reference.read_bytes())
    read_only_file.chmod(0o444)
    read_only_folder.chmod(0o666)
    read_only_folder.parent.chmod(0o555)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(shared_tmp / "numba")}  # the repository's cache is root's
    for db, expected in [
        (read_only_file, "the study database is read-only"),
        (read_only_folder, f"the folder {read_only_folder.parent} is not writable"),
        (new_in_read_only_folder, f"the folder {read_only_folder.parent} is not writable"),
    ]:
        result = subprocess.run(
            _as_unprivileged(
                [sys.executable, str(RUN_COMPARE), "--config", str(config), "--db", str(db), "--workers", "1"]
            ),
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=HANG,
            env=env,
        )
        assert result.returncode == 2, result.stderr
        one_error_line(result.stderr, f"{db}: {expected}")
    assert read_only_file.read_bytes() == read_only_folder.read_bytes() == reference.read_bytes()
    assert not new_in_read_only_folder.exists()


def test_a_full_disk_mid_study_stops_with_one_line_and_what_was_committed_resumes(tmp_path, capsys, monkeypatch):
    config = write_config(tmp_path / "full.toml", budget=100, seeds=4)
    db = tmp_path / "full.sqlite"

    def open_with_no_room_to_grow(path, config, planned_runs=None, **facts):
        # SQLite's own limit: once the file has this many pages a write fails with SQLITE_FULL, as on
        # a full disk; the runs fit in the pages the new tables already have until one needs another.
        conn = open_database(path, config, planned_runs, **facts)
        pages = conn.execute("PRAGMA page_count").fetchone()[0]
        conn.execute(f"PRAGMA max_page_count = {pages}")
        return conn

    monkeypatch.setattr(execute, "open_database", open_with_no_room_to_grow)
    argv = ["--config", str(config), "--db", str(db), "--workers", "1"]
    assert run_cli(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1] == (
        f"error: {db}: the disk is full (database or disk is full); finished runs are in {db}, "
        "run the same command again to resume"
    )
    assert not any("Traceback" in line for line in err)
    committed = rows(db)
    assert 1 <= len(committed) < 24, "the disk must fill part-way for this test to mean anything"
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute("PRAGMA integrity_check").fetchone() == ("ok",)
        n_timings = conn.execute("SELECT COUNT(*) FROM timings").fetchone()[0]
    assert n_timings == len(committed)  # no half-written run

    monkeypatch.undo()  # space freed
    assert run_cli(argv) == 0
    assert f"{len(committed)} already in" in capsys.readouterr().err
    assert len(rows(db)) == 24 and set(committed) <= set(rows(db))  # what was committed is unchanged


# ------------------------------------------------------------------------------ 6. provisional reports


def test_the_report_of_an_unfinished_study_says_it_is_provisional(tiny_db, tmp_path):
    from bwbench.database import reader as results
    from bwbench.report.build import build_report

    _, reference = tiny_db
    db = tmp_path / "part.sqlite"
    db.write_bytes(reference.read_bytes())
    assert results.load_study(db).provisional is None  # finished: 6 of 6
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute("SELECT value FROM study WHERE key = 'planned_runs'").fetchone() == ("6",)
        for table in ("runs", "timings", "traces"):  # as if the study had stopped before these runs
            conn.execute(
                f"DELETE FROM {table} WHERE specimen = 'pom-mt24u01_0.09MPa_r1' OR "
                "(specimen = 'pom-mt24u01_0.05MPa_r1' AND optimizer = 'firefly')"
            )
        conn.commit()
    assert results.load_study(db).provisional == "provisional: 3 of 6 runs"
    build_report(db, tmp_path / "report", profile_params=0, log=io.StringIO())
    markdown = (tmp_path / "report" / "report.md").read_text(encoding="utf-8")
    blocks = markdown.split("\n\n")
    assert blocks[0] == "# Optimiser comparison: tiny (provisional: 3 of 6 runs)"
    assert blocks[1].startswith("> **Provisional: 3 of 6 runs: the study is unfinished")  # before anything else
    recommendation = markdown.split("## Recommendation\n\n")[1].split("\n\n")[0]
    assert recommendation.startswith("**Provisional: 3 of 6 runs**")
    html = (tmp_path / "report" / "report.html").read_text(encoding="utf-8")
    assert "<title>bwbench report: tiny (provisional: 3 of 6 runs)</title>" in html

    with closing(sqlite3.connect(db)) as conn:  # a database from before the key: counted from the config
        conn.execute("DELETE FROM study WHERE key = 'planned_runs'")
        conn.commit()
    assert results.load_study(db).provisional == "provisional: 3 of 6 runs"


def test_planned_runs_are_counted_from_a_stored_configuration_when_possible():
    from bwbench.database.plan import planned_from_config

    config = {
        "study": {"seeds": 5},
        "specimens": {"files": ["a", "b", "c"]},
        "optimizers": {"x": {}, "y": {}},
        "posterior": {"specimens": ["a"], "seeds": 2},
    }
    assert planned_from_config(config) == 5 * 3 * 2 + 2
    assert planned_from_config({**config, "posterior": None}) == 30
    assert planned_from_config({**config, "specimens": {"filters": {}}}) is None  # cannot tell: say nothing
    assert planned_from_config({}) is None


# ------------------------------------------------------------------------------ 8. other mistakes


def test_csv_into_a_missing_folder_is_written_there(tiny_db, tmp_path, capsys):
    config, reference = tiny_db
    db = tmp_path / "copy.sqlite"
    db.write_bytes(reference.read_bytes())
    csv = tmp_path / "new" / "folder" / "runs.csv"
    assert run_cli(["--config", str(config), "--db", str(db), "--csv", str(csv)]) == 0
    assert len(csv.read_text().splitlines()) == 1 + 6


def test_a_bad_scheduler_address_is_one_line(tiny_db, tmp_path, capsys):
    config, _ = tiny_db
    assert run_cli(["--config", str(config), "--db", str(tmp_path / "s.sqlite"), "--scheduler", "nonsense://x:1"]) == 2
    one_error_line(
        capsys.readouterr().err.splitlines()[-1],
        "cannot connect to the Dask scheduler at nonsense://x:1: unknown address scheme 'nonsense'",
    )
