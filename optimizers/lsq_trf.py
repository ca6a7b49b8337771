"""Bounded nonlinear least squares (scipy ``least_squares``, trust-region reflective), random restarts.

Algorithm: Gauss-Newton steps on the residual vector r(u) (model − data, one entry per sample)
inside a trust region, with the reflective handling of the bounds 0 ≤ u ≤ 1 of Branch, Coleman
and Li (method "trf"); the Jacobian is taken by forward differences. On the identifiable
formulation this is variable projection: the coefficients that enter the force linearly are solved
inside every evaluation, so the search sees only the hysteretic parameters. When a local search
stops (``xtol``/``ftol``/gtol 1e-8, ``max_nfev_per_start``, or a stall: the MSE fell by less than
``stall_rtol`` over the last ``stall_iters`` iterations), the next starts from a new uniform
point, until the budget is spent.

Library call: ``scipy.optimize.least_squares(fun, u0, jac=jac, bounds=(0, 1), method="trf",
x_scale=..., diff_step=..., xtol=..., ftol=..., max_nfev=...)`` with ``u0`` uniform in the box.
``jac`` is ours: the d perturbed points of one Jacobian are ONE ``objective.residuals`` batch call
(the kernel simulates a batch in parallel; scipy's "2-point" asks for them one at a time), forward
differences of absolute step ``diff_step`` in unit coordinates, taken inward (backward) where
u + step would leave the box. Every point, Jacobian ones included, counts against the budget;
the residual at the point the Jacobian is taken at is reused from ``fun`` (scipy always asks for
the Jacobian at the last accepted point, which ``fun`` has just evaluated), so one iteration costs
1 + d evaluations. ``BudgetExhausted`` propagates out of ``least_squares`` (scipy does not catch
it), or is raised by ``jac`` when its batch spent the budget. scipy draws no random numbers: the
run's randomness is only the starting points, drawn from ``rng``. ``batched=True``: a Jacobian
is one call of d points (a step is one point).

Options: ``diff_step`` (1e-5, unit coordinates), ``xtol`` (1e-8), ``ftol`` (1e-8),
``jacobian`` ("auto": exact where the problem has it — the model's forward sensitivities through the
linear solve, ``Objective.residual_jacobian``, charged what it costs in plain evaluations, e.g. 2 for
Spencer's model instead of the d = 6 of differences — else forward differences; "differences":
always differences), ``x_scale`` ("jac": variables scaled by the inverse column norms of the Jacobian, updated every
iteration; or "unit": no scaling), ``max_nfev_per_start`` (None: until converged; else scipy's ``max_nfev``
of one local search, i.e. its residual evaluations, Jacobians not included), ``stall_iters`` (5;
0 = never) and ``stall_rtol`` (1e-3); ``stop_agree`` (0: spend the whole budget, as a study does)
and ``agree_rtol`` (1e-2): stop once ``stop_agree`` local searches, each from its own random start,
ended at the best optimum found (``_agreed``: MSE within ``agree_rtol``, and every parameter within 2 %
of its range or, with ``agree_same_fit`` (true), the fitted curves within ``AGREE_FTOL`` (``lsq_agreement``) = 5 % of the
residual RMS of each other) after at least 9 searches (a basin attracting 30 % of starts is then missed
with probability < 5 %) — more starts would spend the budget finding it again (``bwbench fit`` sets 3
unless told otherwise; the result says how many evaluations it used and why it stopped, and
``extras["agreement"]`` states the rule). The fitted-curve clause is for an optimum that is a valley
along a direction the data do not determine: on the switched model's VPP fits the searches that find
it end with MSE within 0.1 % but parameters up to 0.33 of the box apart, and never agreed by place;
their fitted curves differ by < 2 % of the residual RMS. It costs no evaluation (the residual vector
of each end is kept) and two optima with different fits never agree, however close their MSE (a
straight segment between the valley's ends was tried first: it rises 4–48 % in MSE, the valley is
curved). A plateau where the hysteresis does nothing (starts end at one linear fit, far apart) also
agrees by its fitted curve, so agreement that needs the clause waits for ``VALLEY_SEARCHES`` = 18
searches (a basin attracting 1 start in 6 is then missed with probability < 5 %). ``stop_on_arrival`` (true; only with ``stop_agree``): a local search stops as soon as trf
stands at the best optimum earlier searches ended at (half the agreement's tolerances: MSE within
``agree_rtol``/2, every unit coordinate within ``AGREE_UTOL``/2 or the fitted curve within
``AGREE_FTOL``/2): it would end there, after the 5+ iterations its stall test needs (on MR-damper
tests the searches that found the optimum spent about half their evaluations confirming it). It
counts as ending there. ``explore`` (true; only with ``stop_agree``): where the problem has a cheaper copy
(``Objective.exploration``: Spencer's model at tolerance 1e-4, not 1e-5, on every k-th sample of a record of
≥ 1,000 samples per cycle) the searches run there (stall window 3); their best end is then polished on the
problem itself (window 2, a tenth of ``stall_rtol``: the reported fit), all on the one budget, of which
``POLISH_SHARE`` (≥ ``POLISH_MIN``) is kept for the polish; ``extras["exploration"]`` gives the split.

Why the stall test: on the switched model most random starts fall within 10–20 iterations into
one of a few local minima (on the 0.05 MPa specimen, identifiable formulation: 11.1× and 28× the
noise floor; the global one is reached from ~1 start in 6), and then creep along a flat valley
with steps scipy's ``ftol`` (one step's relative decrease) does not stop: 60–120 more iterations,
~8 evaluations each, for < 1 % of MSE. Stopping after 5 iterations with < 0.1 % in total cut the
cost of a start from ~600 to ~110 evaluations (≈ 35 starts in 4,100 instead of ≈ 7): the global
minimum is found far more often, and a start in its basin is stopped within ~1 % of its MSE.
+inf handling (model blew up): a blown-up trial point gets a constant residual vector whose mean
square is 10 × the worst finite mean square seen so far (``WorstFinitePenalty``), so its cost is
above every finite one: trf rejects the step and shrinks its trust region instead of stopping
("Residuals are not finite") or steering by NaN. A blown-up perturbed point of a Jacobian is
retried on the other side of u (one more batch for all such columns); a column blown up on both
sides is set to zero, so the Gauss-Newton step leaves that coordinate alone. A start whose
residual is not finite is redrawn (scipy refuses a non-finite start).

Problems without ``residual_batch`` (only a loss): the residual is the one-element vector
√loss, through ``objective.batch``; the same Gauss-Newton machinery then works on a 1 × d
Jacobian (a much weaker method than on real residuals). ``bwbench.testing.SphereProblem`` has
residuals, so the contract checks exercise the residual path.

Why: the loss is a sum of squares of ~2,000 residuals of a smooth model, so the Jacobian carries
far more information per evaluation than a loss value does: Gauss-Newton converges in a few
iterations from a start in the right basin, and restarts cover the basins.
"""

