"""The contract every registered backend keeps, tested over the whole registry."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bwbench.optimize import fitting
from bwbench.optimize import registry
from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem
from bwbench.data.specimen import read_specimen
from fakes import SphereProblem

ROOT = Path(__file__).resolve().parents[2]
SPECIMEN = ROOT / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
BACKENDS = sorted(registry.available())
EXPECTED = {"paper-ga", "pso", "anneal", "firefly", "nlopt-bobyqa", "nlopt-sbplx", "nlopt-neldermead",
            "emcee", "cmaes", "de", "random"}


def CountingProblem():
    """14-D shifted sphere that blows up (+inf) where u₀ > 0.9; counts every evaluation itself."""
    return SphereProblem(blow_up=lambda P: P[:, 0] > 0.9)


def test_every_backend_of_the_issue_is_registered():
    assert EXPECTED <= set(BACKENDS)


@pytest.mark.parametrize("name", BACKENDS)
@pytest.mark.parametrize("budget", [1, 57, 600])
def test_exact_budget_never_exceeded(name, budget):
    problem = CountingProblem()
    result = fitting.run(problem, name, budget, seed=11)
    assert problem.evaluated == result.nfev <= budget
    stopped_early = result.message != "budget exhausted"
    assert result.nfev == budget or stopped_early


@pytest.mark.parametrize("name", BACKENDS)
def test_same_seed_is_bit_identical_and_other_seeds_differ(name):
    runs = [fitting.run(CountingProblem(), name, 400, seed=s) for s in (5, 5, 6)]
    assert runs[0].trace_mse == runs[1].trace_mse and runs[0].trace_nfev == runs[1].trace_nfev
    assert runs[0].params == runs[1].params and runs[0].nfev == runs[1].nfev
    assert runs[0].trace_mse != runs[2].trace_mse


@pytest.mark.parametrize("name", BACKENDS)
def test_infinite_loss_is_survived(name):
    # +inf on 90 % of the box: a hostile, mostly blown-up model
    mostly_infinite = SphereProblem(blow_up=lambda P: (P[:, 0] > 0.9) | (P[:, 1] > 0.1))
    result = fitting.run(mostly_infinite, name, 300, seed=2)
    assert result.nfev <= 300
    assert not np.isnan(result.mse)


@pytest.mark.parametrize("name", BACKENDS)
def test_runs_on_a_real_specimen_and_reports_physical_parameters(name):
    problem = SwitchedBoucWenProblem(read_specimen(SPECIMEN))
    result = fitting.run(problem, name, 300, seed=1)
    assert result.nfev <= 300 and np.isfinite(result.mse)
    values = np.array([result.params[n] for n in problem.param_names])
    assert np.all(values >= problem.lower) and np.all(values <= problem.upper)
    assert result.to_record()["xi-"] < 0  # physical units, ξ₋ negative
    assert result.f_err == -result.mse and result.rmse_N == pytest.approx(np.sqrt(result.mse))


def _with_plugin_env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "tests" / "plugin_dist"), env.get("PYTHONPATH", "")])
    return env


def test_entry_point_plugin_is_listed_and_runs(tmp_path):
    bwbench = [sys.executable, "-m", "bwbench.cli"]
    listing = subprocess.run(bwbench + ["optimizers"], env=_with_plugin_env(), capture_output=True, text=True)
    assert listing.returncode == 0, listing.stderr
    assert "test-plugin-coordinate" in listing.stdout and "plugin" in listing.stdout
    out = tmp_path / "r.json"
    fit = subprocess.run(
        bwbench + ["fit", str(SPECIMEN), "--optimizer", "test-plugin-coordinate", "--budget", "120",
                   "--seed", "3", "--out", str(out)],
        env=_with_plugin_env(), capture_output=True, text=True,
    )
    assert fit.returncode == 0, fit.stderr
    assert '"nfev": 120' in out.read_text()


def test_unknown_backend_and_option_are_user_errors(capsys):
    from bwbench.cli import main

    assert main(["fit", str(SPECIMEN), "--optimizer", "nope", "--out", "x.json"]) == 2
    assert "unknown optimiser 'nope'" in capsys.readouterr().err
    assert main(["fit", str(SPECIMEN), "--optimizer", "random", "--option", "colour=3", "--out", "x.json"]) == 2
    assert "unknown option(s) colour" in capsys.readouterr().err
