"""The objective: counts every evaluation, enforces an exact budget, keeps the best so far.

The budget is enforced here and nowhere else (docs/design.md#objective-and-budget): evaluation number budget+1 raises
``BudgetExhausted``; a batch larger than what is left is cut, the cut rows get +inf, and the
next call raises. Optimisers work in unit coordinates u ∈ [0, 1]^d; points outside are clipped to
the box (and counted) so every backend sees the same feasible set.
"""

from __future__ import annotations

import time

import numpy as np

from bwbench.errors import BudgetExhausted


class Objective:
    """Loss = MSE (N²) = −F_err of a problem, on an exact evaluation budget.

    ``batch``/``__call__`` give losses; ``residuals`` gives the residual vectors the loss is the
    mean square of (least-squares backends), counted against the same budget.
    """

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

    def _admit(self, U) -> tuple[int, np.ndarray]:
        """How many rows of U (m, d) the budget runs, and those rows clipped to the box; raises for a
        wrong shape or a spent budget."""
        if U.ndim != 2 or U.shape[1] != self.dim:
            raise ValueError(f"expected points of dimension {self.dim}, got shape {U.shape}")
        if self.exhausted:
            raise BudgetExhausted(f"budget of {self.budget} evaluations is spent")
        take = min(len(U), self.remaining)
        return take, np.clip(U[:take], 0.0, 1.0)

    def batch(self, U) -> np.ndarray:
        """Losses of the rows of U (shape (m, d)); rows past the budget are not run (+inf)."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        take, U_run = self._admit(U)
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
        take, U_run = self._admit(U)
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

    def residuals(self, U) -> np.ndarray:
        """Residual vectors of the rows of U: shape (m, n) for U of shape (m, d), (n,) for one point (d,).

        Needs a problem with ``residual_batch(P) -> (m, n)`` (model − data, in the square root of
        the loss's unit, rows of +inf where the model blows up); raises ``TypeError`` otherwise.
        Counted and cut exactly like ``batch``: each row is one evaluation, rows past the budget
        are not run and read +inf, a call once the budget is spent raises ``BudgetExhausted``;
        points are clipped to the box. A row with any non-finite entry is returned as all +inf.
        The loss recorded for the trace and the best point is the row's mean square (+inf for a
        non-finite row), which is the problem's ``loss_batch`` of the same point up to rounding.
        """
        residual_batch = getattr(self.problem, "residual_batch", None)
        if not callable(residual_batch):
            raise TypeError(
                f"{type(self.problem).__name__} has no residual_batch: "
                "only its loss can be evaluated (use batch or __call__)"
            )
        U = np.asarray(U, dtype=float)
        single = U.ndim == 1
        U = np.atleast_2d(U)
        take, U_run = self._admit(U)
        if not take:  # an empty batch: nothing run, nothing counted
            return np.empty((0, int(getattr(self.problem, "n_data", 0))))
        run = np.atleast_2d(np.array(residual_batch(self.problem.from_unit(U_run)), dtype=float))
        if run.shape[0] != take:
            raise ValueError(f"residual_batch returned {run.shape[0]} rows for {take} points")
        finite = np.all(np.isfinite(run), axis=1)
        run[~finite] = np.inf  # a NaN from a blow-up must read +inf, like a loss
        with np.errstate(over="ignore"):  # a huge finite residual may square to inf: a loss of inf
            losses = np.where(finite, np.mean(np.where(finite[:, None], run, 0.0) ** 2, axis=1), np.inf)
        R = np.full((len(U), run.shape[1]), np.inf)
        R[:take] = run
        self._record(U_run, losses)
        return R[0] if single else R

    @property
    def jacobian_cost(self) -> int:
        """Evaluations one ``residual_jacobian`` is charged; 0 when the problem has no exact Jacobian."""
        return (
            int(getattr(self.problem, "jacobian_cost", 0))
            if callable(getattr(self.problem, "residual_jacobian", None))
            else 0
        )

    def residual_jacobian(self, u):
        """(residual (n,), its Jacobian (n, d) in unit coordinates) of one point u (d,), exact (the
        problem's ``residual_jacobian``: the model's sensitivities integrated with its state); None when
        the problem could not give it at this point (a caller then takes differences); (+inf residual,
        None) where the simulation itself did not finish (a plain evaluation there would be +inf too).

        Charged ``jacobian_cost`` evaluations whether or not it succeeds (the work was done): the
        cost of a simulation with sensitivities measured in plain simulations, so a backend using
        exact Jacobians spends the budget as fairly as one taking differences. Past the budget: the
        evaluations left are charged and ``BudgetExhausted`` raised."""
        cost = self.jacobian_cost
        if cost < 1:
            raise TypeError(f"{type(self.problem).__name__} has no exact Jacobian")
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        if u.shape != (self.dim,):
            raise ValueError(f"expected a point of shape ({self.dim},), got {u.shape}")
        if self.exhausted:
            raise BudgetExhausted(f"budget of {self.budget} evaluations is spent")
        if self.remaining < cost:
            self.nfev = self.budget
            raise BudgetExhausted(f"budget of {self.budget} evaluations is spent")
        P = self.problem.from_unit(u)
        found = self.problem.residual_jacobian(P)
        if found is None or found[1] is None:
            self.nfev += cost
            return found
        r, J = found
        from bwbench.engine.box import box_derivative

        J = J * box_derivative(P, self.problem.lower, self.problem.upper, self.problem.log_scaled)[None, :]
        with np.errstate(over="ignore"):
            loss = float(np.mean(r**2)) if np.all(np.isfinite(r)) else np.inf
        self._record(u[None, :], np.array([loss]))
        self.nfev += cost - 1
        return r, J

    def exploration(self, reserve: int):
        """An ``Objective`` over a cheaper copy of the problem (its ``exploration()``: the same search
        space, the model simulated more cheaply), on this budget less ``reserve`` evaluations; None when
        the problem has none or too little budget is left. Its evaluations count here once ``charge``d;
        its best point is not recorded here (its losses are not the problem's own)."""
        make = getattr(self.problem, "exploration", None)
        cheaper = make() if callable(make) else None
        if cheaper is None or self.remaining - int(reserve) < 1:
            return None
        return Objective(cheaper, self.remaining - int(reserve))

    def charge(self, exploration: Objective) -> None:
        """Count the evaluations an ``exploration`` objective ran against this budget."""
        self.nfev = min(self.budget, self.nfev + exploration.nfev)

    def apply(self, U, simulate) -> np.ndarray:
        """``simulate(P)`` (physical rows (m, d) → rows (m, ...)) of the rows of U, each counted as one
        evaluation, cut and refused past the budget like ``batch`` (rows not run are NaN): for a
        simulation that is not a loss, e.g. the trajectory a check of the fit reads. The best point
        and the trace are not touched."""
        U = np.atleast_2d(np.asarray(U, dtype=float))
        take, U_run = self._admit(U)
        run = np.asarray(simulate(self.problem.from_unit(U_run)), dtype=float)
        self.nfev += take
        out = np.full((len(U), *run.shape[1:]), np.nan)
        out[:take] = run
        return out

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
