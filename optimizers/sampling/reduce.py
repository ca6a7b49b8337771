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
linear one, and the chain samples the reduced model with the shape held. A second test then holds
x_y at the top of its box as well (``Model.yield_parameters``; the branch never yields within the
stroke) when that too is within ``YIELD_LIKELIHOOD_RATIO`` (three parameters): beyond the stroke x_y
only trades with the scale of the state handed to the other branch (x_y₊·ρ in the shared state), a
ridge to the cap along which a chain mixes for ever (R̂ 1.07 at 250,000 evaluations on pom-mt24u01
0.05 MPa with x_y₊ sampled, 1.007 with it held). What then trades with the held parameters is the
reduced model's gauge (``Model.reduced_gauge``), which the report does not compare with a truth. The
sampler's message, and so the report, says which branch was reduced and why, or why not.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.errors import BudgetExhausted

LIKELIHOOD_RATIO = 5.99 / 2  # χ²₂(0.95)/2: two shape parameters dropped
YIELD_LIKELIHOOD_RATIO = 7.81 / 2  # χ²₃(0.95)/2: the yield displacement held at the cap as well
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
    better: tuple | None = None  # (u, log_prob) of a full-model optimum better than every start's


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
    limits = {
        b: limit for b, limit in model.linear_limits(problem.state).items() if limit and all(n in names for n in limit)
    }
    if not limits:
        return Reduction()
    best = float(np.max(log_prob))
    order = np.argsort(-log_prob)[:SEARCHES]
    out = Reduction()
    per = budget // max(len(limits) * len(order), 1)
    yields = model.yield_parameters(problem.state)
    for branch, limit in limits.items():
        fixed = {**out.fixed, **_unit_values(problem, limit, points[order[0]])}
        found, lp = _held(objective, points[order], fixed, per, log_prob_fn)
        if found is None:
            continue
        if np.max(lp) > best:  # the reduced model beat the full one's searches: the full model's own
            # optimum is near (it nests the reduced one), and the test needs it
            full, lp_full = _held(objective, found[np.argsort(-lp)[:1]], {}, per, log_prob_fn)
            best = max(best, float(np.max(lp)), -np.inf if full is None else float(np.max(lp_full)))
            if full is not None:
                out.better = (full[int(np.argmax(lp_full))], float(np.max(lp_full)))
        gap = best - float(np.max(lp))
        labels = ", ".join(f"{_label(problem, n)} = {v:g}" for n, v in limit.items())
        if not gap <= LIKELIHOOD_RATIO:
            out.notes.append(
                f"branch {branch}: with {labels} (linear until it yields) the best fit is Δlog p = "
                f"{gap:.1f} below the full model's (> {LIKELIHOOD_RATIO:.2f}, the likelihood-ratio test "
                "of its two shape parameters at 95 %): the data tell its shape; sampled in full"
            )
            continue
        out.fixed, out.points, out.log_prob = fixed, found, lp
        note = (
            f"branch {branch}: with {labels} (linear until it yields) the best fit is Δlog p = {gap:.2f} from the "
            f"full model's (≤ {LIKELIHOOD_RATIO:.2f}, the likelihood-ratio test of its two shape parameters at "
            "95 %): the data cannot tell its shape from a linear branch's, so the chain holds these"
        )
        # A linear branch that never yields within the stroke: where it would yield, beyond, only trades
        # with the scale of the state it hands to the other branch (x_y₊·ρ in the shared state): a ridge
        # to the box's cap that a chain crosses for ever. Held at the cap when the data cannot tell.
        name = yields.get(branch)
        if name in names:
            j = names.index(name)
            capped, lp_capped = _held(objective, found, {**fixed, j: 1.0}, per, log_prob_fn)
            gap_capped = np.inf if capped is None else best - float(np.max(lp_capped))
            top = float(problem.from_unit(np.ones((1, len(names))))[0][j])
            if gap_capped <= YIELD_LIKELIHOOD_RATIO:
                out.fixed, out.points, out.log_prob = {**fixed, j: 1.0}, capped, lp_capped
                note += (
                    f"; and with {_label(problem, name)} at the top of its box ({top:.4g}, never yielding within "
                    f"the stroke) Δlog p = {gap_capped:.2f} (≤ {YIELD_LIKELIHOOD_RATIO:.2f}, three parameters): "
                    "held there too"
                )
            else:
                note += (
                    f"; {_label(problem, name)} at the top of its box is Δlog p = {gap_capped:.1f} below "
                    f"(> {YIELD_LIKELIHOOD_RATIO:.2f}): the branch yields within the stroke, "
                    f"{_label(problem, name)} sampled"
                )
        out.notes.append(note + "; the other parameters sampled")
    return out


def _held(objective, starts: np.ndarray, fixed: dict, budget: int, log_prob_fn):
    """The optima (unit coordinates) re-optimised from ``starts`` with the coordinates ``fixed`` held,
    each on ``budget`` evaluations, and their log-posteriors; (None, None) when none was finite."""
    starts = np.array(starts, dtype=float)
    for j, value in fixed.items():
        starts[:, j] = value
    found = [_reoptimise(objective, u, fixed, budget) for u in starts]
    kept = np.array([u for u in found if u is not None])
    if not len(kept):
        return None, None
    return kept, log_prob_fn(kept)


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

    from bwbench.optimizers.sampling.budget_share import Share

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
        least_squares(
            residual,
            np.clip(u0[free], 0.0, 1.0),
            bounds=(0.0, 1.0),
            method="trf",
            diff_step=1e-5,
            xtol=1e-8,
            ftol=1e-8,
            max_nfev=max(budget // (len(free) + 1), 1),
        )
    except BudgetExhausted:
        pass
    return share.best_u


def _label(problem, name: str) -> str:
    for p in problem.parameter_list:
        if p.name == name:
            return p.label or p.name
    return name
