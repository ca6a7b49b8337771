"""The contract every registered backend keeps, tested over the whole registry."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bwbench import testing
from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting, registry
from paper_problems import SwitchedBoucWenProblem

ROOT = Path(__file__).resolve().parents[2]
SPECIMEN = ROOT / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
BACKENDS = sorted(registry.available())
EXPECTED = {
    "paper-ga",
    "pso",
    "anneal",
    "firefly",
    "nlopt-bobyqa",
    "nlopt-sbplx",
    "nlopt-neldermead",
    "emcee",
    "cmaes",
    "de",
    "random",
}


def test_every_backend_of_the_issue_is_registered():
    assert EXPECTED <= set(BACKENDS)


@pytest.mark.parametrize("name", BACKENDS)
@pytest.mark.parametrize("budget", testing.BUDGETS)
def test_exact_budget_never_exceeded(name, budget):
    testing.check_exact_budget(name, budgets=(budget,))


@pytest.mark.parametrize("name", BACKENDS)
def test_same_seed_is_bit_identical_and_other_seeds_differ(name):
    testing.check_same_seed(name)


@pytest.mark.parametrize("name", BACKENDS)
def test_infinite_loss_is_survived(name):
    testing.check_infinite_loss(name)


@pytest.mark.parametrize("name", BACKENDS)
def test_runs_on_a_real_specimen_and_reports_physical_parameters(name):
    problem = SwitchedBoucWenProblem(read_specimen(SPECIMEN))
    result = fitting.run(problem, name, 300, seed=1)
    assert result.nfev <= 300 and np.isfinite(result.mse)
    values = np.array([result.params[n] for n in problem.param_names])
    assert np.all(values >= problem.lower) and np.all(values <= problem.upper)
    assert result.to_record()["xi-"] < 0  # physical units, ξ₋ negative
    assert result.f_err == -result.mse and result.rmse_N == pytest.approx(np.sqrt(result.mse))


@pytest.fixture(scope="module")
def plugin_env(tmp_path_factory):
    """The example plugin package (examples/plugin) pip-installed into its own folder, as a user would."""
    source = tmp_path_factory.mktemp("plugin-src") / "plugin"
    shutil.copytree(ROOT / "examples" / "plugin", source)  # the build writes into the source tree
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
            str(source),
        ],
        check=True,
        capture_output=True,
    )
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site), env.get("PYTHONPATH", "")])
    return env


def test_installed_example_plugin_is_listed_runs_and_keeps_the_contract(plugin_env, tmp_path):
    bwbench = [sys.executable, "-m", "bwbench.cli"]
    listing = subprocess.run(bwbench + ["optimizers"], env=plugin_env, capture_output=True, text=True)
    assert listing.returncode == 0, listing.stderr
    assert "example-coordinate-search" in listing.stdout and "one point per call" in listing.stdout
    out = tmp_path / "r.json"
    fit = subprocess.run(
        bwbench
        + [
            "fit",
            str(SPECIMEN),
            "--optimizer",
            "example-coordinate-search",
            "--budget",
            "120",
            "--seed",
            "3",
            "--out",
            str(out),
        ],
        env=plugin_env,
        capture_output=True,
        text=True,
    )
    assert fit.returncode == 0, fit.stderr
    assert '"nfev": 120' in out.read_text()
    # the plugin's own tests: bwbench.testing's contract checks, run against the installed plugin
    tests = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(ROOT / "examples" / "plugin" / "tests")],
        env=plugin_env,
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert tests.returncode == 0, tests.stdout + tests.stderr
    assert "2 passed" in tests.stdout


def test_unknown_backend_and_option_are_user_errors(capsys):
    from bwbench.cli import main

    assert main(["fit", str(SPECIMEN), "--optimizer", "nope", "--out", "x.json"]) == 2
    assert "unknown optimiser 'nope'" in capsys.readouterr().err
    assert main(["fit", str(SPECIMEN), "--optimizer", "random", "--option", "colour=3", "--out", "x.json"]) == 2
    assert "unknown option(s) colour" in capsys.readouterr().err


def test_the_table_of_builtin_backends_is_what_the_modules_register():
    import importlib
    import pkgutil

    import bwbench.optimizers as builtin

    found = {}
    for module in pkgutil.iter_modules(builtin.__path__):
        before = set(registry.REGISTRY.items)
        loaded = importlib.import_module(f"{builtin.__name__}.{module.name}")
        found.update(
            {
                name: module.name
                for name, backend in registry.REGISTRY.items.items()
                if backend.minimize.__module__ == loaded.__name__
            }
        )
        assert set(registry.REGISTRY.items) >= before
    assert found == registry.BUILTIN
