"""The degrading, pinching Bouc-Wen model (``bwbn``) against an independent solve_ivp reference written
here from Foliente (1995)'s equations in time (z and ε = ∫z·u̇·dt, A = 1), its exact Jacobians against
central differences in both formulations, its maps, and a fit that recovers a degrading record."""

import functools
import warnings
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

import bwbench
from bwbench.data.specimen_input import from_frame
from bwbench.engine.objective import Objective
from bwbench.models import registry
from bwbench.models.bwbn.model import MODEL
from bwbench.problems.hysteresis.formulations import make_problem
from reference_bwbn import growing_cycles, reference_force

# k, α, c, β, γ, n, δν, δη, ζ_s, p, q, ψ, δψ, λ (N/mm, –, N·s/mm, mm⁻ⁿ, mm⁻ⁿ, –, mm⁻², mm⁻², –, mm⁻², –, mm, mm⁻¹, –)
PINCHED = np.array([100.0, 0.05, 0.5, 0.02, 0.02, 1.5, 2e-4, 1e-4, 0.9, 2e-3, 0.1, 3.0, 2e-4, 0.2])
# narrow pinching (ψ/z_u0 ≈ 0.06), unloading softer than loading (γ > β), n = 1: a sharp yield
NARROW = np.array([50.0, 0.1, 0.0, 0.01, 0.05, 1.0, 1e-4, 3e-4, 0.8, 5e-3, 0.2, 1.0, 0.0, 0.1])


@pytest.fixture(scope="module")
def signal():
    x_of, v_of, t = growing_cycles()
    return SimpleNamespace(t=t, x=x_of(t), v=v_of(t), a=np.zeros_like(t)), x_of, v_of


@pytest.mark.parametrize("P", [PINCHED, NARROW], ids=["pinched", "narrow"])
def test_matches_solve_ivp_to_two_hundred_thousandths_of_the_force_range(P, signal):
    s, x_of, v_of = signal
    ours = MODEL.force_batch(P[None], s)[0]
    ref = reference_force(P, s.t, x_of, v_of)
    assert np.max(np.abs(ours - ref)) <= 2e-5 * np.ptp(ref)


def test_registered_and_maps_to_and_from_the_direct_parameters(signal):
    s, _, _ = signal
    assert registry.get("bwbn") is MODEL and "bwbn" in registry.names()
    theta, coef = MODEL.from_direct(PINCHED)
    np.testing.assert_allclose(MODEL.to_direct(theta, coef), PINCHED, rtol=1e-12)
    w = MODEL.trajectories(theta[None], s)[0]
    force = coef["c"] * s.v + coef["k"] * s.x + coef["h"] * w
    np.testing.assert_allclose(force, MODEL.force_batch(PINCHED[None], s)[0], rtol=0, atol=1e-9)


def test_direct_force_sensitivities_match_central_differences(signal):
    s, _, _ = signal
    F, dF = MODEL.force_sensitivities(PINCHED, s)
    np.testing.assert_array_equal(F, MODEL.force_batch(PINCHED[None], s)[0])
    for j in range(len(PINCHED)):
        step = np.zeros(len(PINCHED))
        step[j] = 1e-6 * PINCHED[j] if PINCHED[j] else 1e-6
        fd = (MODEL.force_batch((PINCHED + step)[None], s)[0] - MODEL.force_batch((PINCHED - step)[None], s)[0]) / (
            2 * step[j]
        )
        assert np.linalg.norm(dF[:, j] - fd) <= 1e-6 * np.linalg.norm(fd), MODEL.direct_parameters()[j].name


@functools.cache
def degrading_frame(noise=5.0, seed=3):
    """A slow column test of growing amplitude from the reference (not bwbench's kernel), 5 N noise."""
    x_of, v_of, t = growing_cycles(period=20.0, rate=10.0)
    f = reference_force(PINCHED, t, x_of, v_of) + np.random.default_rng(seed).normal(0, noise, len(t))
    return pd.DataFrame({"time_s": t, "displacement_mm": x_of(t), "force_N": f})


@pytest.mark.parametrize("seed", [0, 1])
def test_identifiable_jacobian_through_the_linear_solve_matches_central_differences(seed):
    problem = make_problem(from_frame(degrading_frame().copy(), "column"), {"model": "bwbn"})
    objective = Objective(problem, 1000)
    u = 0.2 + 0.6 * np.random.default_rng(seed).random(problem.dim)
    r, J = objective.residual_jacobian(u)
    assert objective.nfev == MODEL.sensitivity_cost
    np.testing.assert_array_equal(r, objective.residuals(u))
    for j, name in enumerate(problem.param_names):
        e = np.zeros(problem.dim)
        e[j] = 1e-6
        fd = (objective.residuals(u + e) - objective.residuals(u - e)) / 2e-6
        assert np.linalg.norm(J[:, j] - fd) <= 1e-4 * max(np.linalg.norm(fd), 1e-3 * np.linalg.norm(J)), name


def test_a_fit_recovers_an_independently_simulated_degrading_column():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", bwbench.FitWarning)
        fit = bwbench.fit(degrading_frame(), model="bwbn", budget=600, seed=1, name="column")
    # a loading protocol of growing cycles starts its specimen from rest (pre-rolled it fitted at 27 N)
    assert fit.problem.start.resolved == "rest" and "growing amplitude" in fit.problem.start.reason
    assert fit.rmse_N < 5.3  # the 5 N noise
    p = fit.params
    assert p["k0"] == pytest.approx(100.0, rel=0.01) and p["alpha"] == pytest.approx(0.05, abs=0.005)
    assert p["dnu"] == pytest.approx(2e-4, rel=0.1) and p["zeta_s"] == pytest.approx(0.9, abs=0.03)
