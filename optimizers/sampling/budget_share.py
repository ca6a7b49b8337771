"""A share of an objective's budget: what a sampler's start (local searches, a re-optimisation) may
spend, with its own best point, every evaluation counted against the real budget."""

from __future__ import annotations

import numpy as np

from bwbench.errors import BudgetExhausted


class Share:
    """``objective`` seen through a smaller budget, with its own best point; evaluations count against
    the real one. ``BudgetExhausted`` when the share is spent."""

    def __init__(self, objective, budget: int):
        self.objective, self.dim, self.problem = objective, objective.dim, objective.problem
        self.budget = int(budget)
        self.stop = objective.nfev + int(budget)
        self.best_u, self.best_mse = None, np.inf

    @property
    def nfev(self) -> int:
        return self.objective.nfev

    @property
    def remaining(self) -> int:
        return min(self.stop - self.objective.nfev, self.objective.remaining)

    @property
    def exhausted(self) -> bool:
        return self.remaining <= 0

    def _take(self, U):
        if self.exhausted:
            raise BudgetExhausted("this share of the budget is spent")
        U = np.atleast_2d(np.asarray(U, dtype=float))
        return U, min(len(U), self.remaining)

    def _keep_best(self, U, losses):
        if len(losses) and np.min(losses) < self.best_mse:
            i = int(np.argmin(losses))
            self.best_u, self.best_mse = np.clip(U[i], 0.0, 1.0), float(losses[i])

    def batch(self, U):
        U, take = self._take(U)
        losses = np.full(len(U), np.inf)
        losses[:take] = self.objective.batch(U[:take])
        self._keep_best(U[:take], losses[:take])
        return losses

    def residuals(self, U):
        U = np.asarray(U, dtype=float)
        single = U.ndim == 1
        U, take = self._take(U)
        run = self.objective.residuals(U[:take])
        R = np.full((len(U), run.shape[1]), np.inf)
        R[:take] = run
        with np.errstate(over="ignore"):
            losses = np.where(
                np.all(np.isfinite(run), axis=1), np.mean(np.where(np.isfinite(run), run, 0) ** 2, axis=1), np.inf
            )
        self._keep_best(U[:take], losses)
        return R[0] if single else R
