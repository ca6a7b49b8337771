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
ended at the best optimum found (``agreed_searches``: MSE within ``agree_rtol``, and every parameter within 2 %
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
(``Objective.exploration``: Spencer's model at tolerance 1e-4, not 1e-5, and 10 steps per sample interval, on
every k-th sample of a record of ≥ 1,000 samples per cycle) the searches run there (stall window 3, xtol at
least ``EXPLORE_XTOL``); their best end, and up to ``POLISH_ENDS`` − 1 other optima they ended at within
``POLISH_RTOL`` × ``agree_rtol`` of its MSE, are then polished on the problem itself (window 2, a tenth of
``stall_rtol``; the best of all is the reported fit), all on the one budget, of which ``POLISH_SHARE`` (≥
``POLISH_MIN``) is kept for the polish; ``extras["exploration"]`` gives the split.
``fused`` (true; only with ``stop_agree`` and exact Jacobians): every point trf asks for is simulated
with its sensitivities (``Objective.residual_jacobian``, charged what a Jacobian is charged, e.g. 2
evaluations for Spencer's model) and its Jacobian kept: trf asks for the Jacobian at each point it
accepts, right after the residual there, which then costs nothing more. Without it an accepted point
is simulated twice, once plain and once with sensitivities; with it a rejected point costs a
simulation with sensitivities (~1.5 plain ones) instead of one plain. On the MR-damper generator's
tests about two trial points in three are accepted: seven tests at two seeds took 22 % less CPU time
(9.86 → 7.65 s) and 10–21 % fewer evaluations, the same NRMSE on every fit. Studies (no ``stop_agree``)
keep the plain residual and the separate Jacobian.

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

from bwbench.engine.options import Bool, Choice, Float, Int
from bwbench.engine.registry import register
from bwbench.errors import BudgetExhausted
from bwbench.optimizers.lsq.agreement import agreed_searches, agreement_rule, how_agreed, same_optimum
from bwbench.optimizers.lsq.residuals import Arrived, Residuals, Stalled
from bwbench.threads import blas_limits

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
    "fused": Bool(True),
}


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
    fused=True,
):
    from scipy.optimize import least_squares  # here: scipy.optimize is slow to import

    search = dict(
        least_squares=least_squares,
        diff_step=diff_step,
        xtol=float(xtol),
        ftol=float(ftol),
        x_scale=1.0 if x_scale == "unit" else x_scale,
        max_nfev=None if max_nfev_per_start is None else int(max_nfev_per_start),
        stall=(stall_iters, stall_rtol),
        exact=jacobian == "auto",
        fused=bool(fused and stop_agree),
    )
    cheaper = (
        objective.exploration(max(POLISH_MIN, int(POLISH_SHARE * objective.budget))) if stop_agree and explore else None
    )
    # One BLAS thread: trf takes an SVD of the (L + d) × d Jacobian every iteration, small enough that
    # BLAS's threads cost more than they save (many times more on a busy machine); and the run then
    # does not depend on the machine's thread count.
    with blas_limits(1, user_api="blas"):
        if cheaper is None:
            return _restarts(objective, rng, search, stop_agree, agree_rtol, stop_on_arrival, agree_same_fit)
        # The exploring searches' ends need only be within the agreement's tolerances (the best one is
        # polished): a shorter stall window. On the MR-damper generator's tests 3 instead of 5 took
        # 10–25 % fewer evaluations, the same optimum and NRMSE on every test.
        stall, xtol = search["stall"], search["xtol"]
        search["stall"] = (min(int(stall[0]), EXPLORE_STALL_ITERS), stall[1])
        search["xtol"] = max(xtol, EXPLORE_XTOL)
        ends: list[tuple] = []  # the exploring searches' ends, for the polish
        try:
            extras = _restarts(cheaper, rng, search, stop_agree, agree_rtol, stop_on_arrival, agree_same_fit, ends)
        except BudgetExhausted:
            extras = {"message": "budget exhausted", "stop_reason": "budget exhausted"}
        finally:
            objective.charge(cheaper)
            search["stall"], search["xtol"] = stall, xtol
        return _polish(objective, cheaper, rng, search, extras, _distinct_ends(ends, agree_rtol) or [cheaper.best_u])


# Evaluations kept back from the exploring searches for the polish of their best ends (``_polish``): it took
# 7–30 on the MR-damper generator's tests (a few trf iterations from an end within ~1 % of the optimum's MSE).
POLISH_SHARE, POLISH_MIN, POLISH_STALL_ITERS, EXPLORE_STALL_ITERS = 0.05, 40, 2, 3
# The exploring searches' xtol (scipy's test on the step, relative to x), at least: a search on a plateau
# far from the optimum ended by trf shrinking its trust region after rejected steps until the step was 1e-8
# of x, each rejection a simulation (a fifth of a fit's CPU on some seeds). At 1e-4, five MR-damper tests
# × three seeds: 4.4 % fewer evaluations, the same optimum and MSE to the last digit printed (1e-3: 7 %
# fewer, one fit 0.02 % worse after the polish). The polish keeps the fit's own xtol.
EXPLORE_XTOL = 1e-4
# At most this many distinct exploring ends are polished: the cheaper simulation may rank two optima whose
# MSE is within ``POLISH_RTOL`` × the agreement's tolerance of each other the other way round.
POLISH_ENDS, POLISH_RTOL = 3, 2.0


