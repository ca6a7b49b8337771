"""Bounds on the solved linear coefficients, and the inertia rule on sine tests (linear_bounds, inertia_rule)."""

import numpy as np
import pytest
from scipy.optimize import lsq_linear

from bwbench.datasets import mr_damper
from bwbench.models import excitation
from bwbench.models.switched.model import LAYOUT
from bwbench.problems.hysteresis.joint_problem import stack_signals
from bwbench.problems.hysteresis.linear import solve as ls
from bwbench.problems.hysteresis.linear.bounds import M_MAX, physical_bounds


def damper_test(amplitude, frequency, seed=0):
    """A recorded MR-damper sine test (velocity channel with 0.5 mm/s noise) as (excitation, force)."""
    test = mr_damper.sine_test(
        amplitude_mm=amplitude,
        frequency_hz=frequency,
        voltage=1.0,
        rate_hz=500.0,
        cycles=2,
        peak_force_N=None,
        rng=seed,
        velocity_noise_mm_s=0.5,
    )
    return excitation.measured(test.t, test.x, test.v), test.f


def explicit_design(e, w, names):
    plus = e.v >= 0
    col = {"m": e.a}
    for b, mask in (("+", plus), ("-", ~plus)):
        col.update({f"c{b}": e.v * mask, f"k{b}": e.x * mask, f"h{b}": w * mask, f"f{b}": 1.0 * mask})
    return np.column_stack([col[n] for n in names])


def test_bounded_coefficients_stay_inside_their_bounds_and_are_the_bounded_least_squares_optimum():
    e, f = damper_test(25.0, 1.0)
    rng = np.random.default_rng(11)
    # w: smooth hysteresis-like trajectories, different per row; a large inertia in the force so m wants to be big
    phase = rng.uniform(0.1, 1.5, size=(16, 1))
    W = np.tanh(np.cumsum(np.sign(e.v)[None, :] * phase * 0.05, axis=1))
    f = f + 3.0 * e.a - 0.02 * e.v * (e.v < 0)
    bounds = {"m": (0.0, 0.5), "c+": (0.0, np.inf), "c-": (0.0, np.inf), "h+": (-50.0, 50.0), "f-": (-10.0, 10.0)}
    design = ls.LinearDesign(e, f, LAYOUT, fix_mass=None, bounds=bounds)
    free = ls.LinearDesign(e, f, LAYOUT, fix_mass=None, mass_min=None)
    sol, unbounded = design.solve(W, residual=True), free.solve(W)
    assert sol.bound_active.sum() >= 8  # the bounds bite on most rows
    names = list(sol.names)
    for name, (lo, hi) in bounds.items():
        values = sol.coef[:, names.index(name)]
        assert np.all((values >= lo) & (values <= hi)), name
    X_names = design.free_names
    for i in range(len(W)):
        X = explicit_design(e, W[i], X_names)
        lower = [bounds.get(n, (-np.inf, np.inf))[0] for n in X_names]
        upper = [bounds.get(n, (-np.inf, np.inf))[1] for n in X_names]
        scale = np.linalg.norm(X, axis=0)
        reference = lsq_linear(
            X / scale, f, bounds=(np.array(lower) * scale, np.array(upper) * scale), method="bvls", tol=1e-12
        )
        rss = np.sum((X @ (reference.x / scale) - f) ** 2)
        assert sol.mse[i] * len(f) == pytest.approx(rss, rel=1e-7)
        residual = X @ sol.coef[i, sol.free_index] - f
        np.testing.assert_allclose(sol.residual[i], residual, atol=1e-7 * np.abs(f).max())
        assert sol.mse[i] >= unbounded.mse[i] * (1 - 1e-12)


def test_physical_bounds_follow_the_sign_convention():
    e, f = damper_test(25.0, 1.0)
    from bwbench.problems.hysteresis.linear.columns import coefficient_units

    units = coefficient_units(LAYOUT)
    bounds, notes = physical_bounds(LAYOUT, e, f, units)
    assert bounds == {"m": (0.0, M_MAX), "c+": (0.0, np.inf), "c-": (0.0, np.inf)}
    flipped, notes = physical_bounds(LAYOUT, e, -f, units)  # a loop that runs clockwise: no sign imposed
    assert flipped == {"m": (0.0, M_MAX)} and "either sign" in notes[0]


