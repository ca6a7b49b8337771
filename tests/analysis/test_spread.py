"""Non-uniqueness split into its causes: on a toy posterior of known width, the scatter of a strong
optimiser's fits is the data's and a deliberately weak optimiser's is the optimiser's."""

import numpy as np
import pytest

from bwbench.analysis import spread
from bwbench.engine import fitting
from bwbench.study.posterior_config import POSTERIOR_OPTIONS
from toy_posteriors import LinearToy


def _log_post(problem, P):
    return -0.5 * problem.n_data * np.log(problem.loss_batch(P))


@pytest.fixture(scope="module")
def posterior():
    problem = LinearToy(2, 200)
    result = fitting.run(problem, "emcee", 60_000, seed=4, options=POSTERIOR_OPTIONS["emcee"])
    chain, lp = result.extras["chain"], result.extras["log_prob"]
    half = len(chain) // 2
    return problem, chain[half:].reshape(-1, 2), lp[half:].reshape(-1)


def test_the_posterior_has_the_known_width(posterior):
    problem, draws, _ = posterior
    table, _ = spread.decompose(draws[:1], np.zeros(1), draws, np.zeros(len(draws)), ["a", "b"])
    # central 99 % of a Gaussian: 2 × 2.576 σ
    np.testing.assert_allclose(table["posterior_width"], 2 * 2.576 * problem.posterior_sd(), rtol=0.12)


def test_a_strong_optimisers_scatter_is_the_datas_and_a_weak_ones_is_the_optimisers(posterior):
    problem, draws, draws_lp = posterior
    strong = np.array(
        [[fitting.run(problem, "lsq-trf", 200, seed=s).params[n] for n in problem.param_names] for s in range(6)]
    )
    weak = np.array(
        [[fitting.run(problem, "random", 40, seed=s).params[n] for n in problem.param_names] for s in range(6)]
    )
    fits = np.vstack([strong, weak])
    table, kind = spread.decompose(fits, _log_post(problem, fits), draws, draws_lp, ["a", "b"])
    assert list(kind[:6]) == [spread.DATA] * 6  # the least-squares optimum: as probable as the draws, inside
    assert list(kind[6:]) == [spread.EARLY] * 6  # 40 random points: far below the posterior's bulk
    assert (table["scatter"] == "the optimiser").all()
    assert (table["stopped_early"] >= 4).all() and (table["elsewhere"] == 0).all()
    # the strong fits alone: their (tiny) scatter lies within the posterior, the data's
    table, _ = spread.decompose(strong, _log_post(problem, strong), draws, draws_lp, ["a", "b"])
    assert (table["scatter"] == "the data").all() and (table["inside"] == 6).all()
    assert (table["fits_spread"] < table["posterior_width"]).all()


def test_as_probable_but_outside_an_interval_is_another_mode():
    rng = np.random.default_rng(0)
    draws = rng.normal(0.3, 0.01, (4000, 1))
    lp = -0.5 * ((draws[:, 0] - 0.3) / 0.01) ** 2
    fits = np.array([[0.3], [0.7]])  # the second sits in a mode the draws never visited, as probable
    table, kind = spread.decompose(fits, np.array([0.0, 0.0]), draws, lp, ["a"])
    assert list(kind) == [spread.DATA, spread.ELSEWHERE] and table["scatter"].iloc[0] == "another mode"
