"""What the data leave to the box: the profile likelihood of every searched parameter beside its marginal,
where the profile is flat (the data allow that stretch of the box, and the posterior's mass there follows
the box), and how the posterior moves when such a parameter's box is cut.

**Profile** (``profile``): on ``GRID`` values of each parameter evenly across its box (unit coordinates)
and ``QUANTILES`` of its posterior draws (where the marginal is drawn beside it), the others re-maximised by L-BFGS-B from the best posterior draw near that value (the gradient by central
differences, one batched call per gradient), at most ``ITERATIONS`` iterations a point. A maximisation is
a lower bound of the true profile; started from the posterior's best draws it is within a fraction of a
nat on the stretches the posterior covers.

**Undetermined** (``allowed``): the values where the profile is within ``ALLOW`` = χ²₁(0.95)/2 = 1.92 of
its maximum are what the data allow (the 95 % profile-likelihood region). A parameter whose allowed
stretch covers at least ``UNDETERMINED`` of its box is undetermined there: the likelihood is as high along
it, so how much posterior mass sits at each value is set by the volume the other parameters have there,
i.e. by the box, not by the data.

**Prior sensitivity** (``sensitivity``): the posterior under a box cut to a part of a parameter's range is
the posterior's draws inside that part, renormalised (a uniform prior truncated), so region masses and
means under the cut box are read from the same draws, exactly, with no new run. A box made wider cannot be
read this way; the cuts show which way and how far the answer moves with the box.
"""

from __future__ import annotations

import numpy as np

GRID = 10  # profile points per parameter evenly across its box
QUANTILES = (0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 0.98)  # and at these quantiles of its posterior draws
ITERATIONS = 25  # L-BFGS-B iterations per profile point
ALLOW = 1.92  # χ²₁(0.95)/2: the 95 % profile-likelihood region
UNDETERMINED = 0.5  # an allowed stretch of at least this share of the box: undetermined there
STEP = 1e-5  # central differences in unit coordinates
CUTS = ((1 / 3, 1.0), (0.0, 2 / 3))  # the boxes read for the prior sensitivity: a third cut off below, above


def cost(dim: int) -> int:
    """Evaluations ``profile`` spends at most on ``dim`` parameters (a budget to reserve for it)."""
    per_point = (ITERATIONS + 5) * (1 + 2 * max(dim - 1, 0)) + 2
    return dim * (GRID + len(QUANTILES)) * per_point


def grid(u: np.ndarray) -> np.ndarray:
    """The profile's values of one parameter (unit coordinates), sorted: ``GRID`` evenly across the box and
    the ``QUANTILES`` of its draws ``u``."""
    even = (np.arange(GRID) + 0.5) / GRID
    return np.unique(np.round(np.concatenate([even, np.quantile(u, QUANTILES)]), 6))


def profile(log_like, draws: np.ndarray, log_prob: np.ndarray) -> dict:
    """{"unit": (d lists of values), "log_like": (d lists)}: the profile log-likelihood of each parameter at
    its ``grid`` values.

    ``log_like(U) -> (m,)``: the batched log-likelihood of unit points (−inf or a very low value where the
    model blows up; it may raise ``StopIteration`` to stop, e.g. when a budget is spent: the points left
    read NaN). ``draws`` (m, d) and ``log_prob`` (m,): the posterior's draws, the starts."""
    draws, log_prob = np.asarray(draws, float), np.asarray(log_prob, float)
    d = draws.shape[1]
    units = [grid(draws[:, j]) for j in range(d)]
    out = [np.full(len(v), np.nan) for v in units]
    # "near" for the draws that count as the profile's value: a quarter of the posterior's sd, within half a
    # grid step (a draw further off in a parameter the data pin down says nothing of the value)
    width = np.minimum(0.5 / GRID, 0.25 * draws.std(axis=0))
    spent = False
    for j in range(d):
        previous = None  # the optimum at the grid's previous value: a second start, walking along the grid
        for g, value in enumerate(units[j]):
            if spent:
                break
            near = np.abs(draws[:, j] - value) <= 0.5 / GRID
            pool = np.flatnonzero(near) if near.any() else np.argsort(np.abs(draws[:, j] - value))[:20]
            starts = [draws[pool[np.argmax(log_prob[pool])]].copy()] + (
                [previous.copy()] if previous is not None else []
            )
            for start in starts:
                start[j] = value
            best = [-np.inf, starts[0]]
            try:
                first = np.asarray(log_like(np.array(starts)), float)
                _maximise(log_like, starts[int(np.argmax(first))], j, best)
            except StopIteration:  # the budget is spent: what was found stands, the rest is NaN
                spent = True
            previous = best[1]
            # a maximisation is a lower bound; so is the best draw close to the value (a failed
            # maximisation would otherwise show as a dip where the draws say the likelihood is as high)
            close = np.abs(draws[:, j] - value) <= width[j]
            found = max(best[0], float(np.max(log_prob[close])) if close.any() else -np.inf)
            out[j][g] = found if np.isfinite(found) else np.nan
    return {"unit": [v.tolist() for v in units], "log_like": [v.tolist() for v in out]}


