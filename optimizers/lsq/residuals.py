"""lsq-trf's objective as scipy ``least_squares`` sees it: a finite residual function with a batched or
exact Jacobian counted on the budget (every point with its sensitivities, when ``fused``), and the tests
that end a local search early: a stall over a window of iterations, or arrival at the best optimum an
earlier search ended at (``lsq_trf``'s docstring)."""

from __future__ import annotations

import numpy as np

from bwbench.engine.finite_penalty import WorstFinitePenalty
from bwbench.errors import BudgetExhausted
from bwbench.optimizers.lsq.agreement import same_optimum


class Stalled(Exception):
    """A local search that no longer makes progress worth its evaluations: restart elsewhere."""


class Arrived(Stalled):
    """A local search that reached an optimum an earlier search ended at (``Residuals.known``)."""


class Residuals:
    """The objective as a finite residual function for least_squares, with a batched Jacobian."""

    def __init__(
        self,
        objective,
        diff_step: float,
        stall_iters: int = 0,
        stall_rtol: float = 0.0,
        exact: bool = False,
        fused: bool = False,
    ):
        self.objective = objective
        self.exact = exact and getattr(objective, "jacobian_cost", 0) > 0  # a budget share has none
        # Every point trf asks for is simulated with its sensitivities (``_fused``), so the Jacobian trf
        # asks for next at an accepted point is already there.
        self.fused = fused and self.exact
        self._last_J = None
        self.stall_iters, self.stall_rtol = int(stall_iters), float(stall_rtol)
        self.costs: list[float] = []  # mean square at each Jacobian of the current local search
        self.step = float(diff_step)
        if not 0.0 < self.step < 0.5:
            raise ValueError(f"diff_step must be in (0, 0.5) (unit coordinates), got {diff_step}")
        has_residuals = callable(getattr(objective.problem, "residual_batch", None))
        self._evaluate = objective.residuals if has_residuals else self._sqrt_loss
        self.penalty = WorstFinitePenalty(before_any_finite=1.0)
        self._last_u = None
        self._last_r = None
        self.search_best = np.inf  # the lowest mean square the current local search has seen
        self.search_best_u = None  # and where (unit coordinates)
        self.search_best_r = None  # and its residual vector (model − data): the fitted curve, up to the data
        self.has_residuals = has_residuals
        # Ends of the finished local searches (MSE, u): a search stops once it reaches the best of them
        # (``_check_arrival``); ``arrival_rtol`` None when searches run to their own end (a study).
        self.known: list[tuple] = []
        self.arrival_rtol: float | None = None
        self.arrival_floor = 0.0

    def _sqrt_loss(self, U):
        with np.errstate(invalid="ignore"):
            return np.sqrt(self.objective.batch(U))[:, None]

    def raw(self, U) -> np.ndarray:
        """Residual rows (m, n) of the points U (m, d), +inf rows on blow-up; remembers mean squares."""
        U = np.atleast_2d(U)
        R = np.atleast_2d(self._evaluate(U))
        finite = np.all(np.isfinite(R), axis=1)
        for u, row in zip(U[finite], R[finite]):
            self._note(u, row)
        return R

    def _note(self, u, row) -> None:
        """Remember the mean square of a finite residual row at u: the penalty's worst, the search's best."""
        with np.errstate(over="ignore"):
            ms = float(np.mean(row**2))
        self.penalty(ms)
        if ms < self.search_best:
            self.search_best, self.search_best_u, self.search_best_r = ms, np.clip(u, 0.0, 1.0), row.copy()

    def _fused(self, u) -> np.ndarray | None:
        """The residual at u from one simulation with sensitivities (charged what a Jacobian is), its
        Jacobian kept for ``jac``; +inf where the simulation did not finish (a plain one would not
        either: not run); None where the problem gave no answer (then the plain simulation runs)."""
        found = self.objective.residual_jacobian(np.asarray(u, dtype=float))
        if found is not None and found[1] is None:
            return found[0]  # not finished: charged, and no second simulation to learn the same
        if found is None or not np.all(np.isfinite(found[0])):
            return None
        r, J = found
        self._note(u, r)
        self._remember(u, r)
        # Sensitivities grow without bound near a blow-up; trf squares the columns: keep those it can.
        self._last_J = J if np.all(np.isfinite(J)) and np.max(np.abs(J)) <= 1e100 else None
        return r

    def _finite(self, r) -> np.ndarray:
        if np.all(np.isfinite(r)):
            return r
        # A constant vector of mean square 10 × the worst finite one seen: a cost above all others.
        return np.full(r.shape, np.sqrt(self.penalty.value))

    def start(self, u0) -> np.ndarray | None:
        """Evaluate a starting point; its finite residual (kept for ``fun``), or None on blow-up."""
        self.costs = []
        self.search_best, self.search_best_u, self.search_best_r = np.inf, None, None
        r = self._fused(u0) if self.fused else None
        if r is None:
            r = self.raw(u0)[0]
        if not np.all(np.isfinite(r)):
            return None
        self._remember(u0, r)
        return r

    def _remember(self, u, r):
        if self._last_u is None or not np.array_equal(u, self._last_u):
            self._last_J = None  # the kept Jacobian is of the point before
        self._last_u, self._last_r = np.array(u, dtype=float), r

    def fun(self, u) -> np.ndarray:
        if self._last_u is not None and np.array_equal(u, self._last_u):
            return self._last_r.copy()  # scipy re-asks for x0: no new simulation
        r = self._fused(u) if self.fused else None
        if r is not None and np.all(np.isfinite(r)):
            return r.copy()  # remembered with its Jacobian by ``_fused``
        if r is None:
            r = self.raw(u)[0]
        r = self._finite(r)
        self._remember(u, r)
        return r.copy()

    def jac(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        r0 = self.fun(u)  # normally remembered: scipy takes the Jacobian at the point fun just ran
        self._check_progress(float(np.mean(r0**2)))
        self._check_arrival(u, r0)
        if self._last_J is not None and np.array_equal(u, self._last_u):
            return self._last_J  # simulated with its sensitivities when fun ran (``fused``)
        if self.exact:
            found = self.objective.residual_jacobian(u)
            # Sensitivities grow without bound near a blow-up; trf squares the columns: keep those it can.
            ok = found is not None and found[1] is not None
            if ok and np.all(np.isfinite(found[1])) and np.max(np.abs(found[1])) <= 1e100:
                return found[1]
            self._stop_if_spent()  # no sensitivities here (a stiff corner): differences, if the budget allows
        h = np.where(u + self.step <= 1.0, self.step, -self.step)  # inward at the upper bound
        R = self.raw(u + np.diag(h))
        self._stop_if_spent()
        bad = ~np.all(np.isfinite(R), axis=1)
        if bad.any():  # blew up next to u: look on the other side, if it is inside the box
            h[bad] = -h[bad]
            inside = bad & (u + h >= 0.0) & (u + h <= 1.0)
            if inside.any():
                idx = np.flatnonzero(inside)
                R[idx] = self.raw(u[None, :] + np.diag(h)[idx])
                self._stop_if_spent()
            bad = ~np.all(np.isfinite(R), axis=1)
        J = (R - r0[None, :]) / h[:, None]
        J[bad] = 0.0  # blown up on both sides: no slope to follow along that coordinate
        return J.T

    def _check_progress(self, cost: float):
        # scipy's ftol looks at one step; a search creeping along a flat valley makes tiny but
        # steady steps for hundreds of iterations, so judge the progress over a window instead.
        self.costs.append(cost)
        w = self.stall_iters
        if w > 0 and len(self.costs) > w and cost > (1.0 - self.stall_rtol) * self.costs[-1 - w]:
            raise Stalled

    def _check_arrival(self, u, r):
        # The point trf stands at is the best optimum the earlier searches ended at: this search would
        # end there too, after the iterations its stall test needs. Half ``_agreed``'s tolerances, so
        # that the search still agrees with the best end when a later search moves it a little.
        if self.arrival_rtol is None or not self.known:
            return
        best = min(self.known, key=lambda end: end[0])
        end = (float(np.mean(r**2)), np.clip(u, 0.0, 1.0), r)
        if same_optimum(end, best, best[0] * (1.0 + 0.5 * self.arrival_rtol) + self.arrival_floor, 0.5):
            raise Arrived

    def _stop_if_spent(self):
        # A batch cut at the budget leaves +inf rows that are not blow-ups; nothing more can run.
        if self.objective.exhausted:
            raise BudgetExhausted(f"budget of {self.objective.budget} evaluations is spent")
