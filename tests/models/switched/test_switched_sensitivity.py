"""The switched Bouc-Wen kernel with forward sensitivities (the switched model in both formulations and
both states, the classic model in both formulations): the same z as the plain kernel bit for bit,
∂z/∂θ as central differences of the plain kernel (RK4 substeps and backward-Euler steps alike), and the
exact Jacobian of every formulation against differences of the objective, charged its measured price."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.engine.objective import Objective
from bwbench.models.switched import simulation as kernel
from bwbench.models.switched.identifiable import kernel_hysteretic
from bwbench.models.switched.sensitivity import hysteretic_sensitivity, identifiable_jacobian
from bwbench.problems.hysteresis.formulations import make_problem

SPECIMENS = Path(__file__).resolve().parents[3] / "data" / "specimens"
SPECIMEN = SPECIMENS / "pom-mt24u01_0.01MPa_r1.csv"
# An lsq-trf optimum of the switched model, identifiable, shared state, on SPECIMEN (x_y₊ mm, n₊, η₊,
# x_y₋ mm, n₋, η₋, ρ): MSE 1.01 N².
OPTIMUM = np.array([18.9711, 3.81431, -0.00797041, 1.18689, 2.36495, -0.945580, 1.59284])
VARIANTS = [
    ("switched-bouc-wen", "identifiable", "shared"),
    ("switched-bouc-wen", "identifiable", "split"),
    ("switched-bouc-wen", "paper", "shared"),
    ("switched-bouc-wen", "paper", "split"),
    ("bouc-wen", "identifiable", None),
    ("bouc-wen", "direct", None),
]


def problem_of(model, formulation, state, specimen=SPECIMEN):
    settings = {"model": model, "formulation": formulation, **({"state": state} if state else {})}
    return make_problem(read_specimen(specimen), settings)


def interior_point(problem, seed):
    """A seeded point of the box's middle 60 % where the model does not blow up."""
    rng = np.random.default_rng(seed)
    for _ in range(50):
        u = 0.2 + 0.6 * rng.random(problem.dim)
        if np.isfinite(Objective(problem, 1).batch(u[None, :])[0]):
            return u
    raise AssertionError("no finite point in 50 draws")


def assert_columns_match(J, fd, rtol, names):
    """Each column within ``rtol`` of its differences, relative to the column (or, for a column the
    residual does not depend on, such as η in the split state, to the largest column)."""
    largest = max(np.linalg.norm(fd, axis=0))
    for j, name in enumerate(names):
        scale = np.linalg.norm(fd[:, j])
        assert np.linalg.norm(J[:, j] - fd[:, j]) <= rtol * max(scale, 1e-6 * largest), f"column {name}"


@pytest.mark.parametrize("model, formulation, state", VARIANTS, ids=lambda v: str(v))
@pytest.mark.parametrize("seed", [0, 1])
def test_the_exact_jacobian_matches_central_differences_and_costs_its_measured_price(model, formulation, state, seed):
    problem = problem_of(model, formulation, state)
    objective = Objective(problem, 1000)
    u = interior_point(problem, seed)
    found = objective.residual_jacobian(u)
    assert found is not None
    r, J = found
    assert objective.nfev == problem.model.sensitivity_cost == 3
    assert np.array_equal(r, objective.residuals(u))  # the same z to the bit, the same force
    fd = np.empty_like(J)
    for j in range(problem.dim):
        e = np.zeros(problem.dim)
        e[j] = 1e-5
        fd[:, j] = (objective.residuals(u + e) - objective.residuals(u - e)) / 2e-5
    assert_columns_match(J, fd, 1e-4, problem.param_names)


def test_the_identifiable_jacobian_at_an_optimum_matches_differences():
    problem = problem_of("switched-bouc-wen", "identifiable", "shared")
    objective = Objective(problem, 100)
    u = problem.to_unit(OPTIMUM)
    assert np.all((u > 0.01) & (u < 0.99))
    r, J = objective.residual_jacobian(u)
    assert np.mean(r**2) == pytest.approx(1.008, rel=1e-3)
    fd = np.empty_like(J)
    for j in range(problem.dim):
        e = np.zeros(problem.dim)
        e[j] = 1e-5
        fd[:, j] = (objective.residuals(u + e) - objective.residuals(u - e)) / 2e-5
    assert_columns_match(J, fd, 1e-4, problem.param_names)