def _maximise(log_like, start: np.ndarray, j: int, best: list) -> None:
    """Maximise the log-likelihood over every coordinate but ``j`` (held at ``start[j]``) from ``start``;
    the highest value met and its point go into ``best`` (kept when ``log_like`` stops the search)."""
    from scipy.optimize import minimize

    free = [i for i in range(len(start)) if i != j]
    if not free:
        best[0], best[1] = float(log_like(start[None, :])[0]), start
        return
    eye = STEP * np.eye(len(free))

    def fun(x):
        hi, lo = np.clip(x + eye, 0.0, 1.0), np.clip(x - eye, 0.0, 1.0)
        points = np.tile(start, (1 + 2 * len(free), 1))
        points[:, free] = np.vstack([x, hi, lo])
        ll = np.asarray(log_like(points), float)
        if not np.isfinite(ll[0]) or ll[0] < -1e200:
            return 1e300, np.zeros(len(free))
        if ll[0] > best[0]:
            best[0], best[1] = float(ll[0]), points[0].copy()
        grad = (ll[1 : 1 + len(free)] - ll[1 + len(free) :]) / np.diag(hi - lo)
        return -float(ll[0]), -np.where(np.isfinite(grad), grad, 0.0)

    minimize(
        fun, start[free], jac=True, method="L-BFGS-B", bounds=[(0.0, 1.0)] * len(free), options={"maxiter": ITERATIONS}
    )


def allowed(unit, values) -> tuple[float, float] | None:
    """(lowest, highest) unit value of a profile (``unit``, ``values``) within ``ALLOW`` of its maximum;
    None without values."""
    x, y = np.asarray(unit, float), np.asarray(values, float)
    ok = np.isfinite(y)
    if not ok.any():
        return None
    inside = ok & (y >= np.nanmax(y) - ALLOW)
    return float(x[inside].min()), float(x[inside].max())


def undetermined(unit, values) -> tuple[float, float] | None:
    """The allowed stretch (unit) when it spans at least ``UNDETERMINED`` of the box, else None."""
    span = allowed(unit, values)
    if span is None or span[1] - span[0] < UNDETERMINED:
        return None
    return span


def sensitivity(draws: np.ndarray, j: int, regions, physical: np.ndarray) -> list:
    """The posterior under each box of ``CUTS`` for parameter ``j`` (unit coordinates), read from the draws:
    one dict per cut with ``box`` (unit), ``kept`` (the share of the posterior's mass inside it),
    ``regions`` (each region's mass, renormalised) and ``shift`` ((parameter index, mean shift in posterior
    sd) of the parameter other than j that moves most). ``draws`` (m, d) unit, ``physical`` (m, d) their
    physical values, ``regions``: ``posterior_verdict.Region`` list over the same m draws."""
    draws, physical = np.asarray(draws, float), np.asarray(physical, float)
    sd = physical.std(axis=0)
    mean = physical.mean(axis=0)
    out = []
    for lo, hi in CUTS:
        inside = (draws[:, j] >= lo) & (draws[:, j] <= hi)
        kept = float(inside.mean())
        entry = {"box": (lo, hi), "kept": kept, "regions": [], "shift": None}
        if inside.sum() >= 10:
            entry["regions"] = [float(r.members[inside].mean()) for r in regions]
            moved = np.where(sd > 0, (physical[inside].mean(axis=0) - mean) / np.where(sd > 0, sd, 1.0), 0.0)
            moved[j] = 0.0
            k = int(np.argmax(np.abs(moved)))
            entry["shift"] = (k, float(moved[k]))
        out.append(entry)
    return out
