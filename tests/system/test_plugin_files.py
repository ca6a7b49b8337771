"""``--plugin FILE.py`` and a study's ``plugins = [...]``: a model or backend module loaded from a file,
not installed — the shipped examples copied to another folder, run as a user would."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bwbench.plugins as plugins
from bwbench.cli import main
from bwbench.engine import registry as backend_registry
from bwbench.models import registry as model_registry

REPO = Path(__file__).resolve().parents[2]
MODEL_FILE = REPO / "examples" / "model_plugin" / "bwbench_linear_damper.py"
BACKEND_FILE = REPO / "examples" / "plugin" / "bwbench_example_plugin.py"
BWBENCH = Path(sys.executable).parent / "bwbench"


@pytest.fixture
def elsewhere(tmp_path, monkeypatch):
    """A folder outside the repository with a test file and the two example modules under other names;
    the plug-in files declared to workers are this test's only."""
    monkeypatch.delenv(plugins.FILES_VARIABLE, raising=False)
    monkeypatch.chdir(tmp_path)
    shutil.copy(MODEL_FILE, "my_damper.py")
    shutil.copy(BACKEND_FILE, "my_search.py")
    t = np.arange(400) * 0.01
    x, v = 10 * np.sin(2 * np.pi * t), 20 * np.pi * np.cos(2 * np.pi * t)
    f = 3.0 * v + 20.0 * x + np.random.default_rng(0).normal(0, 1.0, len(t))
    np.savetxt(
        "test.csv", np.column_stack([t, x, f]), delimiter=",", header="time_s,displacement_mm,force_N", comments=""
    )
    registries = (model_registry.REGISTRY, backend_registry.REGISTRY)
    before = [(dict(r.items), set(r.from_entry_points)) for r in registries]
    files = dict(plugins._FILE_MODULES)  # noqa: SLF001 (the process's loaded files, restored below)
    yield tmp_path
    # What a test loaded in this process, forgotten: the files, their declaration to workers (set by
    # ``load_files`` itself, so monkeypatch has nothing to undo) and what the registries took from them.
    os.environ.pop(plugins.FILES_VARIABLE, None)
    plugins._FILE_MODULES.clear()  # noqa: SLF001
    plugins._FILE_MODULES.update(files)  # noqa: SLF001
    for registry, (items, named) in zip(registries, before):
        registry.items.clear()
        registry.items.update(items)
        registry.from_entry_points.clear()
        registry.from_entry_points.update(named)


def run(*args):
    """A fresh process, as a user's: nothing registered beforehand."""
    env = {k: v for k, v in os.environ.items() if k != plugins.FILES_VARIABLE}
    return subprocess.run([str(BWBENCH), *args], capture_output=True, text=True, env=env)


def test_a_model_and_a_backend_from_files_fit_without_installing_anything(elsewhere):
    listed = run("models", "--plugin", "my_damper.py")
    assert listed.returncode == 0 and "linear-damper: linear viscous damper and spring" in listed.stdout
    fit = run(
        "fit", "test.csv", "--plugin", "my_damper.py", "--plugin", "my_search.py", "--model", "linear-damper",
        "--optimizer", "example-coordinate-search", "--budget", "300", "--out", "fit.json",
    )  # fmt: skip
    assert fit.returncode == 0, fit.stderr
    first, second = fit.stdout.splitlines()[:2]
    assert first == "fitting test.csv: linear-damper in its direct formulation (its only one)"
    assert second.startswith("example-coordinate-search: MSE ")
    import json

    params = json.loads(Path("fit.json").read_text())["params"]
    assert params["c"] == pytest.approx(3.0, rel=0.05) and params["k"] == pytest.approx(20.0, rel=0.05)


def test_a_study_toml_names_its_plug_in_files_and_its_workers_load_them(elsewhere, capsys):
    Path("study.toml").write_text(
        '[study]\nname = "plug"\nseed = 1\nbudget = 30\nseeds = 1\nplugins = ["my_damper.py"]\n'
        'model = "linear-damper"\n\n[specimens]\nfiles = ["test.csv"]\n\n[optimizers]\nrandom = {}\n'
    )
    assert main(["compare", "--config", "study.toml", "--workers", "1"]) == 0
    assert "study plug: 1/1 runs" in capsys.readouterr().out
    # a spawned worker inherits the files to load; in it the model is found by name
    assert os.environ[plugins.FILES_VARIABLE] == str(elsewhere / "my_damper.py")
    probe = "from bwbench.models import registry; print(registry.get('linear-damper').title)"
    child = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, env=dict(os.environ))
    assert child.stdout.strip() == "linear viscous damper and spring (example plug-in)"


@pytest.mark.parametrize(
    "content, message",
    [
        (None, "--plugin nothere.py: not a Python file (give the path of the plug-in's .py module)"),
        (
            "x = 1\n",
            "defines no MODEL (a bwbench.models.base.Model) or PROBLEM_TYPE, and registers no optimiser backend",
        ),
        ("raise RuntimeError('boom')\n", "failed to load: RuntimeError: boom"),
    ],
    ids=["missing", "gives nothing", "fails to import"],
)
def test_a_bad_plug_in_file_is_one_line_and_exit_2(elsewhere, capsys, content, message):
    name = "nothere.py" if content is None else f"bad_{abs(hash(content))}.py"
    if content is not None:
        Path(name).write_text(content)
    assert main(["models", "--plugin", name]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("error: --plugin ") and message in err
