"""The firefly backend: beats random search on a sphere and never leaves the unit box."""

from __future__ import annotations

import numpy as np

from bwbench.engine.objective import Objective
from bwbench.errors import BudgetExhausted
from bwbench.optimizers import firefly, random_search
from fakes import SphereProblem

DIM = 14


class SpyObjective(Objective):
    """Keeps every point the backend asks for, before the objective's own clipping."""

    def __init__(self, problem, budget):
        super().__init__(problem, budget)
        self.asked = []

    def batch(self, U):
        self.asked.append(np.array(U, dtype=float))
        return super().batch(U)


def _run(minimize, seed, budget=2_000):
    objective = SpyObjective(SphereProblem(), budget)
    try:
        minimize(objective, rng=np.random.default_rng(seed))
    except BudgetExhausted:
        pass
    return objective


def test_firefly_beats_random_search_on_a_sphere_and_stays_in_the_box():
    ff, rs = _run(firefly.minimize, 3), _run(random_search.minimize, 3)
    assert ff.nfev == rs.nfev == 2_000
    assert ff.best_mse < 0.2 * rs.best_mse, (ff.best_mse, rs.best_mse)
    asked = np.vstack(ff.asked)
    assert ((asked >= 0.0) & (asked <= 1.0)).all()
    # One batch per generation, the whole swarm each time.
    assert {len(U) for U in ff.asked} == {25}
