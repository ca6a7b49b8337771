"""Objective.residuals: counted and cut exactly like batch, its recorded loss is the problem's loss."""

from pathlib import Path

import numpy as np
import pytest

from bwbench.data.specimen import read_specimen
from bwbench.engine.objective import Objective
from bwbench.errors import BudgetExhausted
from bwbench.testing import LossOnlySphereProblem, SphereProblem
from paper_problems import IdentifiableProblem, SwitchedBoucWenProblem

ROOT = Path(__file__).resolve().parents[2]
SPECIMEN = ROOT / "data" / "specimens" / "pom-mt24u01_0.05MPa_r1.csv"


def blowing_up_sphere():
    return SphereProblem(dim=3, centre=0.5, n_data=5, blow_up=lambda P: P[:, 0] > 0.9)


def test_a_single_point_is_one_evaluation_and_gives_one_residual_vector():
    problem = blowing_up_sphere()
    objective = Objective(problem, budget=5)
    r = objective.residuals([0.2, 0.5, 0.7])
    assert r.shape == (5,)
    # √n_data·(u − centre) in the first d entries, zeros after
    np.testing.assert_allclose(r, np.sqrt(5) * np.array([-0.3, 0.0, 0.2, 0.0, 0.0]))
    assert objective.nfev == problem.evaluated == 1
    assert objective.best_mse == pytest.approx(0.09 + 0.04, rel=1e-14)
    assert objective.trace_nfev == [1]


def test_a_batch_counts_every_row_and_blown_up_rows_read_inf():
    problem = blowing_up_sphere()
    objective = Objective(problem, budget=10)
    U = np.array([[0.5, 0.5, 0.5], [0.95, 0.5, 0.5], [0.6, 0.5, 0.5], [0.4, 0.4, 0.5]])
    R = objective.residuals(U)
    assert R.shape == (4, 5) and objective.nfev == problem.evaluated == 4
    assert np.all(np.isinf(R[1])) and np.all(np.isfinite(np.delete(R, 1, axis=0)))
    assert objective.best_mse == 0.0 and np.array_equal(objective.best_u, U[0])
    # the same points as losses: the same numbers, and the trace of one point at a time
    twin = Objective(blowing_up_sphere(), budget=10)
    losses = twin.batch(U)
    np.testing.assert_allclose(
        np.mean(np.where(np.isfinite(R), R, 0) ** 2, axis=1)[[0, 2, 3]], losses[[0, 2, 3]], rtol=1e-14, atol=1e-300
    )
    assert twin.trace_nfev == objective.trace_nfev and twin.best_mse == objective.best_mse


def test_points_outside_the_box_are_clipped_and_counted():
    objective = Objective(blowing_up_sphere(), budget=3)
    r = objective.residuals(np.array([-0.5, 0.5, 1.5]))
    np.testing.assert_allclose(r[:3], np.sqrt(5) * np.array([-0.5, 0.0, 0.5]))
    np.testing.assert_array_equal(objective.best_u, [0.0, 0.5, 1.0])


def test_a_batch_is_cut_at_the_budget_and_the_next_call_raises():
    problem = blowing_up_sphere()
    objective = Objective(problem, budget=7)
    objective.residuals(np.full((3, 3), 0.3))
    R = objective.residuals(np.full((6, 3), 0.4))  # 4 left: rows 4 and 5 are not run
    assert problem.evaluated == objective.nfev == 7 and objective.exhausted
    assert np.all(np.isfinite(R[:4])) and np.all(np.isinf(R[4:]))
    for call in (
        lambda: objective.residuals(np.full(3, 0.5)),
        lambda: objective.residuals(np.full((2, 3), 0.5)),
        lambda: objective.batch(np.full((2, 3), 0.5)),
        lambda: objective(np.full(3, 0.5)),
    ):
        with pytest.raises(BudgetExhausted):
            call()
    assert problem.evaluated == 7


def test_residuals_and_losses_share_one_budget():
    problem = blowing_up_sphere()
    objective = Objective(problem, budget=4)
    objective.batch(np.full((2, 3), 0.3))
    objective(np.full(3, 0.3))
    objective.residuals(np.full((5, 3), 0.3))
    assert problem.evaluated == objective.nfev == 4
    with pytest.raises(BudgetExhausted):
        objective.residuals(np.full(3, 0.3))


def test_a_problem_without_residuals_is_refused_without_counting():
    problem = LossOnlySphereProblem(dim=3, n_data=5)
    objective = Objective(problem, budget=4)
    with pytest.raises(TypeError, match="no residual_batch"):
        objective.residuals(np.full(3, 0.3))
    assert objective.nfev == problem.evaluated == 0
    with pytest.raises(ValueError, match="dimension 3"):
        Objective(blowing_up_sphere(), budget=4).residuals(np.full((2, 4), 0.3))


class NaNResiduals(SphereProblem):
    def residual_batch(self, P):
        R = super().residual_batch(P)
        R[P[:, 1] > 0.8, 2] = np.nan  # one NaN entry: the whole row is a blow-up
        return R


def test_a_row_with_a_nan_reads_inf_and_is_never_the_best():
    objective = Objective(NaNResiduals(dim=3, centre=0.9, n_data=4), budget=3)
    R = objective.residuals(np.array([[0.9, 0.9, 0.9], [0.1, 0.1, 0.1]]))
    assert np.all(np.isinf(R[0])) and np.all(np.isfinite(R[1]))
    np.testing.assert_array_equal(objective.best_u, [0.1, 0.1, 0.1])


@pytest.mark.parametrize("make", [SwitchedBoucWenProblem, IdentifiableProblem], ids=["paper", "identifiable"])
def test_recorded_loss_is_the_mean_square_and_the_problems_loss(make):
    problem = make(read_specimen(SPECIMEN))
    U = np.random.default_rng(4).random((6, problem.dim))
    objective = Objective(problem, budget=6)
    R = objective.residuals(U)
    assert R.shape == (6, problem.n_data) == (6, 1921)
    losses = problem.loss_batch(problem.from_unit(U))
    finite = np.isfinite(losses)
    assert finite.sum() >= 4  # the seed gives real fits to compare, not blow-ups
    np.testing.assert_array_equal(np.all(np.isfinite(R), axis=1), finite)
    mean_square = np.mean(R[finite] ** 2, axis=1)
    np.testing.assert_allclose(mean_square, losses[finite], rtol=1e-12)
    assert objective.best_mse == pytest.approx(np.min(losses), rel=1e-12)
    np.testing.assert_array_equal(objective.best_u, U[np.argmin(losses)])
