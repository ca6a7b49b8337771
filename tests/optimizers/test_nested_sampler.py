"""The nested-sampling backend on posteriors whose answer is known (tests/toy_posteriors.py): mode
masses, ln Z in closed form, a ridge, and the verdict when the budget or the live points are too few."""

import numpy as np
import pytest

from bwbench.analysis import nested, posterior_verdict
from bwbench.engine import fitting
from toy_posteriors import GaussianToy, MixtureToy, RidgeToy


def run(toy, budget=60_000, seed=1, **options):
    options = {"live_points": 100, "min_ess": 120, **options}
    return fitting.run(toy, "nested", budget, seed, options)


def test_two_modes_of_mass_0_7_and_0_3_are_found_with_their_masses():
    toy = MixtureToy([[0.3, 0.3], [0.7, 0.7]], 0.04, [0.7, 0.3])
    result = run(toy)
    extras = result.extras
    verdict = posterior_verdict.judge(
        extras["chain"], extras["log_prob"], extras["log_z"], extras["log_z_err"], ["p0", "p1"]
    )
    assert len(verdict["modes"]) == 2
    heavy, light = verdict["modes"]
    centre = extras["chain"].reshape(-1, 2)[heavy.members].mean(axis=0)
    assert np.allclose(centre, [0.3, 0.3], atol=0.02)  # the 0.7 mode is the one at (0.3, 0.3)
    assert heavy.mass == pytest.approx(0.7, abs=0.05) and light.mass == pytest.approx(0.3, abs=0.05)
    assert verdict["converged"], verdict["message"]
    assert extras["chain"].shape[1] == 4  # four independent runs, the chains of R̂


def test_ln_z_of_a_gaussian_matches_its_closed_form_within_the_stated_error():
    toy = GaussianToy([0.4, 0.6], [0.05, 0.03])
    extras = run(toy).extras
    pooled = nested.evidence(extras["log_z"], extras["log_z_err"])
    assert abs(pooled["log_z"] - toy.log_z()) <= 2 * pooled["err"]  # 2σ: the error is a standard deviation
    assert 0.02 < pooled["err"] < 0.5
    assert pooled["agree"]
    # each run on its own too (its error is its own)
    for z, e in zip(extras["log_z"], extras["log_z_err"]):
        assert abs(z - toy.log_z()) <= 3 * e


def test_a_ridge_is_sampled_along_its_length_and_pinned_across_it():
    toy = RidgeToy(3, 0.01)
    result = run(toy)
    draws = result.extras["chain"].reshape(-1, 3)
    lo, hi = np.quantile(draws[:, 0], [0.05, 0.95])
    assert hi - lo > 0.75  # flat along p0 + p1 = 1: the marginal of p0 fills most of its box
    assert np.std(draws[:, 0] + draws[:, 1] - 1) < 0.02  # across the ridge: sd 0.01
    assert result.extras["converged"], result.message


def test_too_small_a_budget_is_never_called_converged():
    toy = MixtureToy([[0.3, 0.3], [0.7, 0.7]], 0.04, [0.7, 0.3])
    result = run(toy, budget=2_500)
    assert result.nfev <= 2_500
    assert result.extras["converged"] is False
    assert "cut by the budget" in result.message and "not converged" in result.message


def test_a_budget_too_small_for_one_run_is_spent_on_prior_draws_and_said():
    toy = GaussianToy([0.4, 0.6], [0.05, 0.03])
    result = run(toy, budget=50)
    assert result.nfev == 50 and np.isfinite(result.mse)
    assert "too small for one nested-sampling run" in result.message