def test_one_sine_test_never_separates_the_mass_but_sines_at_two_frequencies_do():
    slow, f_slow = damper_test(25.0, 1.0, 0)
    fast, f_fast = damper_test(10.0, 2.5, 1)
    for e, f in ((slow, f_slow), (fast, f_fast)):
        check = ls.inertia_check(e, f, LAYOUT)
        # the noise is 1e-3 of the inertia force of 1 t, yet a sine confounds m with k
        assert check.excited and check.inertia_rms_N > 100 * check.noise_N
        assert not check.separable and check.sine_segments == 1 and "a sine confounds m with k" in check.reason
        assert ls.LinearDesign(e, f, LAYOUT).mass == ls.M_UNFITTED
    both = stack_signals([slow, fast])
    check = ls.inertia_check(both, np.concatenate([f_slow, f_fast]), LAYOUT)
    assert check.fit and check.sine_segments == 2 and "every record is a sine test" in check.reason
    # a record that is not a sine keeps the noise rule
    t = np.arange(0.0, 2.0, 2e-3)
    two_tone = excitation.measured(t, 20 * np.sin(2 * np.pi * 2 * t) + 5 * np.sin(2 * np.pi * 5.3 * t + 0.4))
    check = ls.inertia_check(
        two_tone, 50 * np.tanh(two_tone.v / 10) + np.random.default_rng(2).normal(0, 1, len(t)), LAYOUT
    )
    assert check.sine_segments == 0 and check.fit


def test_continuous_offsets_tie_the_two_branch_offsets():
    e, f = damper_test(10.0, 2.5)
    w = np.tanh(np.cumsum(np.sign(e.v) * 0.05))
    design = ls.LinearDesign(e, f, LAYOUT, offsets="continuous")
    sol = design.solve(w[None, :], residual=True)
    names = list(sol.names)
    assert sol.coef[0, names.index("f+")] == sol.coef[0, names.index("f-")]
    X = explicit_design(e, w, [n for n in design.free_names])
    X[:, list(design.free_names).index("f+")] = 1.0  # one offset column over both branches
    beta, *_ = np.linalg.lstsq(X, f, rcond=None)
    assert sol.mse[0] == pytest.approx(np.mean((X @ beta - f) ** 2), rel=1e-9)
    branch = ls.LinearDesign(e, f, LAYOUT).solve(w[None, :])
    assert branch.mse[0] <= sol.mse[0]


def test_the_loss_alone_is_the_full_solves_mse_on_bounded_free_and_blown_up_rows():
    """``LinearDesign.mse`` (what a loss calls) gives solve(Z).mse to the bit: rows whose bounds bite
    (re-solved), rows inside them, a row that blew up (+inf) and one so large that its squares overflow
    (its w-column is dropped as dependent: the fit without it)."""
    e, f = damper_test(25.0, 1.0)
    rng = np.random.default_rng(11)
    phase = rng.uniform(0.1, 1.5, size=(16, 1))
    W = np.tanh(np.cumsum(np.sign(e.v)[None, :] * phase * 0.05, axis=1))
    W[3, 40:] = np.inf
    W[5] *= 1e300
    f = f + 3.0 * e.a - 0.02 * e.v * (e.v < 0)
    bounds = {"m": (0.0, 0.5), "c+": (0.0, np.inf), "c-": (0.0, np.inf), "h+": (-50.0, 50.0), "f-": (-10.0, 10.0)}
    active = []
    for design in (
        ls.LinearDesign(e, f, LAYOUT, fix_mass=None, bounds=bounds),
        ls.LinearDesign(e, f, LAYOUT, fix_mass=None, mass_min=None),
    ):
        solution = design.solve(W)
        np.testing.assert_array_equal(design.mse(W), solution.mse)
        np.testing.assert_array_equal(design.mse(W[7]), solution.mse[7:8])  # one row, as a one-point call
        assert np.isposinf(solution.mse[3]) and not solution.full_rank[5]
        assert np.all(np.isfinite(np.delete(solution.mse, 3)))
        active.append(int(solution.bound_active.sum()))
    assert active[0] >= 8 and active[1] == 0  # the bounded design re-solves most rows, the free one none