from __future__ import annotations

import numpy as np
from threadpoolctl import threadpool_limits

from bwbench.errors import BudgetExhausted
from bwbench.optimize.finite_penalty import WorstFinitePenalty
from bwbench.optimize.options import Bool, Choice, Float, Int
from bwbench.optimize.registry import register
from bwbench.optimizers.lsq_agreement import _agreed, _how_agreed, _rule, _same_optimum

OPTIONS = {
    "diff_step": Float(1e-5, minimum=1e-10, maximum=0.1),
    "xtol": Float(1e-8, minimum=1e-15, maximum=1.0),
    "ftol": Float(1e-8, minimum=1e-15, maximum=1.0),
    "x_scale": Choice("jac", ("jac", "unit")),
    "max_nfev_per_start": Int(None, minimum=1, none="until the local search converges or stalls"),
    "stall_iters": Int(5, minimum=0, maximum=10_000),
    "stall_rtol": Float(1e-3, minimum=0.0, maximum=1.0),
    "jacobian": Choice("auto", ("auto", "differences")),
    "stop_agree": Int(0, minimum=0, maximum=1000),
    "agree_rtol": Float(1e-2, minimum=0.0, maximum=1.0),
    "stop_on_arrival": Bool(True),
    "agree_same_fit": Bool(True),
    "explore": Bool(True),
}


class _Stalled(Exception):
    """A local search that no longer makes progress worth its evaluations: restart elsewhere."""


class _Arrived(_Stalled):
    """A local search that reached an optimum an earlier search ended at (``_Residuals.known``)."""


