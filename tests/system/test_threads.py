"""One thread per process by default (numba and BLAS), in ``fit`` as in a study's runs; ``--threads N``
opts in; the settings are restored afterwards."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest
from threadpoolctl import threadpool_info

from bwbench import threads
from bwbench.cli import main
from bwbench.engine import fitting

SPECIMEN = Path(__file__).resolve().parents[2] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"


@pytest.fixture
def seen(monkeypatch, tmp_path):
    """The thread counts in force while the fit runs."""
    shutil.copy(SPECIMEN, tmp_path / "s.csv")
    monkeypatch.chdir(tmp_path)
    found = {}
    real = fitting.run

    def spy(*args, **kwargs):
        found["numba"] = numba.get_num_threads()
        found["blas"] = {pool["num_threads"] for pool in threadpool_info()}
        found["env"] = os.environ.get("OMP_NUM_THREADS")
        return real(*args, **kwargs)

    monkeypatch.setattr(fitting, "run", spy)
    return found


def test_fit_runs_on_one_thread_by_default_and_restores_the_settings(seen):
    before = numba.get_num_threads()
    assert main(["fit", "s.csv", "--optimizer", "random", "--budget", "20", "--out", "r.json"]) == 0
    assert seen["numba"] == 1 and seen["blas"] <= {1}
    if "OMP_NUM_THREADS" not in os.environ:
        assert seen["env"] == "1"  # what a library loaded later, or a spawned worker, starts with
    assert numba.get_num_threads() == before


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="needs 2 cores")
def test_threads_opts_in_to_more(tmp_path):
    # In a fresh process, as a command runs: numba's pool keeps the size it started with, and an earlier
    # test in this one may have started it with one thread (pytest-xdist orders tests differently per run).
    script = textwrap.dedent(f"""
        import os
        os.environ.pop("NUMBA_NUM_THREADS", None)
        import numba
        from bwbench.cli import main
        from bwbench.engine import fitting
        seen, real = [], fitting.run
        fitting.run = lambda *a, **k: seen.append(numba.get_num_threads()) or real(*a, **k)
        code = main(["fit", {str(SPECIMEN)!r}, "--optimizer", "random", "--budget", "20", "--formulation", "identifiable",
                     "--out", "r.json", "--threads", "2"])  # identifiable: 20 random points fit (exit 0)
        print(code, seen)
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "0 [2]"


def test_a_study_run_uses_the_threads_it_is_given(monkeypatch):
    from bwbench.study import tasks

    found = []
    monkeypatch.setattr(fitting, "run", lambda *a, **k: found.append(numba.get_num_threads()) or 1 / 0)
    task = tasks.Task(
        "ranking",
        "random",
        0,
        1,
        10,
        {},
        "switched-bouc-wen",
        {"state": "shared", "excitation": "measured"},
        tasks.SpecimenEntry("s", str(SPECIMEN)),
    )
    row = tasks.run_task(task)["row"]
    assert row["status"] == "error" and "ZeroDivisionError" in row["error"]  # the spy raised: recorded
    if numba.config.NUMBA_NUM_THREADS >= 2:
        tasks.run_task(task, threads=2)
        assert found == [1, 2]


def test_environment_fills_only_what_the_user_left_unset_and_restores_it(monkeypatch):
    monkeypatch.setenv("MKL_NUM_THREADS", "3")
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    with threads.environment(1):
        assert os.environ["MKL_NUM_THREADS"] == "3" and os.environ["OPENBLAS_NUM_THREADS"] == "1"
    assert "OPENBLAS_NUM_THREADS" not in os.environ and os.environ["MKL_NUM_THREADS"] == "3"


def test_numba_imported_before_the_environment_starts_its_pool_with_it_and_compiles_after():
    # What `compare --workers 1` does: the command modules import numba (which reads its variables
    # then), the environment says one thread, a run starts numba's pool and later compiles a ufunc;
    # numba re-reads its variables at each compilation and refused a size other than its pool's.
    script = textwrap.dedent("""
        import os
        os.environ.pop("NUMBA_NUM_THREADS", None)
        import numba
        from bwbench import threads
        with threads.environment(1):
            numba.get_num_threads()  # starts the pool
            numba.vectorize(["float64(float64)"])(lambda x: x + 1.0)  # a compilation re-reads the variables
        numba.vectorize(["float64(float64)"])(lambda x: x + 2.0)  # and after the block too
        from numba.core import config
        print(config.NUMBA_NUM_THREADS)
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "1"


def test_a_late_import_that_compiles_meets_the_running_pools_size(tmp_path):
    # The pool started at the machine's size; a variable set since (as a block of ``environment`` may
    # leave it) made ArviZ's import-time compilation raise "Cannot set NUMBA_NUM_THREADS ...".
    script = textwrap.dedent("""
        import os
        os.environ.pop("NUMBA_NUM_THREADS", None)
        import numba
        numba.get_num_threads()  # launches the pool
        size = numba.config.NUMBA_NUM_THREADS
        os.environ["NUMBA_NUM_THREADS"] = str(size + 1)
        from bwbench.threads import settle_numba_environment
        settle_numba_environment()
        numba.njit(lambda x: x + 1)(1)  # compiles: re-reads the variable
        print(os.environ["NUMBA_NUM_THREADS"] == str(size))
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "True"