def _distinct_ends(ends: list[tuple], agree_rtol: float) -> list:
    """Where to polish from: the best end's u, then those of ends that are other optima (neither the same
    place nor the same fitted curve as one already taken, ``same_optimum``) with MSE within ``POLISH_RTOL``
    × ``agree_rtol`` of the best's, best first, at most ``POLISH_ENDS``."""
    finite = sorted((e for e in ends if np.isfinite(e[0]) and e[1] is not None), key=lambda e: e[0])
    taken: list[tuple] = []
    for end in finite:
        if len(taken) == POLISH_ENDS or end[0] > finite[0][0] * (1.0 + POLISH_RTOL * agree_rtol):
            break
        if not any(same_optimum(end, other, np.inf) for other in taken):
            taken.append(end)
    return [end[1] for end in taken]


def _polish(objective, cheaper, rng, search, extras, starts) -> dict:
    """One local search on the problem itself from each of ``starts`` (the distinct best ends the exploring
    searches found on ``cheaper``, the problem's cheaper simulation; the best of all is the result), then, if
    they did not agree, more searches there until the budget is spent (a budget is spent whole unless
    searches agree); the extras, with how it went."""
    before = objective.nfev
    # Each starts where a search ended, within ~1 % of the optimum's MSE: stalled after two iterations
    # (not five) of less than a tenth of ``stall_rtol`` in all.
    stall = min(int(search["stall"][0]), POLISH_STALL_ITERS)
    residuals = Residuals(
        objective, search["diff_step"], stall, 0.1 * search["stall"][1], exact=search["exact"], fused=search["fused"]
    )
    polished = 0
    how = "their best end polished" if len(starts) == 1 else f"their {len(starts)} best distinct ends polished"
    for u0 in starts:
        if u0 is None or residuals.start(u0) is None:  # nothing finite there, or not on the finer simulation
            continue
        polished += 1
        try:
            _local_search(residuals, u0, search)
        except Stalled:
            pass
        except BudgetExhausted:
            how += " until the budget ran out"
            break
    if not polished:
        return _restarts(objective, rng, search, 0, 0.0, False, False)
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
    """One trf search from u0 (already ``start``ed); ``Stalled`` (and ``Arrived``) propagate."""
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


def _restarts(objective, rng, search, stop_agree, agree_rtol, stop_on_arrival, agree_same_fit, ends=None) -> dict:
    """Local searches from uniform random starts until the objective raises ``BudgetExhausted`` or
    ``stop_agree`` of them agree (the module docstring); the run's extras when they agree. ``ends``: a list
    to keep the searches' ends in (MSE, u, residual vector or None), for the caller."""
    d = objective.dim
    stall_iters, stall_rtol = search["stall"]
    residuals = Residuals(
        objective, search["diff_step"], stall_iters, stall_rtol, exact=search["exact"], fused=search["fused"]
    )
    ends = [] if ends is None else ends  # (lowest MSE, where, its residual vector or None) of each finished search
    arrivals = 0
    if stop_agree and stop_on_arrival:
        residuals.known, residuals.arrival_rtol = ends, float(agree_rtol)
    while True:  # until the objective raises BudgetExhausted, or enough local searches agree
        u0 = rng.random(d)
        if residuals.start(u0) is None:
            continue  # blew up at the start: draw another
        try:
            _local_search(residuals, u0, search)
        except Arrived:
            arrivals += 1
        except Stalled:
            pass
        # The fitted curve joins the end only where the problem has residuals: a loss alone says nothing about it.
        fit = residuals.search_best_r if agree_same_fit and residuals.has_residuals else None
        ends.append((residuals.search_best, residuals.search_best_u, fit))
        floor = 1e-12 * residuals.penalty.worst_finite
        residuals.arrival_floor = floor
        agreed = agreed_searches(ends, int(stop_agree), float(agree_rtol), floor)
        if agreed:
            arrived = f"; {arrivals} of them stopped on reaching an optimum an earlier one ended at" if arrivals else ""
            by_fit = how_agreed(ends, float(agree_rtol), floor).count("fit")
            fit = f", {by_fit} of them by their fitted curve only" if by_fit else ""
            rule = agreement_rule(agree_rtol, agree_same_fit and residuals.has_residuals)
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