class _Residuals:
    """The objective as a finite residual function for least_squares, with a batched Jacobian."""

    def __init__(self, objective, diff_step: float, stall_iters: int = 0, stall_rtol: float = 0.0, exact: bool = False):
        self.objective = objective
        self.exact = exact and getattr(objective, "jacobian_cost", 0) > 0  # a budget share has none
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
        with np.errstate(over="ignore"):
            for u, row in zip(U[finite], R[finite]):
                ms = float(np.mean(row**2))
                self.penalty(ms)
                if ms < self.search_best:
                    self.search_best, self.search_best_u, self.search_best_r = ms, np.clip(u, 0.0, 1.0), row.copy()
        return R

    def _finite(self, r) -> np.ndarray:
        if np.all(np.isfinite(r)):
            return r
        # A constant vector of mean square 10 × the worst finite one seen: a cost above all others.
        return np.full(r.shape, np.sqrt(self.penalty.value))

    def start(self, u0) -> np.ndarray | None:
        """Evaluate a starting point; its finite residual (kept for ``fun``), or None on blow-up."""
        self.costs = []
        self.search_best, self.search_best_u, self.search_best_r = np.inf, None, None
        r = self.raw(u0)[0]
        if not np.all(np.isfinite(r)):
            return None
        self._remember(u0, r)
        return r

    def _remember(self, u, r):
        self._last_u, self._last_r = np.array(u, dtype=float), r

    def fun(self, u) -> np.ndarray:
        if self._last_u is not None and np.array_equal(u, self._last_u):
            return self._last_r.copy()  # scipy re-asks for x0: no new simulation
        r = self._finite(self.raw(u)[0])
        self._remember(u, r)
        return r.copy()

    def jac(self, u) -> np.ndarray:
        u = np.asarray(u, dtype=float)
        r0 = self.fun(u)  # normally remembered: scipy takes the Jacobian at the point fun just ran
        self._check_progress(float(np.mean(r0**2)))
        self._check_arrival(u, r0)
        if self.exact:
            found = self.objective.residual_jacobian(u)
            # Sensitivities grow without bound near a blow-up; trf squares the columns: keep those it can.
            if found is not None and np.all(np.isfinite(found[1])) and np.max(np.abs(found[1])) <= 1e100:
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
            raise _Stalled

    def _check_arrival(self, u, r):
        # The point trf stands at is the best optimum the earlier searches ended at: this search would
        # end there too, after the iterations its stall test needs. Half ``_agreed``'s tolerances, so
        # that the search still agrees with the best end when a later search moves it a little.
        if self.arrival_rtol is None or not self.known:
            return
        best = min(self.known, key=lambda end: end[0])
        end = (float(np.mean(r**2)), np.clip(u, 0.0, 1.0), r)
        if _same_optimum(end, best, best[0] * (1.0 + 0.5 * self.arrival_rtol) + self.arrival_floor, 0.5):
            raise _Arrived

    def _stop_if_spent(self):
        # A batch cut at the budget leaves +inf rows that are not blow-ups; nothing more can run.
        if self.objective.exhausted:
            raise BudgetExhausted(f"budget of {self.objective.budget} evaluations is spent")


@register(
    "lsq-trf",
    family="least-squares",
    description="scipy least_squares (trust-region reflective), batched forward-difference Jacobian, random restarts",
    options=OPTIONS,
    batched=True,
)
def minimize(
    objective,
    *,
    rng,
    diff_step=1e-5,
    xtol=1e-8,
    ftol=1e-8,
    x_scale="jac",
    max_nfev_per_start=None,
    stall_iters=5,
    stall_rtol=1e-3,
    jacobian="auto",
    stop_agree=0,
    agree_rtol=1e-2,
    stop_on_arrival=True,
    agree_same_fit=True,
    explore=True,
):
    from scipy.optimize import least_squares  # here: scipy.optimize costs ~0.5 s to import

    search = dict(
        least_squares=least_squares,
        diff_step=diff_step,
        xtol=float(xtol),
        ftol=float(ftol),
        x_scale=1.0 if x_scale == "unit" else x_scale,
        max_nfev=None if max_nfev_per_start is None else int(max_nfev_per_start),
        stall=(stall_iters, stall_rtol),
        exact=jacobian == "auto",
    )
    cheaper = (
        objective.exploration(max(POLISH_MIN, int(POLISH_SHARE * objective.budget))) if stop_agree and explore else None
    )
    # One BLAS thread: trf takes an SVD of the (L + d) × d Jacobian every iteration, 5 ms on one
    # core and 95 ms with OpenBLAS's 2 threads on a busy 2-core machine (L ≈ 2,000, d = 14); and
    # the run then does not depend on the machine's thread count.
    with threadpool_limits(limits=1, user_api="blas"):
        if cheaper is None:
            return _restarts(objective, rng, search, stop_agree, agree_rtol, stop_on_arrival, agree_same_fit)
        # The exploring searches' ends need only be within the agreement's tolerances (the best one is
        # polished): a shorter stall window. On the MR-damper generator's tests 3 instead of 5 took
        # 10–25 % fewer evaluations, the same optimum and NRMSE on every test.
        stall = search["stall"]
        search["stall"] = (min(int(stall[0]), EXPLORE_STALL_ITERS), stall[1])
        try:
            extras = _restarts(cheaper, rng, search, stop_agree, agree_rtol, stop_on_arrival, agree_same_fit)
        except BudgetExhausted:
            extras = {"message": "budget exhausted", "stop_reason": "budget exhausted"}
        finally:
            objective.charge(cheaper)
            search["stall"] = stall
        return _polish(objective, cheaper, rng, search, extras)


