"""Where an ensemble sampler starts: several local optima from dispersed starts, and a spread around
each from the local curvature (the Laplace approximation).

Walkers scattered uniformly over a 7- or 14-dimensional box stay in its poor regions for a very long
time, and walkers packed in a tiny ball around one optimum take as long to spread out and cannot
show a second mode. So the start spends a share of the budget on independent local searches
(``lsq-trf``: Gauss-Newton from uniform random points, the best backend of the ranking on the
switched model), keeps the optima whose log-posterior is within ``MODE_LOG_PROB`` of the best (a
mode lower by more holds a fraction below e^−10 of the mass of the best when the widths are alike:
negligible), and picks from them, greedily, the ones farthest apart, one per ensemble. Each
ensemble's walkers are drawn from N(u*, (2·)²Σ) around its optimum u*, Σ = s²·(JᵀJ)⁺ from the
Jacobian J of the residual there (s² = RSS/(L − d)), overdispersed twice, as Gelman & Rubin ask of
the starts of chains whose agreement is to be tested; directions the data do not determine get at
most ``MAX_SD`` (unit coordinates). Every evaluation counts against the objective's budget.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.errors import BudgetExhausted
from bwbench.optimizers.sampling.budget_share import Share

MODE_LOG_PROB = 10.0  # optima this far below the best log-posterior are negligible modes
MAX_SD = 0.25  # largest start standard deviation along any direction (unit coordinates)
OVERDISPERSION = 2.0  # start spread / Laplace standard deviation
STEP = 1e-5  # finite-difference step of the Jacobian (unit coordinates)


def local_optima(objective, rng, budget: int, searches: int) -> list[tuple[np.ndarray, float]]:
    """(u, MSE) of the best point of each of ``searches`` independent ``lsq-trf`` searches, each on an
    equal share of ``budget`` (a search restarts from a new random point when it converges early)."""
    from bwbench.optimizers.lsq_trf import minimize as lsq_trf

    per = budget // max(searches, 1)
    out: list[tuple[np.ndarray, float]] = []
    for _ in range(searches):
        if per < objective.dim + 2 or objective.remaining < objective.dim + 2:
            break
        share = Share(objective, per)
        try:
            lsq_trf(share, rng=rng)
        except BudgetExhausted:
            pass
        if share.best_u is not None and np.isfinite(share.best_mse):
            out.append((share.best_u, share.best_mse))
    return out


def choose(points: np.ndarray, log_prob: np.ndarray, count: int) -> tuple[list[int], int]:
    """Indices of ``count`` starts among ``points`` (n, d): the best, then greedily the point farthest
    from those chosen, among the points within ``MODE_LOG_PROB`` of the best (repeated round-robin
    when there are fewer); and how many points were left out as negligible modes."""
    log_prob = np.asarray(log_prob, dtype=float)
    good = np.flatnonzero(np.isfinite(log_prob) & (log_prob >= np.nanmax(log_prob) - MODE_LOG_PROB))
    chosen = [int(good[np.argmax(log_prob[good])])]
    while len(chosen) < min(count, len(good)):
        distance = np.min(np.linalg.norm(points[good][:, None, :] - points[chosen][None, :, :], axis=2), axis=1)
        chosen.append(int(good[np.argmax(distance)]))
    return [chosen[k % len(chosen)] for k in range(count)], int(np.isfinite(log_prob).sum() - len(good))


def laplace_covariance(objective, u: np.ndarray, fallback: float = 0.05) -> np.ndarray:
    """Σ = s²·(JᵀJ)⁺ in unit coordinates at ``u`` from a forward-difference Jacobian of the residual
    (d + 1 evaluations), every standard deviation capped at ``MAX_SD``; ``fallback``²·I for a problem
    without residuals or where the residual is not finite."""
    d = objective.dim
    if not callable(getattr(objective.problem, "residual_batch", None)):
        return fallback**2 * np.eye(d)
    h = np.where(u + STEP <= 1.0, STEP, -STEP)
    R = objective.residuals(np.vstack([u, u + np.diag(h)]))
    if not np.all(np.isfinite(R)):
        return fallback**2 * np.eye(d)
    r0 = R[0]
    J = (R[1:] - r0).T / h
    s2 = float(r0 @ r0) / max(len(r0) - d, 1)
    values, vectors = np.linalg.eigh(J.T @ J)
    with np.errstate(divide="ignore"):
        variances = np.where(values > 0, s2 / np.maximum(values, 1e-300), np.inf)
    variances = np.minimum(variances, MAX_SD**2)
    return (vectors * variances) @ vectors.T


def draw_walkers(rng, centre: np.ndarray, covariance: np.ndarray, n: int, tries: int = 100) -> np.ndarray:
    """``n`` points of N(centre, OVERDISPERSION²·covariance) inside the unit box (points outside are
    drawn again; after ``tries`` rounds the rest are clipped just inside)."""
    d = len(centre)
    root = np.linalg.cholesky(OVERDISPERSION**2 * covariance + 1e-18 * np.eye(d))
    out = np.empty((n, d))
    todo = np.arange(n)
    for _ in range(tries):
        out[todo] = centre + rng.standard_normal((len(todo), d)) @ root.T
        todo = todo[np.any((out[todo] <= 0.0) | (out[todo] >= 1.0), axis=1)]
        if not len(todo):
            break
    return np.clip(out, 1e-9, 1.0 - 1e-9)


@dataclass
class Plan:
    """Where each of K ensembles starts: ``walkers`` (K arrays (W, d), unit coordinates) and their
    ``log_prob`` (K arrays (W,)); ``fixed`` {coordinate index: unit value} held fixed by a reduced
    model; ``notes``: what was done, one sentence each."""

    walkers: list
    log_prob: list
    fixed: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)


def plan(
    objective, rng, log_prob, ensembles: int, walkers: int, fraction: float, searches_per_ensemble: int = 2
) -> Plan:
    """The starts of the module docstring on ``fraction`` of the remaining budget (local searches) plus
    a few evaluations per ensemble (curvature, the walkers' own log-probabilities); ``log_prob`` maps
    unit points (m, d) to log-posteriors, counted by the objective. A budget too small for one local
    search falls back to walkers uniform in the box."""
    from bwbench.optimizers.sampling import reduce as mcmc_reduce

    d = objective.dim
    share = int(fraction * objective.remaining)
    optima = local_optima(objective, rng, share, searches_per_ensemble * ensembles)
    if not optima or objective.remaining < ensembles * (walkers + d + 1) + 2 * len(optima):
        return Plan(
            [rng.random((walkers, d)) for _ in range(ensembles)],
            [None] * ensembles,
            notes=["start: walkers uniform in the box (the budget is too small for local searches)"],
        )
    points = np.array([u for u, _ in optima])
    lp = log_prob(points)
    reduction = mcmc_reduce.reduce(objective, points, lp, log_prob, share // 2)
    notes = list(reduction.notes)
    if reduction.better is not None:  # a full-model optimum found from the reduced one: a start too
        points, lp = np.vstack([reduction.better[0], points]), np.concatenate([[reduction.better[1]], lp])
    if reduction.fixed:  # the full model's optima moved into the reduced one, and the reduced model's own
        points = points.copy()
        for j, value in reduction.fixed.items():
            points[:, j] = value
        assert reduction.points is not None and reduction.log_prob is not None  # set with ``fixed``
        points = np.vstack([reduction.points, points])
        lp = np.concatenate([reduction.log_prob, log_prob(points[len(reduction.points) :])])
    picks, negligible = choose(points, lp, ensembles)
    distinct = len(set(picks))
    notes.insert(
        0,
        f"start: {len(optima)} local searches (lsq-trf) on {fraction:.0%} of the budget; "
        f"{distinct} distinct optim{'um' if distinct == 1 else 'a'} within Δlog p = {MODE_LOG_PROB:g} of the "
        f"best seed the {ensembles} ensemble(s)"
        + (f"; {negligible} optima lower by more left out (negligible modes)" if negligible else ""),
    )
    fixed_index = np.array(sorted(reduction.fixed), dtype=int)
    free = np.setdiff1d(np.arange(d), fixed_index)
    starts, start_lp = [], []
    for i in picks:
        centre = points[i]
        covariance = laplace_covariance(objective, centre)
        reduced = covariance[np.ix_(free, free)]
        U = np.repeat(centre[None, :], walkers, axis=0)
        U[:, free] = draw_walkers(rng, centre[free], reduced, walkers)
        values = log_prob(U)
        for spread in (1.0, 0.1, 1e-3):  # blew up (or past the budget): drawn again, closer each time
            bad = ~np.isfinite(values)
            if not bad.any():
                break
            U[np.ix_(bad, free)] = draw_walkers(
                rng, centre[free], spread**2 * reduced + 1e-12 * np.eye(len(free)), int(bad.sum())
            )
            values[bad] = log_prob(U[bad])
        starts.append(U)
        start_lp.append(values)
    return Plan(starts, start_lp, {int(j): float(v) for j, v in reduction.fixed.items()}, notes)
