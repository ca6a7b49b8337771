"""Spencer's model with forward sensitivities: the same ẏ as the plain kernel, ∂ẏ/∂θ as central
differences of it, and the exact Jacobian of the identifiable formulation (single file and joint)
against differences, charged its measured cost against the budget."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.engine.objective import Objective
from bwbench.errors import BudgetExhausted
from bwbench.models.spencer.kernel import ydot_batch
from bwbench.models.spencer.model import MODEL
from bwbench.models.spencer.sensitivity import ydot_sensitivity_batch
from bwbench.problems.hysteresis.formulations import make_problem

DATA = Path(__file__).resolve().parents[3] / "data" / "mr_damper"
# A fit's optimum on mr_25mm_1Hz_0V (x_y mm, n, η, v_y mm/s, r₀, κ₀ 1/s) and a point of the box far from it.
OPTIMUM = np.array([0.02435, 1.5079, 0.0527, 2.2478, 0.05188, 0.2055])
ELSEWHERE = np.array([0.3, 2.5, -0.8, 40.0, 0.5, 3.0])


def arrays(path):
    problem = make_problem(read_specimen(path), {"model": "spencer", "formulation": "identifiable"})
    return problem, [np.ascontiguousarray(np.asarray(getattr(problem.signal, k), dtype=float)) for k in "txva"]


def _central_differences(theta, signal, j, rel, tol):
    h = rel * (theta[j] if j in (0, 3, 4) else max(abs(theta[j]), 1.0))  # relative for the log-scaled x_y, v_y, r₀
    up, down = theta.copy(), theta.copy()
    up[j] += h
    down[j] -= h
    return (ydot_batch(up[None], *signal, tol=tol)[0][0] - ydot_batch(down[None], *signal, tol=tol)[0][0]) / (2 * h)


@pytest.mark.parametrize("theta", [OPTIMUM, ELSEWHERE], ids=["optimum", "elsewhere"])
def test_sensitivities_match_central_differences_at_a_tight_tolerance(theta):
    """The sensitivity equations themselves: at tolerance 1e-9 per step (the step control's jitter
    small against steps of 1e-3) they agree with central differences of the plain kernel to 1e-4."""
    _, signal = arrays(DATA / "mr_25mm_1Hz_0V.csv")
    Z, S, status = ydot_sensitivity_batch(theta[None], *signal, tol=1e-9)
    plain, _ = ydot_batch(theta[None], *signal, tol=1e-9)
    assert status[0] == 0
    assert np.array_equal(Z[0], plain[0])  # the same steps, the same ẏ: the state's arithmetic is the plain kernel's
    for j in range(6):
        fd = _central_differences(theta, signal, j, 1e-3, 1e-9)
        assert np.linalg.norm(S[0, :, j] - fd) <= 1e-4 * np.linalg.norm(fd), f"column {j}"


@pytest.mark.parametrize("theta", [OPTIMUM, ELSEWHERE], ids=["optimum", "elsewhere"])
def test_sensitivities_at_the_fits_tolerance_match_differences_to_a_few_thousandths(theta):
    """At the tolerance a fit runs at (1e-5 per step) the sensitivities are the ODE's on the plain
    kernel's steps, not the derivative of those discrete steps: against central differences (steps of
    1 %, above the step control's jitter) they agree to ~1e-3 (≤ 1.2e-2 for η at the optimum, where ẏ
    hardly depends on it) — far closer than Gauss-Newton needs."""
    _, signal = arrays(DATA / "mr_25mm_1Hz_0V.csv")
    Z, S, status = ydot_sensitivity_batch(theta[None], *signal)
    plain, _ = ydot_batch(theta[None], *signal)
    assert status[0] == 0
    assert np.array_equal(Z[0], plain[0])
    for j in range(6):
        fd = _central_differences(theta, signal, j, 1e-2, 1e-5)
        assert np.linalg.norm(S[0, :, j] - fd) <= 2e-2 * np.linalg.norm(fd), f"column {j}"


@pytest.mark.parametrize(
    "files", [["mr_25mm_1Hz_0V.csv"], ["mr_25mm_1Hz_0V.csv", "mr_10mm_2Hz_1V.csv"]], ids=["single", "joint"]
)
def test_the_identifiable_jacobian_matches_differences_and_costs_its_measured_price(files):
    specimens = [read_specimen(DATA / f) for f in files]
    problem = make_problem(
        specimens if len(specimens) > 1 else specimens[0], {"model": "spencer", "formulation": "identifiable"}
    )
    objective = Objective(problem, 100)
    u = problem.to_unit(OPTIMUM)
    r, J = objective.residual_jacobian(u)
    assert objective.nfev == MODEL.sensitivity_cost == 2
    r0 = objective.residuals(u)
    assert np.max(np.abs(r - r0)) <= 1e-6 * np.max(np.abs(r0))  # ẏ to rounding (|w|^n by exp and log)
    for j in range(problem.dim):
        e = np.zeros(problem.dim)
        # Steps of 1e-3 (unit coordinates), above the step control's jitter at the fit's tolerance; well
        # inside the box (η sits near its upper edge). The sensitivities agree to ~1e-3 there (see above).
        e[j] = min(1e-3, 0.1 * u[j], 0.1 * (1.0 - u[j]))
        fd = (objective.residuals(u + e) - objective.residuals(u - e)) / (2 * e[j])
        assert np.linalg.norm(J[:, j] - fd) <= 5e-3 * np.linalg.norm(fd), f"column {problem.param_names[j]}"


@pytest.mark.parametrize(
    "bounds, held",
    [
        ({}, {"k1": 0.0}),  # the physical default: k₁ ≥ 0 holds a column of x at 0 (unbounded k₁ = −6.65 N/mm)
        ({"k1": [-np.inf, np.inf], "c1": [0, 50]}, {"c1": 50.0}),  # a held coefficient of the w-column (ẏ)
        (
            {"k1": [0, 1], "c1": [0, 50]},
            {"k1": 1.0, "c1": 50.0},
        ),  # both held (k₁ = 1.91 N/mm with c₁ = 50): the offset solved
    ],
    ids=["k1", "c1", "both"],
)
def test_the_jacobian_with_coefficients_held_on_their_bounds_matches_differences(bounds, held):
    """Variable projection over the free columns, the held w-column's contribution differentiated
    and projected: against central differences at a point where the bounds are active."""
    problem = make_problem(
        read_specimen(DATA / "mr_25mm_1Hz_0V.csv"),
        {"model": "spencer", "formulation": "identifiable", "bounds": bounds},
    )
    coef = dict(zip(problem.linear_names, problem.linear(OPTIMUM)))
    assert {name: coef[name] for name in held} == held  # the bounds are active at this point
    objective = Objective(problem, 100)
    u = problem.to_unit(OPTIMUM)
    found = objective.residual_jacobian(u)
    assert found is not None
    r, J = found
    r0 = objective.residuals(u)
    assert np.max(np.abs(r - r0)) <= 1e-6 * np.max(np.abs(r0))
    for j in range(problem.dim):
        e = np.zeros(problem.dim)
        e[j] = min(1e-3, 0.1 * u[j], 0.1 * (1.0 - u[j]))  # as above
        fd = (objective.residuals(u + e) - objective.residuals(u - e)) / (2 * e[j])
        assert np.linalg.norm(J[:, j] - fd) <= 1e-2 * np.linalg.norm(fd), f"column {problem.param_names[j]}"


def test_an_exact_jacobian_past_the_budget_spends_what_is_left_and_stops():
    problem, _ = arrays(DATA / "mr_10mm_2Hz_1V.csv")
    objective = Objective(problem, 3)
    u = problem.to_unit(OPTIMUM)
    objective.residuals(u)
    objective.residuals(u)
    with pytest.raises(BudgetExhausted):
        objective.residual_jacobian(u)  # 1 left, 2 needed
    assert objective.nfev == 3


def test_lsq_trf_with_exact_jacobians_reaches_the_optimum_differences_reach():
    """On a generator test (6 N force noise) both reach the noise; exact Jacobians, charged 2
    evaluations instead of 6, leave more of the budget to restarts."""
    from bwbench.engine import fitting

    problem, _ = arrays(DATA / "mr_10mm_5Hz_0V.csv")
    exact = fitting.run(problem, "lsq-trf", 800, 1)
    differences = fitting.run(problem, "lsq-trf", 800, 1, {"jacobian": "differences"})
    assert exact.nfev == differences.nfev == 800
    assert np.sqrt(exact.mse) < 6.6 and np.sqrt(differences.mse) < 6.6


def test_the_direct_jacobian_matches_differences():
    """The direct formulation: F = c₁·ẏ(θ(P)) + k₁·(x − x₀), the map θ(P) differentiated by hand."""
    from bwbench.models.spencer.model import direct_from_theta

    problem = make_problem(read_specimen(DATA / "mr_25mm_1Hz_0V.csv"), {"model": "spencer", "formulation": "direct"})
    objective = Objective(problem, 100)
    # c₁, f₀ of the bounded solve at OPTIMUM (k₁ on its bound 0); k₁ = 10 N/mm puts the point inside
    # the direct box, whose floor is now k₁ = 0 (the loops dissipate), not on that floor.
    P = direct_from_theta(OPTIMUM, [91.2, 10.0, -168.0])
    P[8] = 200.0  # A away from the gauge the box centres
    u = problem.to_unit(P)
    assert np.all((u > 0.01) & (u < 0.99))
    r, J = objective.residual_jacobian(u)
    assert objective.nfev == 2
    r0 = objective.residuals(u)
    assert np.max(np.abs(r - r0)) <= 1e-6 * np.max(np.abs(r0))
    for j in range(problem.dim):
        e = np.zeros(problem.dim)
        e[j] = 1e-3  # below ~1e-4 the step control's jitter (tolerance 1e-5 per step) dominates the differences
        fd = (objective.residuals(u + e) - objective.residuals(u - e)) / 2e-3
        assert np.linalg.norm(J[:, j] - fd) <= 1e-2 * np.linalg.norm(fd), f"column {problem.param_names[j]}"


def test_a_record_from_rest_is_simulated_from_rest_with_its_sensitivities_too():
    """A ramped sine from rest whose first recorded velocity is noise (not 0): the plain simulation starts
    the model at rest (``starts_from_rest``), and so must the one with sensitivities, else a fit's
    Jacobians (and, with lsq-trf's fused evaluations, its residuals) are those of a pre-rolled start
    (measured: 17 mm/s of ẏ apart on a 62 mm/s range)."""
    from bwbench.models import excitation
    from bwbench.models.start import starts_from_rest

    t = np.arange(0.0, 3.0, 0.002)
    x = 25.0 * np.sin(2 * np.pi * t) * np.minimum(1.0, t / 0.5) ** 2
    v = np.gradient(x, t) + np.random.default_rng(0).normal(0.0, 0.5, t.size)
    signal = excitation.measured(t, x, v)
    assert signal.v[0] != 0.0 and starts_from_rest(signal.t, signal.x, signal.v)
    theta = np.array([0.03, 2.6, 0.2, 19.0, 0.09, 0.2])
    ydot, S = MODEL.trajectory_sensitivities(theta, signal)
    np.testing.assert_array_equal(ydot, MODEL.trajectories(theta[None], signal)[0])
    assert np.all(np.isfinite(S))
