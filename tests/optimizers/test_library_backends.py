"""The library-wrapping backends (pso, anneal, nlopt-*, cmaes, de, emcee) on a cheap fake problem:
exact budget, +inf survived, better than random search, repeatable, and no global side effects."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from bwbench.engine import fitting
from fakes import SphereProblem

BACKENDS = ["pso", "anneal", "nlopt-bobyqa", "nlopt-sbplx", "nlopt-neldermead", "cmaes", "de", "emcee"]
BUDGET = 600


def ShiftedSphere():
    """6-D sphere centred at 0.3, blowing up (+inf) where u₀ < 0.2, next to the minimum, so that
    local searches too run into it; counts evaluations."""
    return SphereProblem(dim=6, centre=0.3, blow_up=lambda P: P[:, 0] < 0.2)


@pytest.fixture(scope="module")
def random_mse():
    return fitting.run(ShiftedSphere(), "random", BUDGET, seed=3).mse


@pytest.mark.parametrize("name", BACKENDS)
def test_spends_the_exact_budget_survives_inf_and_beats_random(name, random_mse, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # so that stray output files (report.log, outcmaes/) would show
    global_state = np.random.get_state()
    root_handlers = list(logging.getLogger().handlers)
    problem = ShiftedSphere()

    result = fitting.run(problem, name, BUDGET, seed=3)

    assert result.message == "budget exhausted"
    assert result.nfev == problem.evaluated == BUDGET
    assert problem.blew_up > 0  # the +inf region was visited, and survived
    assert np.isfinite(result.mse) and result.mse < 0.5 * random_mse
    assert all(np.array_equal(a, b) for a, b in zip(np.random.get_state(), global_state))
    assert logging.getLogger().handlers == root_handlers
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", BACKENDS)
def test_same_seed_gives_identical_results(name):
    saved = np.random.get_state()
    try:
        first = fitting.run(ShiftedSphere(), name, BUDGET, seed=3)
        np.random.random(1000)  # a backend secretly drawing from numpy's global generator now differs
        second = fitting.run(ShiftedSphere(), name, BUDGET, seed=3)
    finally:
        np.random.set_state(saved)
    assert first.trace_mse == second.trace_mse and first.trace_nfev == second.trace_nfev
    assert first.params == second.params


def test_emcee_returns_its_chain():
    problem = ShiftedSphere()
    result = fitting.run(problem, "emcee", BUDGET, seed=3)
    extras = result.extras
    n_walkers = 2 * problem.dim + 2
    assert extras["n_walkers"] == n_walkers and extras["n_data"] == problem.n_data
    assert extras["chain"].shape == (extras["n_steps"], n_walkers, problem.dim)
    assert extras["n_steps"] >= BUDGET // n_walkers  # proposals outside the box cost nothing
    assert extras["log_prob"].shape == (extras["n_steps"], n_walkers)
    assert np.all((extras["chain"] >= 0) & (extras["chain"] <= 1))
    assert 0 < extras["acceptance_fraction"] < 1
    assert extras["autocorr_time"].shape == (problem.dim,)
    # The point estimate is the objective's best: no chain state can be better.
    assert np.max(extras["log_prob"]) <= -0.5 * problem.n_data * np.log(result.mse)
