"""The posterior's verdict (``posterior_verdict.judge``) on runs whose answer is known: draws made directly
from toy posteriors (no sampler: fast), each run one chain, with what a sampler would say of each run."""

import numpy as np
import pytest

from bwbench.analysis import posterior_profile, posterior_verdict

CENTRES = np.array([[0.3, 0.3], [0.7, 0.7]])
SD = 0.04


def mixture_runs(masses_per_run, n=1000, seed=0):
    """Draws (n, runs, 2) of two Gaussian modes, run k putting ``masses_per_run[k]`` in the mode at (0.7, 0.7),
    and their log-likelihoods under the 0.7/0.3 mixture."""
    rng = np.random.default_rng(seed)
    runs = []
    for light in masses_per_run:
        which = rng.random(n) < light
        runs.append(CENTRES[which.astype(int)] + rng.normal(0, SD, (n, 2)))
    draws = np.clip(np.stack(runs, axis=1), 0, 1)
    return draws, log_like(draws)


def log_like(P):
    parts = [np.log(w) - 0.5 * np.sum(((P - c) / SD) ** 2, axis=-1) for c, w in zip(CENTRES, (0.7, 0.3))]
    return np.logaddexp(*parts)


def judge(draws, lp, **kw):
    runs = draws.shape[1]
    kw.setdefault("ess", [draws.shape[0]] * runs)
    return posterior_verdict.judge(draws, lp, [0.0] * runs, [0.1] * runs, ["p0", "p1"], **kw)


def test_a_bimodal_posterior_of_known_masses_is_converged_with_a_region_of_mass_0_3():
    draws, lp = mixture_runs([0.3] * 6)
    verdict = judge(draws, lp)
    assert verdict.converged, verdict.reasons
    assert verdict.line.startswith("Posterior converged")
    light = [r for r in verdict.regions if "0.6" in r.label or "0.7" in r.label]
    assert len(light) == 1 and light[0].mass == pytest.approx(0.3, abs=0.03)
    assert verdict.precision["met"].all()
    assert [c.passed for c in verdict.checks] == [True, True, True]
    assert verdict.badge["reproduce"] is True  # 1,000 effective draws a run: R̂ is computed


def test_runs_that_split_the_mass_differently_are_not_precise_and_the_runs_needed_are_said():
    # the default specimen's arm: 0.20, 0.52, 0.31, 0.43 across runs
    draws, lp = mixture_runs([0.20, 0.52, 0.31, 0.43])
    verdict = judge(draws, lp, run_nfev=[600_000] * 4)
    assert not verdict.converged and verdict.precision_met is False
    region = max(verdict.regions, key=lambda r: r.se)
    assert region.se == pytest.approx(np.std([0.20, 0.52, 0.31, 0.43], ddof=1) / 2, abs=0.02)
    assert region.spread.endswith("across runs") and np.ptp(region.run_mass) > 0.25  # the runs' range is shown
    # SE ~0.07 against 0.05: about 4·(0.07/0.05)² ≈ 8 runs
    assert 6 <= verdict.needed["runs"] <= 14
    assert verdict.needed["evaluations"] == verdict.needed["runs"] * 600_000
    assert "would suffice" in verdict.line or "more" in verdict.line


def test_a_run_that_missed_a_mode_fails_the_region_check():
    draws, lp = mixture_runs([0.3, 0.3, 0.3, 0.3, 0.0])
    verdict = judge(draws, lp)
    failed = [c for c in verdict.checks if c.passed is False]
    assert [c.name for c in failed] == ["every region in every run"]
    assert "run 5" in failed[0].detail
    assert not verdict.converged and "missed a region" in verdict.line