def test_a_mode_missed_for_want_of_live_points_is_said_and_never_converged():
    # a narrow mode holding half the mass at (0.85, 0.85, 0.85): 20 live points miss it, and the runs agree
    # with each other on the broad mode alone — R̂ alone would call that converged
    toy = MixtureToy([[0.3, 0.3, 0.3], [0.85, 0.85, 0.85]], [0.05, 0.002], [0.5, 0.5])
    extras = run(toy, budget=30_000, seed=3, live_points=20, min_ess=20).extras
    draws, lp = extras["chain"], extras["log_prob"]
    assert np.all(np.abs(draws - 0.85).max(axis=2) > 0.1)  # no draw in the narrow mode
    names = ["p0", "p1", "p2"]
    alone = posterior_verdict.judge(draws, lp, extras["log_z"], extras["log_z_err"], names)
    assert alone["converged"], alone["message"]  # by R̂, ESS, ln Z and masses
    best = np.array([0.85, 0.85, 0.85])  # what an optimiser finds: the narrow mode's peak
    verdict = posterior_verdict.judge(
        draws,
        lp,
        extras["log_z"],
        extras["log_z_err"],
        names,
        best_fit=(best, float(toy.log_density(best[None])[0]), "the best ranking fit"),
    )
    assert not verdict["converged"] and verdict["best_fit_place"]["where"] == "missed"
    assert "the sampler missed a mode at least as probable as the best ranking fit" in verdict["message"]
    # a poor point is below the support, a point among the draws is in the mode
    poor = np.array([0.05, 0.95, 0.5])
    where = nested.locate(poor, float(toy.log_density(poor[None])[0]), draws, lp, verdict)
    assert where["where"] == "below" and where["delta"] > 50
    inside = np.array([0.31, 0.29, 0.3])
    where = nested.locate(inside, float(toy.log_density(inside[None])[0]), draws, lp, verdict)
    assert where["where"] == "mode" and where["mode"] == 0
    # what the missed mode costs: its mass, 0.5, missing from the evidence (true ln Z = 0)
    assert verdict["evidence"]["log_z"] == pytest.approx(np.log(0.5), abs=3 * verdict["evidence"]["err"])


class WiderBox(GaussianToy):
    """The same likelihood searched in a box ``factor`` times wider in every parameter (same centre)."""

    def __init__(self, mean, sd, factor):
        super().__init__(mean, sd)
        self.factor = factor
        self.lower, self.upper = 0.5 - factor / 2 * np.ones(self.dim), 0.5 + factor / 2 * np.ones(self.dim)

    def from_unit(self, U):
        return self.lower + np.asarray(U, dtype=float) * (self.upper - self.lower)


def test_ln_z_falls_by_ln_c_per_parameter_when_the_box_widens_by_c():
    narrow = run(GaussianToy([0.45, 0.55], [0.04, 0.04])).extras
    wide = run(WiderBox([0.45, 0.55], [0.04, 0.04], 2.0)).extras
    a = nested.evidence(narrow["log_z"], narrow["log_z_err"])
    b = nested.evidence(wide["log_z"], wide["log_z_err"])
    expected = nested.box_sensitivity([2.0, 2.0])  # −2 ln 2
    assert expected == pytest.approx(-2 * np.log(2))
    assert b["log_z"] - a["log_z"] == pytest.approx(expected, abs=3 * np.hypot(a["err"], b["err"]))


def fake_run(light: float, rng, n=2000):
    """A finished run's weighted samples (equal weights) of two modes, ``light`` of them at (0.7, 0.7)."""
    which = rng.random(n) < light
    u = np.clip(np.array([[0.3, 0.3], [0.7, 0.7]])[which.astype(int)] + rng.normal(0, 0.04, (n, 2)), 0, 1)
    return {
        "u": u,
        "weights": np.ones(n),
        "logl": np.zeros(n),
        "ess": float(n),
        "nfev": 10_000,
        "log_z": 0.0,
        "log_z_err": 0.1,
        "complete": True,
    }


def test_more_runs_are_planned_while_the_runs_disagree_and_as_many_as_the_budget_pays():
    from types import SimpleNamespace

    from bwbench.optimizers import nested_sampler

    rng = np.random.default_rng(0)
    job = {"d": 2}
    objective = SimpleNamespace(problem=SimpleNamespace(from_unit=lambda U: U), remaining=10**6)
    agreeing = [fake_run(0.3, rng) for _ in range(4)]
    assert nested_sampler._next_plan(agreeing, objective, job, 32, 0) == 4  # precise: no more runs
    # masses 0.20, 0.52, 0.31, 0.43 across runs: SE ~0.07 against 0.05, about 8 runs needed
    scattered = [fake_run(m, rng) for m in (0.20, 0.52, 0.31, 0.43)]
    plan = nested_sampler._next_plan(scattered, objective, job, 32, 0)
    assert 6 <= plan <= 16
    assert nested_sampler._next_plan(scattered, objective, job, 5, 0) == 5  # max_runs
    poor = SimpleNamespace(problem=objective.problem, remaining=25_000)  # pays for 2 runs of 11,000
    assert nested_sampler._next_plan(scattered, poor, job, 32, 0) == 6


def test_runs_side_by_side_on_two_workers_give_the_same_draws_as_one():
    toy = GaussianToy([0.4, 0.6], [0.05, 0.03])
    one = run(toy, budget=12_000, runs=2, max_runs=2, live_points=20, min_ess=20)
    two = run(toy, budget=12_000, runs=2, max_runs=2, live_points=20, min_ess=20, workers=2)
    assert one.nfev == two.nfev and one.mse == two.mse
    np.testing.assert_array_equal(one.extras["chain"], two.extras["chain"])
