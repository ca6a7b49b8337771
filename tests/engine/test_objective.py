"""The objective's exact budget, counted independently of the objective itself."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bwbench.engine.objective import Objective
from bwbench.errors import BudgetExhausted


class CountingSphere:
    """A fake problem that counts every point it is asked to evaluate."""

    dim = 3
    param_names = ("a", "b", "c")
    info: dict = {}
    lower = np.zeros(3)
    upper = np.full(3, 2.0)

    def __init__(self):
        self.evaluated = 0

    def from_unit(self, U):
        return self.lower + np.asarray(U) * (self.upper - self.lower)

    def loss_batch(self, P):
        self.evaluated += len(P)
        loss = np.sum((P - 1.0) ** 2, axis=1)
        return np.where(P[:, 0] > 1.9, np.nan, loss)  # NaN from a "blow-up" must become +inf


@settings(max_examples=60, deadline=None)
@given(
    budget=st.integers(1, 60),
    calls=st.lists(st.one_of(st.just(0), st.integers(1, 25)), min_size=1, max_size=40),
)
def test_no_call_sequence_exceeds_the_budget(budget, calls):
    problem = CountingSphere()
    objective = Objective(problem, budget)
    rng = np.random.default_rng(budget)
    for size in calls:  # 0 = a single call, n = a batch of n
        try:
            if size == 0:
                objective(rng.random(3))
            else:
                out = objective.batch(rng.random((size, 3)))
                assert out.shape == (size,)
        except BudgetExhausted:
            break
        assert problem.evaluated <= budget
    assert problem.evaluated == objective.nfev <= budget
    if sum(max(c, 1) for c in calls) >= budget:
        assert problem.evaluated == budget
        with pytest.raises(BudgetExhausted):
            objective(rng.random(3))
        with pytest.raises(BudgetExhausted):
            objective.batch(rng.random((2, 3)))
        assert problem.evaluated == budget


def test_a_batch_is_cut_to_what_is_left():
    problem = CountingSphere()
    objective = Objective(problem, 10)
    objective.batch(np.full((7, 3), 0.5))
    out = objective.batch(np.full((5, 3), 0.25))
    assert problem.evaluated == 10
    assert np.all(np.isfinite(out[:3])) and np.all(np.isposinf(out[3:]))
    with pytest.raises(BudgetExhausted):
        objective(np.full(3, 0.5))


def test_best_and_trace_follow_the_evaluations():
    problem = CountingSphere()
    objective = Objective(problem, 100)
    points = np.array([[0.0, 0.0, 0.0], [0.99, 0.5, 0.5], [0.25, 0.25, 0.25], [0.5, 0.5, 0.4], [0.5, 0.5, 0.5]])
    losses = objective.batch(points)
    assert np.isposinf(losses[1])  # NaN from the problem is a loss of +inf
    assert objective.trace_nfev == [1, 3, 4, 5]
    np.testing.assert_allclose(objective.trace_mse, [3.0, 0.75, 0.04, 0.0], atol=1e-12)
    np.testing.assert_allclose(objective.best_params, [1.0, 1.0, 1.0])
    np.testing.assert_allclose(objective.best_so_far([0, 1, 2, 3, 5]), [np.inf, 3.0, 3.0, 0.75, 0.0])


def test_points_outside_the_box_are_clipped_and_counted():
    problem = CountingSphere()
    objective = Objective(problem, 5)
    loss = objective(np.array([-1.0, 0.5, 2.0]))
    assert loss == pytest.approx(1.0 + 0.0 + 1.0)
    assert problem.evaluated == 1


def test_budget_must_be_positive():
    with pytest.raises(ValueError, match="budget"):
        Objective(CountingSphere(), 0)
