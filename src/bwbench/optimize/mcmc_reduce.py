"""A branch whose shape the data cannot tell from a linear one is sampled as linear (a reduced model).

The switched model's branch b has three hysteretic parameters, x_y (where it yields), n (how sharply)
and η (how it unloads). When the branch does not yield within the stroke, or carries almost no
hysteretic force of its own (h_b ≈ 0: in the shared state it then only carries w over to the other
branch), the data see one combination of them at most, and a chain that samples all three wanders
along the other two for ever. Before sampling, for each branch with a linear limit
(``Model.linear_limits``: for the switched model η = 0 and n at the top of its box, linear until it
yields): the best optima of the start are moved into that limit and re-optimised with the branch's
shape held (scipy ``least_squares``, every evaluation counted); if the best of them is within
``LIKELIHOOD_RATIO`` of the best optimum in log-posterior — the likelihood-ratio test of dropping the
two shape parameters at 95 % (χ²₂ = 5.99, halved) — the data cannot tell the branch's shape from the
linear one, and the chain samples the reduced model: shape held, x_y still sampled. The sampler's
message, and so the report, says which branch was reduced and why, or why not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.errors import BudgetExhausted

LIKELIHOOD_RATIO = 5.99 / 2  # χ²₂(0.95)/2: two shape parameters dropped
SEARCHES = 3  # local re-optimisations per branch, from the best optima


@dataclass
class Reduction:
    """``fixed``: {coordinate index: unit value}; ``points``/``log_prob``: the reduced model's optima
    (unit coordinates, fixed coordinates filled in) and log-posteriors; ``notes``: one sentence per
    branch tested."""

    fixed: dict = field(default_factory=dict)
    points: np.ndarray | None = None
    log_prob: np.ndarray | None = None
    notes: list = field(default_factory=list)


def reduce(objective, points: np.ndarray, log_prob: np.ndarray, log_prob_fn, budget: int) -> Reduction:
    """The test of the module docstring for the optima ``points`` (unit coordinates, (n, d)) of the full
    model and their ``log_prob``; ``log_prob_fn`` maps unit points to log-posteriors (counted);
    ``budget``: evaluations for the re-optimisations. No reduction for a problem or model without
    linear limits, or a direct formulation."""
    problem = objective.problem
    model = getattr(problem, "model", None)
    if getattr(problem, "formulation", "") != "identifiable" or model is None or not len(points):
        return Reduction()
    names = list(problem.param_names)
    limits = {b: limit for b, limit in model.linear_limits(problem.state).items()
              if limit and all(n in names for n in limit)}
    if not limits:
        return Reduction()
    best = float(np.max(log_prob))
    order = np.argsort(-log_prob)[:SEARCHES]
    out = Reduction()
    per = budget // max(len(limits) * len(order), 1)
    for branch, limit in limits.items():
        fixed = {**out.fixed, **_unit_values(problem, limit, points[order[0]])}
        starts = points[order].copy()
        for j, value in fixed.items():
            starts[:, j] = value
        found = [_reoptimise(objective, u, fixed, per) for u in starts]
        found = np.array([u for u in found if u is not None])
        if not len(found):
            continue
        lp = log_prob_fn(found)
        gap = best - float(np.max(lp))
        labels = ", ".join(f"{_label(problem, n)} = {v:g}" for n, v in limit.items())
        if not gap <= LIKELIHOOD_RATIO:
            out.notes.append(f"branch {branch}: with {labels} (linear until it yields) the best fit is Δlog p = "
                             f"{gap:.1f} below the full model's (> {LIKELIHOOD_RATIO:.2f}, the likelihood-ratio test "
                             "of its two shape parameters at 95 %): the data tell its shape; sampled in full")
            continue
        out.fixed, out.points, out.log_prob = fixed, found, lp
        out.notes.append(f"branch {branch}: with {labels} (linear until it yields) the best fit is Δlog p = "
                         f"{gap:.2f} from the full model's (≤ {LIKELIHOOD_RATIO:.2f}, the likelihood-ratio test of its "
                         "two shape parameters at 95 %): the data cannot tell its shape from a linear branch's, so "
                         "the chain samples the reduced model with these held (the other parameters sampled)")
    return out


def _unit_values(problem, limit: dict, u: np.ndarray) -> dict:
    """{coordinate index: unit value} of the physical values ``limit`` (by name)."""
    names = list(problem.param_names)
    P = problem.from_unit(u[None, :])[0]
    for name, value in limit.items():
        P[names.index(name)] = value
    unit = problem.to_unit(P)
    return {names.index(n): float(np.clip(unit[names.index(n)], 0.0, 1.0)) for n in limit}


def _reoptimise(objective, u0: np.ndarray, fixed: dict, budget: int) -> np.ndarray | None:
    """Least squares on the coordinates not in ``fixed`` from ``u0`` on at most ``budget`` evaluations
    (counted); the best point met (full unit vector), or None when none was finite."""
    from scipy.optimize import least_squares

    from bwbench.optimize.mcmc_start import Share

    d = objective.dim
    free = np.array([j for j in range(d) if j not in fixed], dtype=int)
    share = Share(objective, budget)
    if not callable(getattr(objective.problem, "residual_batch", None)) or share.remaining < len(free) + 2:
        return None

    def embed(v):
        u = np.array(u0, dtype=float)
        u[free] = v
        return u

    def residual(v):
        r = share.residuals(embed(v)[None, :])[0]
        return np.where(np.isfinite(r), r, 1e10)  # a blow-up: a huge cost, never NaN in scipy

    try:
        least_squares(residual, np.clip(u0[free], 0.0, 1.0), bounds=(0.0, 1.0), method="trf", diff_step=1e-5,
                      xtol=1e-8, ftol=1e-8, max_nfev=max(budget // (len(free) + 1), 1))
    except BudgetExhausted:
        pass
    return share.best_u


def _label(problem, name: str) -> str:
    for p in problem.parameter_list:
        if p.name == name:
            return p.label or p.name
    return name