def test_runs_sharing_a_bias_pass_every_agreement_yet_the_best_fit_and_the_insertion_test_catch_it():
    # every run misses the light mode alike: they agree with one another (precision met, R̂ fine)
    draws, lp = mixture_runs([0.0] * 6)
    alone = judge(draws, lp)
    assert alone.converged, alone.reasons
    # the best fit found otherwise sits at the missed mode's peak, as probable as the draws
    peak = CENTRES[1]
    best = (peak, float(log_like(peak[None])[0]), "the best ranking fit")
    caught = judge(draws, lp, best_fit=best)
    assert not caught.converged
    assert "missed a mode at least as probable as the best ranking fit" in caught.line
    # UltraNest's insertion-order test failing in a run is a hard failure too
    flagged = judge(draws, lp, insertion=[True] * 5 + [False])
    assert not flagged.converged and "insertion-order test fails in run 6" in flagged.line


def test_a_cut_run_is_never_converged_and_no_precision_is_promised():
    draws, lp = mixture_runs([0.3] * 4)
    verdict = judge(draws, lp, complete=[True, True, False, True], run_nfev=[1000] * 4)
    assert not verdict.converged
    assert verdict.reasons[0] == "1 of 4 runs cut by the budget before their stopping rule (run 3)"
    assert verdict.needed is None  # a cut run says nothing of what the full runs would need


def test_the_badge_is_computed_only_on_enough_effective_draws_per_run():
    draws, lp = mixture_runs([0.3] * 4)
    few = judge(draws, lp, ess=[1000, 1000, 120, 1000])
    assert few.badge["reproduce"] is None and "120 effective draws" in few.badge["text"]
    assert few.converged  # the badge does not decide: the precision does


def test_doubling_the_steps_catches_runs_whose_steps_were_too_few():
    draws, lp = mixture_runs([0.3, 0.3, 0.3, 0.3, 0.3, 0.05], n=2000)
    verdict = judge(draws, lp, steps=[2, 2, 2, 2, 2, 4])
    check = next(c for c in verdict.checks if c.name == "steps doubled")
    assert check.passed is False and "run 6" in check.detail
    fine = judge(*mixture_runs([0.3] * 6, n=2000), steps=[2, 2, 2, 4, 2, 2])
    assert next(c for c in fine.checks if c.name == "steps doubled").passed


def test_a_flat_direction_is_called_undetermined_and_a_cut_box_moves_the_mass():
    # a ridge: the likelihood is as high all along p0 + p1 = 1, so p0 is allowed over its whole box
    def ridge(U):
        U = np.atleast_2d(U)
        return -0.5 * ((U[:, 0] + U[:, 1] - 1) / 0.01) ** 2 - 0.5 * ((U[:, 2] - 0.5) / 0.05) ** 2

    rng = np.random.default_rng(1)
    p0 = rng.random(4000)
    draws = np.column_stack([p0, 1 - p0 + rng.normal(0, 0.01, 4000), rng.normal(0.5, 0.05, 4000)])
    draws = np.clip(draws, 0, 1)
    found = posterior_profile.profile(ridge, draws, ridge(draws))
    flat, pinned = np.asarray(found["log_like"][0]), np.asarray(found["log_like"][2])
    assert np.nanmax(flat) - np.nanmin(flat) < 0.1  # flat within the noise along the ridge
    lo, hi = posterior_profile.undetermined(found["unit"][0], flat)
    assert lo < 0.06 and hi > 0.94  # over the whole grid across the box
    assert posterior_profile.undetermined(found["unit"][2], pinned) is None  # p2 is pinned to 0.5 ± 0.05
    lo, hi = posterior_profile.allowed(found["unit"][2], pinned)
    assert 0.35 < lo < 0.5 < hi < 0.65
    # the box of p0 cut to its upper two thirds: the posterior's draws with p0 ≥ 1/3
    verdict = posterior_verdict.judge(
        draws.reshape(1000, 4, 3), ridge(draws).reshape(1000, 4), [0.0] * 4, [0.1] * 4, ["p0", "p1", "p2"]
    )
    flat_draws = draws.reshape(1000, 4, 3).reshape(-1, 3)
    cuts = posterior_profile.sensitivity(flat_draws, 0, verdict.regions, flat_draws)
    assert cuts[0]["kept"] == pytest.approx(2 / 3, abs=0.03)
    assert cuts[0]["shift"][0] == 1 and cuts[0]["shift"][1] < -0.5  # p1 = 1 − p0 falls with p0's box
