"""Problem and model plug-ins installed as packages, as an outside author ships them: the example
packages (examples/problem_plugin, examples/model_plugin) pip-installed into their own folder, then
``bwbench compare`` in a fresh process whose spawned workers, and whose local Dask cluster's workers,
load them from the installed entry points. Nothing is registered in this test's own process."""

from __future__ import annotations

import os
import shutil
import sqlite3
import subprocess
import sys
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest

from bwbench.data import strict_json

ROOT = Path(__file__).resolve().parents[2]
HANG = 600  # s: only to turn a hang into a failure, never a speed requirement
TOY = """
[study]
name = "toy"
problem = "toy-decay"
seed = 5
budget = 120
seeds = 2
noise_mV = 0.02

[optimizers]
random = {}
cmaes = {}
nlopt-bobyqa = {}
"""
TOY_RUNS = 2 * 3 * 2  # specimens x backends x seeds
# The damper's true coefficients: a force made exactly of them, fitted back by least squares.
C_TRUE, K_TRUE = 2.5, 40.0  # N·s/mm, N/mm
CLUSTER = """
import sys
from distributed import LocalCluster

if __name__ == "__main__":
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cluster:
        print(cluster.scheduler_address, flush=True)
        sys.stdin.read()  # until the test closes our stdin
"""


@pytest.fixture(scope="module")
def plugin_env(tmp_path_factory):
    """Both example packages installed into one folder, and an environment that sees it."""
    sources = tmp_path_factory.mktemp("plugin-src")
    for name in ("problem_plugin", "model_plugin"):
        shutil.copytree(ROOT / "examples" / name, sources / name)  # the build writes into the source tree
    site = tmp_path_factory.mktemp("site")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "--target",
            str(site),
            str(sources / "problem_plugin"),
            str(sources / "model_plugin"),
        ],
        check=True,
        capture_output=True,
    )
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")])
    return env


@pytest.fixture(scope="module")
def cluster(plugin_env, tmp_path_factory):
    """A local Dask cluster (2 worker processes) started where the plug-ins are installed; its address."""
    script = tmp_path_factory.mktemp("cluster") / "cluster.py"
    script.write_text(CLUSTER, encoding="utf-8")
    process = subprocess.Popen(
        [sys.executable, str(script)],
        env=plugin_env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        address = process.stdout.readline().strip()
        assert address.startswith("tcp://"), "the local cluster did not start"
        yield address
    finally:
        process.stdin.close()
        try:
            process.wait(timeout=60)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        process.stdout.close()


def bwbench(env, *args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "bwbench.cli", *map(str, args)],
        env=env,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=HANG,
    )


def check_toy_study(db: Path, env, out: Path) -> set:
    """Every run finished, recorded strictly, and the report builds; the set of workers that ran them."""
    with closing(sqlite3.connect(db)) as conn:
        rows = conn.execute("SELECT problem, status, error, params_json, metrics_json FROM runs").fetchall()
        workers = {w for (w,) in conn.execute("SELECT worker FROM timings")}
    assert len(rows) == TOY_RUNS
    assert {(r[0], r[1], r[2]) for r in rows} == {("toy-decay", "ok", None)}
    for _, _, _, params, metrics in rows:
        assert set(strict_json.loads(params)) == {"a", "b"} and "a_error" in strict_json.loads(metrics)
    report = bwbench(env, "report", "--db", db, "--out", out)
    assert report.returncode == 0, report.stderr
    md = (out / "report.md").read_text(encoding="utf-8")
    assert "# Optimiser comparison: toy" in md and "## Decay constants" in md and "median RMSE (mV)" in md
    return workers