# Evaluations kept back from the exploring searches for the polish of their best end (``_polish``): it took
# 7–30 on the MR-damper generator's tests (a few trf iterations from an end within ~1 % of the optimum's MSE).
POLISH_SHARE, POLISH_MIN, POLISH_STALL_ITERS, EXPLORE_STALL_ITERS = 0.05, 40, 2, 3


def _polish(objective, cheaper, rng, search, extras) -> dict:
    """One local search on the problem itself from the best end the exploring searches (on ``cheaper``,
    the problem's cheaper simulation) found, then, if they did not agree, more searches there until the
    budget is spent (a budget is spent whole unless searches agree); the extras, with how it went."""
    before = objective.nfev
    u0 = cheaper.best_u
    # It starts where the searches agreed, within ~1 % of the optimum's MSE: stalled after two iterations
    # (not five) of less than a tenth of ``stall_rtol`` in all.
    stall = min(int(search["stall"][0]), POLISH_STALL_ITERS)
    residuals = _Residuals(objective, search["diff_step"], stall, 0.1 * search["stall"][1], exact=search["exact"])
    how = "their best end polished"
    if u0 is None or residuals.start(u0) is None:  # nothing finite there, or not on the finer simulation
        return _restarts(objective, rng, search, 0, 0.0, False, False)
    try:
        _local_search(residuals, u0, search)
    except _Stalled:
        pass
    except BudgetExhausted:
        how += " until the budget ran out"
    polish, rest = objective.nfev - before, ""
    if extras.get("stop_reason") == "budget exhausted" and not objective.exhausted:
        try:
            _restarts(objective, rng, search, 0, 0.0, False, False)
        except BudgetExhausted:
            rest = f", and the {objective.nfev - before - polish} left in more local searches there"
    note = getattr(cheaper.problem, "exploration_note", "") or "a cheaper copy of the problem"
    extras = dict(extras)
    extras["message"] = (
        f"{extras['message']}; the local searches ran on a cheaper simulation ({note}), {how} on the model's own "
        f"in {polish} evaluations{rest}"
    )
    extras["exploration"] = {"simulation": note, "evaluations": cheaper.nfev, "polish": polish}
    return extras


def _local_search(residuals, u0, search) -> None:
    """One trf search from u0 (already ``start``ed); ``_Stalled`` (and ``_Arrived``) propagate."""
    search["least_squares"](
        residuals.fun,
        u0,
        jac=residuals.jac,
        bounds=(0.0, 1.0),
        method="trf",
        x_scale=search["x_scale"],
        xtol=search["xtol"],
        ftol=search["ftol"],
        max_nfev=search["max_nfev"],
    )


def _restarts(objective, rng, search, stop_agree, agree_rtol, stop_on_arrival, agree_same_fit) -> dict:
    """Local searches from uniform random starts until the objective raises ``BudgetExhausted`` or
    ``stop_agree`` of them agree (the module docstring); the run's extras when they agree."""
    d = objective.dim
    stall_iters, stall_rtol = search["stall"]
    residuals = _Residuals(objective, search["diff_step"], stall_iters, stall_rtol, exact=search["exact"])
    ends: list[tuple] = []  # (lowest MSE, where, its residual vector or None) of each finished local search
    arrivals = 0
    if stop_agree and stop_on_arrival:
        residuals.known, residuals.arrival_rtol = ends, float(agree_rtol)
    while True:  # until the objective raises BudgetExhausted, or enough local searches agree
        u0 = rng.random(d)
        if residuals.start(u0) is None:
            continue  # blew up at the start: draw another
        try:
            _local_search(residuals, u0, search)
        except _Arrived:
            arrivals += 1
        except _Stalled:
            pass
        # The fitted curve joins the end only where the problem has residuals: a loss alone says nothing about it.
        fit = residuals.search_best_r if agree_same_fit and residuals.has_residuals else None
        ends.append((residuals.search_best, residuals.search_best_u, fit))
        floor = 1e-12 * residuals.penalty.worst_finite
        residuals.arrival_floor = floor
        agreed = _agreed(ends, int(stop_agree), float(agree_rtol), floor)
        if agreed:
            arrived = f"; {arrivals} of them stopped on reaching an optimum an earlier one ended at" if arrivals else ""
            by_fit = _how_agreed(ends, float(agree_rtol), floor).count("fit")
            fit = f", {by_fit} of them by their fitted curve only" if by_fit else ""
            rule = _rule(agree_rtol, agree_same_fit and residuals.has_residuals)
            message = (
                f"stopped early: {agreed} of {len(ends)} independent local searches ended at the best "
                f"optimum{fit}, none better{arrived} (agreement: {rule})"
            )
            return {
                "message": message,
                "stop_reason": "restarts agree",
                "local_searches": len(ends),
                "arrivals": arrivals,
                "agreed_by_fit": by_fit,
                "agreement": rule,
            }
