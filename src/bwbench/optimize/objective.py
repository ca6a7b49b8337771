"""The objective: counts every evaluation, enforces an exact budget, keeps the best so far.

The budget is enforced here and nowhere else (DESIGN.md §3): evaluation number budget+1 raises
``BudgetExhausted``; a batch larger than what is left is cut, the cut rows get +inf, and the
next call raises. Optimisers work in unit coordinates u ∈ [0, 1]^d; points outside are clipped to
the box (and counted) so every backend sees the same feasible set.
"""

from __future__ import annotations

import time

import numpy as np

from bwbench.errors import BudgetExhausted


class Objective:
    """Loss = MSE (N²) = −F_err of a problem, on an exact evaluation budget."""

    def __init__(self, problem, budget: int):
        if int(budget) < 1:
            raise ValueError(f"budget must be a positive number of evaluations, got {budget}")
        self.problem = problem
        self.budget = int(budget)
        self.dim = problem.dim
        self.nfev = 0
        self.best_mse = np.inf
        self.best_u = None
        # (evaluation index, best MSE) at every improvement: enough to draw best-so-far curves.
        self.trace_nfev: list[int] = []
        self.trace_mse: list[float] = []
        self.started = time.perf_counter()

    @property
    def remaining(self) -> int:
        return self.budget - self.nfev

    @property
    def exhausted(self) -> bool:
        return self.nfev >= self.budget

    @property
    def best_params(self) -> np.ndarray | None:
        return None if self.best_u is None else self.problem.from_unit(self.best_u)

    def batch(self, U) -> np.ndarray:
        """Losses of the rows of U (shape (m, d)); rows past the budget are not run (+inf)."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        if U.ndim != 2 or U.shape[1] != self.dim:
            raise ValueError(f"expected points of dimension {self.dim}, got shape {U.shape}")
        if self.exhausted:
            raise BudgetExhausted(f"budget of {self.budget} evaluations is spent")
        take = min(len(U), self.remaining)
        U_run = np.clip(U[:take], 0.0, 1.0)
        losses = np.full(len(U), np.inf)
        if take:
            run = self.problem.loss_batch(self.problem.from_unit(U_run))
            run = np.where(np.isfinite(run), run, np.inf)
            losses[:take] = run
            self._record(U_run, run)
        return losses

    def batch_with_likelihood(self, U) -> tuple[np.ndarray, np.ndarray]:
        """(losses, log-likelihoods) of the rows of U, counted and cut like ``batch``: the problem's own
        ``log_likelihood_batch`` when it has one (e.g. linear coefficients integrated out), else the
        Gaussian likelihood with σ integrated out under Jeffreys' prior, −(n/2)·log(MSE). Rows past
        the budget, and rows that blow up, get loss +inf and log-likelihood −inf."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        if U.ndim != 2 or U.shape[1] != self.dim:
            raise ValueError(f"expected points of dimension {self.dim}, got shape {U.shape}")
        if self.exhausted:
            raise BudgetExhausted(f"budget of {self.budget} evaluations is spent")
        take = min(len(U), self.remaining)
        U_run = np.clip(U[:take], 0.0, 1.0)
        losses, loglik = np.full(len(U), np.inf), np.full(len(U), -np.inf)
        if take:
            P = self.problem.from_unit(U_run)
            if hasattr(self.problem, "log_likelihood_batch"):
                run, ll = self.problem.log_likelihood_batch(P)
            else:
                run = self.problem.loss_batch(P)
                n = float(getattr(self.problem, "n_data", 1000))
                with np.errstate(divide="ignore", invalid="ignore"):  # an exact fit: tiny, not 0
                    ll = -0.5 * n * np.log(np.maximum(run, np.finfo(float).tiny))
            finite = np.isfinite(run)
            run = np.where(finite, run, np.inf)
            losses[:take] = run
            loglik[:take] = np.where(finite & np.isfinite(ll), ll, -np.inf)
            self._record(U_run, run)
        return losses, loglik

    def __call__(self, u) -> float:
        """Loss of one point (1-D, unit coordinates)."""
        u = np.asarray(u, dtype=float)
        if u.shape != (self.dim,):
            raise ValueError(f"expected a point of shape ({self.dim},), got {u.shape}")
        return float(self.batch(u[None, :])[0])

    def _record(self, U_run, losses) -> None:
        start = self.nfev
        self.nfev += len(losses)
        # Walk the batch in order so the trace is the same as if points came one by one.
        for i, loss in enumerate(losses):
            if loss < self.best_mse:
                self.best_mse = float(loss)
                self.best_u = U_run[i].copy()
                self.trace_nfev.append(start + i + 1)
                self.trace_mse.append(self.best_mse)

    def best_so_far(self, at) -> np.ndarray:
        """Best MSE after each evaluation count in ``at`` (+inf before the first finite loss)."""
        at = np.asarray(at)
        idx = np.searchsorted(self.trace_nfev, at, side="right") - 1
        values = np.asarray(self.trace_mse + [np.inf])
        return np.where(idx >= 0, values[idx], np.inf)