def test_installed_problem_plugin_runs_on_spawned_workers_and_the_report_builds(plugin_env, tmp_path):
    db = tmp_path / "toy.sqlite"
    (tmp_path / "toy.toml").write_text(TOY, encoding="utf-8")
    run = bwbench(plugin_env, "compare", "--config", "toy.toml", "--db", db, "--workers", "2", cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert f"{TOY_RUNS} to run on 2 local processes" in run.stderr and "not finished" not in run.stderr
    workers = check_toy_study(db, plugin_env, tmp_path / "report")
    assert len(workers) == 2  # both spawned workers loaded the plug-in and ran some of its runs


def test_installed_problem_plugin_runs_on_a_local_dask_cluster_and_the_report_builds(plugin_env, cluster, tmp_path):
    db = tmp_path / "toy.sqlite"
    (tmp_path / "toy.toml").write_text(TOY, encoding="utf-8")
    run = bwbench(plugin_env, "compare", "--config", "toy.toml", "--db", db, "--scheduler", cluster, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert f"to run on the Dask cluster at {cluster}" in run.stderr and "not finished" not in run.stderr
    workers = check_toy_study(db, plugin_env, tmp_path / "report")
    assert len(workers) >= 1 and not any(w.endswith(f":{os.getpid()}") for w in workers)


def test_a_dask_cluster_without_the_plugin_is_refused_before_any_run(plugin_env, tmp_path):
    """The study's process has the plug-in, the cluster's workers do not: one line naming the worker
    and the fix, exit status 2, and not a run recorded (it used to lose every run, on every rerun)."""
    from distributed import LocalCluster

    (tmp_path / "toy.toml").write_text(TOY, encoding="utf-8")
    db = tmp_path / "toy.sqlite"
    # This test's process has no plug-in installed: neither have the workers it spawns.
    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0") as bare:
        run = bwbench(
            plugin_env,
            "compare",
            "--config",
            "toy.toml",
            "--db",
            db,
            "--scheduler",
            bare.scheduler_address,
            cwd=tmp_path,
        )
    assert run.returncode == 2, run.stderr
    last = run.stderr.strip().splitlines()[-1]
    assert (
        last.startswith("error: the Dask worker tcp://")
        and f"of the scheduler at {bare.scheduler_address} cannot load problem 'toy-decay' (unknown problem 'toy-decay'"
        in last
    )
    assert last.endswith("install the plug-in package on every worker") and "Traceback" not in run.stderr
    with closing(sqlite3.connect(db)) as conn:
        assert conn.execute("SELECT COUNT(*) FROM runs").fetchone() == (0,)


# ------------------------------------------------------------------------------ a model plug-in

DAMPER = """
[study]
name = "damper"
seed = 3
budget = 200
seeds = 2
model = ["linear-damper", "bouc-wen"]

[specimens]
files = ["damper.csv"]

[optimizers]
lsq-trf = {}
random = {}
"""
DAMPER_RUNS = 2 * 2 * 2  # models x backends x seeds


@pytest.fixture(scope="module")
def damper_specimen(tmp_path_factory) -> Path:
    """A force made exactly of F = c·ẋ + k·x on a 5 mm, 0.5 Hz sine, velocity recorded."""
    t = np.arange(0.0, 8.0, 0.01)
    x = 5.0 * np.sin(np.pi * t)
    v = 5.0 * np.pi * np.cos(np.pi * t)
    f = C_TRUE * v + K_TRUE * x
    path = tmp_path_factory.mktemp("damper") / "damper.csv"
    path.write_text(
        "time_s,displacement_mm,velocity_mm_s,force_N\n"
        + "".join(f"{a:.2f},{b:.17g},{c:.17g},{d:.17g}\n" for a, b, c, d in zip(t, x, v, f)),
        encoding="utf-8",
    )
    return path


def test_installed_model_plugin_is_listed_and_fitted(plugin_env, damper_specimen, tmp_path):
    listing = bwbench(plugin_env, "models")
    assert listing.returncode == 0, listing.stderr
    assert "linear-damper: linear viscous damper and spring (example plug-in)" in listing.stdout
    assert "direct parameters: c (N·s/mm), k (N/mm)" in listing.stdout
    fit = bwbench(
        plugin_env,
        "fit",
        damper_specimen,
        "--model",
        "linear-damper",
        "--optimizer",
        "lsq-trf",
        "--budget",
        "200",
        "--out",
        tmp_path / "fit.json",
    )
    assert fit.returncode == 0, fit.stderr
    result = strict_json.loads((tmp_path / "fit.json").read_text(encoding="utf-8"))
    assert result["model"] == "linear-damper"
    assert {k: result["units"][k] for k in ("c", "k")} == {"c": "N·s/mm", "k": "N/mm"}
    assert result["params"]["c"] == pytest.approx(C_TRUE, rel=1e-6)
    assert result["params"]["k"] == pytest.approx(K_TRUE, rel=1e-6)


@pytest.mark.parametrize("where", ["workers", "dask"])
def test_installed_model_plugin_is_compared_on_spawned_and_dask_workers(
    plugin_env, cluster, damper_specimen, tmp_path, where
):
    """``model = [...]`` with a plugged-in model beside a built-in one: every run of both finishes in
    the workers, and least squares gives the damper's exact coefficients back."""
    shutil.copy(damper_specimen, tmp_path / "damper.csv")
    (tmp_path / "damper.toml").write_text(DAMPER, encoding="utf-8")
    db = tmp_path / "damper.sqlite"
    flags = ["--workers", "2"] if where == "workers" else ["--scheduler", cluster]
    run = bwbench(plugin_env, "compare", "--config", "damper.toml", "--db", db, *flags, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert "not finished" not in run.stderr
    with closing(sqlite3.connect(db)) as conn:
        rows = conn.execute("SELECT optimizer, model, status, params_json, rmse_N FROM runs").fetchall()
        workers = {w for (w,) in conn.execute("SELECT worker FROM timings")}
    assert len(rows) == DAMPER_RUNS and {r[2] for r in rows} == {"ok"}
    assert {r[1] for r in rows} == {"linear-damper", "bouc-wen"}
    exact = [strict_json.loads(r[3]) for r in rows if r[0] == "lsq-trf [linear-damper]"]
    assert len(exact) == 2 and all(set(p) == {"c", "k"} for p in exact)
    for p in exact:
        assert p["c"] == pytest.approx(C_TRUE, rel=1e-6) and p["k"] == pytest.approx(K_TRUE, rel=1e-6)
    assert not any(w.endswith(f":{os.getpid()}") for w in workers)
    if where == "workers":
        assert len(workers) == 2


def test_a_model_registered_in_this_process_only_is_refused_for_other_processes(monkeypatch):
    import importlib.util

    from bwbench.errors import UserError
    from bwbench.models import registry
    from bwbench.problems import SpecimenEntry
    from bwbench.study.tasks import Task, missing_plugins, refuse_plugins_only_here

    path = ROOT / "examples" / "model_plugin" / "bwbench_linear_damper.py"
    spec = importlib.util.spec_from_file_location("bwbench_linear_damper_example", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    monkeypatch.setattr(registry.REGISTRY, "items", dict(registry.REGISTRY.items))  # gone again after this test
    registry.register(module.MODEL)

    def task(model):
        return Task(
            "ranking", "random", 0, 1, 10, {}, "switched-bouc-wen", {"model": model}, SpecimenEntry("s", "s.csv")
        )

    assert registry.only_in_this_process("linear-damper") and not registry.only_in_this_process("spencer")
    assert missing_plugins([("problem", "switched-bouc-wen"), ("model", "linear-damper")]) == []
    with pytest.raises(
        UserError,
        match=r"^model 'linear-damper' is registered in this process only \(register\(\)\), "
        r"so 2 workers cannot load it: .*'bwbench.models'",
    ):
        refuse_plugins_only_here([task("spencer"), task("linear-damper")], "2 workers")
    refuse_plugins_only_here([task("spencer"), task("no-such-model")], "2 workers")  # built in; unknown: the run says
    assert missing_plugins([("model", "no-such-model")])[0].startswith(
        "model 'no-such-model' (unknown model 'no-such-model'"
    )


def test_a_broken_plugin_is_one_line_and_breaks_only_itself(plugin_env, damper_specimen, tmp_path):
    """An installed plug-in whose module is missing: asking for it is one line naming the entry point
    and the error; the other plug-ins and the built-ins still work."""
    info = tmp_path / "site" / "broken_plugin-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-plugin\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[bwbench.problems]\nbroken-problem = no_such_module:PROBLEM_TYPE\n\n"
        "[bwbench.models]\nbroken-model = no_such_module:MODEL\n"
    )
    env = {**plugin_env, "PYTHONPATH": os.pathsep.join([str(tmp_path / "site"), plugin_env["PYTHONPATH"]])}
    (tmp_path / "b.toml").write_text(
        '[study]\nname = "b"\nproblem = "broken-problem"\nseed = 1\nbudget = 10\nseeds = 1\n[optimizers]\nrandom = {}\n'
    )
    run = bwbench(env, "compare", "--config", "b.toml", "--db", "b.sqlite", cwd=tmp_path)
    assert run.returncode == 2 and run.stderr == (
        "error: problem plug-in 'broken-problem' (entry point 'no_such_module:PROBLEM_TYPE' of group "
        "'bwbench.problems') failed to load: ModuleNotFoundError: No module named 'no_such_module'\n"
    )
    assert not (tmp_path / "b.sqlite").exists()
    fit = bwbench(
        env,
        "fit",
        damper_specimen,
        "--model",
        "broken-model",
        "--optimizer",
        "random",
        "--budget",
        "10",
        "--out",
        tmp_path / "f.json",
    )
    assert fit.returncode == 2 and len(fit.stderr.splitlines()) == 1
    assert fit.stderr == (
        "error: model plug-in 'broken-model' (entry point 'no_such_module:MODEL' of group "
        "'bwbench.models') failed to load: ModuleNotFoundError: No module named 'no_such_module'\n"
    )
    listing = bwbench(env, "models")
    assert listing.returncode == 0 and "linear-damper:" in listing.stdout and "spencer:" in listing.stdout
    assert listing.stderr.startswith("warning: model plug-in 'broken-model' (entry point")
    good = bwbench(
        env,
        "fit",
        damper_specimen,
        "--model",
        "linear-damper",
        "--optimizer",
        "lsq-trf",
        "--budget",
        "50",
        "--out",
        tmp_path / "g.json",
    )
    assert good.returncode == 0, good.stderr
