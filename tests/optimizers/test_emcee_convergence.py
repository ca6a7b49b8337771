"""The emcee backend as a study's [posterior] runs it: starts at several optima, independent ensembles,
stopped by ArviZ's verdict or by its budget, saying which; modes kept apart."""

import numpy as np
import pytest

from bwbench.analysis import mcmc
from bwbench.engine import fitting
from bwbench.study.posterior_config import POSTERIOR_OPTIONS
from toy_posteriors import BimodalToy, LinearToy

OPTIONS = POSTERIOR_OPTIONS["emcee"]


def test_a_posterior_that_converges_stops_before_its_budget_and_says_so():
    problem = LinearToy(2, 200)
    result = fitting.run(problem, "emcee", 60_000, seed=1, options=OPTIONS)
    extras = result.extras
    assert extras["converged"] is True and result.nfev < 60_000
    assert result.message.startswith(f"converged after {result.nfev:,} evaluations")
    verdict = mcmc.assess(extras["chain"], extras["log_prob"], extras["ensembles"], problem.param_names)
    assert verdict["converged"] and len(verdict["modes"]) == 1
    # ... and it is the right posterior: the Gaussian of the linear model, known in closed form
    kept = extras["chain"][len(extras["chain"]) // 2 :].reshape(-1, 2)
    np.testing.assert_allclose(kept.std(axis=0), problem.posterior_sd(), rtol=0.15)
    ls = np.linalg.lstsq(np.column_stack([np.ones_like(problem.x), problem.x]), problem.y, rcond=None)[0]
    np.testing.assert_allclose(kept.mean(axis=0), ls, atol=0.2 * problem.posterior_sd().max())


def test_the_convergence_loop_stops_on_its_budget_and_says_why():
    problem = LinearToy(2, 200)
    result = fitting.run(problem, "emcee", 3_000, seed=1, options=OPTIONS)
    assert result.nfev == 3_000 and result.extras["converged"] is False
    assert result.message.startswith("budget exhausted before convergence")
    # which parameter failed, with its R̂ and ESS, and which way it was moving
    assert "p0 (R̂ " in result.message or "p1 (R̂ " in result.message
    assert "bulk ESS" in result.message and ("drifting" in result.message or "mix slowly" in result.message)


def test_a_bimodal_posterior_is_reported_as_two_modes():
    problem = BimodalToy(2, 200)
    result = fitting.run(problem, "emcee", 100_000, seed=2, options={**OPTIONS, "ensembles": 4})
    extras = result.extras
    verdict = mcmc.assess(extras["chain"], extras["log_prob"], 4, problem.param_names)
    assert len(verdict["modes"]) == 2, result.message
    centres = sorted(
        float(np.median(extras["chain"][len(extras["chain"]) // 2 :, m.walkers, 0])) for m in verdict["modes"]
    )
    assert centres == pytest.approx([0.25, 0.75], abs=0.02)
    assert "2 modes" in result.message
    # each mode converged on its own; pooled, the walkers of the two modes would give a huge R̂
    assert verdict["converged"]
    pooled = mcmc.convergence(extras["chain"], problem.param_names)
    assert pooled["r_hat"].max() > 1.3  # far beyond 1.01


def test_ranking_defaults_are_unchanged_one_ensemble_uniform_start_whole_budget():
    problem = LinearToy(2, 50)
    result = fitting.run(problem, "emcee", 2_000, seed=0)
    assert result.nfev == 2_000 and result.extras["ensembles"] == 1 and result.extras["converged"] is None
    assert result.message == "budget exhausted"