@pytest.mark.parametrize("state", ["shared", "split"])
def test_z_is_the_plain_kernels_and_the_map_to_kernel_parameters_is_differentiated_right(state):
    problem = problem_of("switched-bouc-wen", "identifiable", state)
    theta = OPTIMUM[: problem.dim]
    s = problem.signal
    z, _ = problem.model.trajectory_sensitivities(theta, s, state)
    assert np.array_equal(z, problem.model.trajectories(theta[None, :], s, state)[0])  # lockstep
    H = kernel_hysteretic(theta[None, :], state)[0]
    assert np.array_equal(z, kernel.hysteretic_state(H, s.t, s.x, s.v, state))  # scalar
    M = identifiable_jacobian(theta, state)
    for j in range(len(theta)):
        h = 1e-6 * abs(theta[j])
        up, down = theta.copy(), theta.copy()
        up[j] += h
        down[j] -= h
        fd = (kernel_hysteretic(up[None, :], state)[0] - kernel_hysteretic(down[None, :], state)[0]) / (2 * h)
        assert np.allclose(M[:, j], fd, rtol=1e-7, atol=1e-9 * np.max(np.abs(H))), f"column {j}"


def test_sensitivities_through_backward_euler_steps_match_differences():
    """'+' saturates at z_s = 3.2e-3 mm and relaxes there at n·A/z_s = 632/mm: 52 RK4 substeps a sample
    (0.083 mm), past the 32 allowed, so the kernel takes backward-Euler steps; '−' takes 16 RK4 substeps.
    (With n < 1 the plain kernel itself is not smooth in H near z = 0: no test point there.)"""
    problem = problem_of("switched-bouc-wen", "paper", "shared")
    s = problem.signal
    H = np.array([1.0, 2.0, 2e4, 8e4, 0.8, 2.5, 3e4, 5e4])  # (A, n, β, γ) per branch
    z_s = (H[0] / (H[2] + H[3])) ** (1 / H[1])
    assert H[1] * H[0] / z_s * np.median(np.abs(np.diff(s.x))) > 32  # the backward-Euler regime
    z, dZ = hysteretic_sensitivity(H, np.eye(8), s.t, s.x, s.v)
    assert np.array_equal(z, kernel.hysteretic_state(H, s.t, s.x, s.v))
    fd = np.empty_like(dZ)
    for j in range(8):
        h = 1e-6 * H[j]
        up, down = H.copy(), H.copy()
        up[j] += h
        down[j] -= h
        fd[:, j] = (kernel.hysteretic_state(up, s.t, s.x, s.v) - kernel.hysteretic_state(down, s.t, s.x, s.v)) / (2 * h)
    assert_columns_match(dZ, fd, 1e-5, [f"H{j}" for j in range(8)])


def test_a_blow_up_gives_no_sensitivities():
    """η > 1 on unloading runs away from saturation (the plain kernel's +inf): None, not NaN columns."""
    problem = problem_of("bouc-wen", "identifiable", None)
    theta = np.array([0.05, 2.0, 3.0])
    assert not np.all(np.isfinite(problem.model.trajectories(theta[None, :], problem.signal)))
    assert problem.model.trajectory_sensitivities(theta, problem.signal) is None


def test_the_joint_jacobian_matches_differences():
    specimens = [read_specimen(SPECIMEN), read_specimen(SPECIMENS / "pom-mt24u01_0.03MPa_r1.csv")]
    problem = make_problem(specimens, {"model": "switched-bouc-wen", "formulation": "identifiable"})
    objective = Objective(problem, 100)
    u = problem.to_unit(OPTIMUM)
    r, J = objective.residual_jacobian(u)
    assert objective.nfev == 3
    assert np.array_equal(r, objective.residuals(u))
    fd = np.empty_like(J)
    for j in range(problem.dim):
        e = np.zeros(problem.dim)
        e[j] = 1e-5
        fd[:, j] = (objective.residuals(u + e) - objective.residuals(u - e)) / 2e-5
    assert_columns_match(J, fd, 1e-4, problem.param_names)


@pytest.mark.parametrize("model, formulation", [("switched-bouc-wen", "identifiable"), ("bouc-wen", "identifiable")])
def test_lsq_trf_with_exact_jacobians_reaches_what_differences_reach(model, formulation):
    """On the 0.01 MPa specimen (noise ≈ 1 N): both Jacobians end at the same optimum within 1 %."""
    from bwbench.engine import fitting

    problem = problem_of(model, formulation, None)
    exact = fitting.run(problem, "lsq-trf", 600, 0)
    differences = fitting.run(problem, "lsq-trf", 600, 0, {"jacobian": "differences"})
    assert exact.nfev == differences.nfev == 600
    assert exact.mse <= 1.01 * differences.mse
