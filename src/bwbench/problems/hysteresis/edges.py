"""A searched parameter that ends on an edge of its box, classified by what the edge means.

- **model limit**: the edge is one of the model's own limits (``Model.parameter_limits``: the switched
  model's η = 1, Spencer's κ₀ floor, a degradation rate of 0): said as such, never "widen"; a
  ``--bounds`` that widens the box past it is refused (``refuse_past_limits``).
- **undetermined** (a flat direction): with the box widened one step beyond the edge (``step``: a
  decade on a log scale, one box width on a linear one), a short local least-squares search from the
  fit (every coordinate free, the linear coefficients re-solved: ``_best_beyond``) lowers the loss,
  against the same search in the box as it is, by less than the loss's own noise — the spread of an MSE over the record's samples, MSE·√(2/L_eff),
  L_eff the samples over the residual's correlation length (``loss_noise``). The data do not determine the parameter beyond its edge; widening would move
  it far for nothing (η at −50 on a white-noise MR record: −379 for 0.3 % of loss).
- **box too small**: the loss keeps falling beyond the edge by more than its noise: ``fit`` widens
  the box there by itself (``widen``), up to ``MAX_WIDENINGS`` steps and never past a model limit, runs
  the search again on what is left of the budget, and says so.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

PROBE_ITERATIONS = 20  # local least-squares steps of the probe beyond an edge
DECADES = 1.0  # a widening step on a log scale
MAX_WIDENINGS = 2
MODEL_LIMIT, UNDETERMINED, TOO_SMALL = "model limit", "undetermined", "box too small"


@dataclass(frozen=True)
class Edge:
    """``name`` on its ``side`` edge; ``kind`` one of the three of the module docstring; ``text`` a
    sentence; ``loss_change``: the relative fall of the MSE one step beyond (NaN for a model limit);
    ``noise``: the MSE's own relative spread."""

    name: str
    side: str
    kind: str
    text: str
    loss_change: float = float("nan")
    noise: float = float("nan")

    def to_json(self) -> dict:
        out: dict = {"side": self.side, "kind": self.kind, "meaning": self.text}
        if np.isfinite(self.loss_change):
            out.update(loss_change_beyond=self.loss_change, loss_noise=self.noise)
        return out


def step(problem, i: int, side: str) -> float:
    """The value one widening step beyond parameter ``i``'s ``side`` edge."""
    lo, hi = float(problem.lower[i]), float(problem.upper[i])
    if problem.log_scaled[i]:
        return hi * 10**DECADES if side == "upper" else lo / 10**DECADES
    return hi + (hi - lo) if side == "upper" else lo - (hi - lo)


def loss_noise(residual) -> float:
    """The relative spread of an MSE over ``residual``'s samples: √(2/L_eff), L_eff = L·(1 − ρ)/(1 + ρ)
    with ρ the lag-one autocorrelation (model error is correlated: fewer independent samples)."""
    r = np.asarray(residual, dtype=float)
    r = r[np.isfinite(r)]
    if r.size < 3:
        return np.inf
    c = r - r.mean()
    rho = float(np.dot(c[1:], c[:-1]) / np.dot(c, c)) if np.dot(c, c) > 0 else 0.0
    rho = min(max(rho, 0.0), 0.999)
    return float(np.sqrt(2.0 / (r.size * (1 - rho) / (1 + rho))))


def classify(problem, params, at_bound: dict) -> list[Edge]:
    """An ``Edge`` for each of ``at_bound`` ({name: side}) at ``params`` (problem coordinates)."""
    if not at_bound:
        return []
    params = np.asarray(params, dtype=float)
    limits = problem.model.parameter_limits(problem.state) if hasattr(problem, "model") else {}
    names = list(problem.param_names)
    start = float(problem.loss_batch(params[None, :])[0])
    noise = loss_noise(problem.residual_batch(params[None, :])[0]) if np.isfinite(start) else np.inf
    base = min(_best_beyond(problem, params, 0, "lower", float(problem.lower[0])), start)  # the box as it is
    out = []
    for name, side in at_bound.items():
        why = limits.get(name, {}).get(side)
        if why:
            out.append(Edge(name, side, MODEL_LIMIT, f"{name} on its {side} edge, the model's limit: {why}"))
            continue
        i = names.index(name)
        far = step(problem, i, side)
        best = _best_beyond(problem, params, i, side, far)
        change = (base - best) / base if base > 0 and np.isfinite(best) else 0.0
        where = f"a box widened to {far:.4g}" + (" (a decade beyond)" if problem.log_scaled[i] else "")
        if change <= noise:
            out.append(
                Edge(
                    name,
                    side,
                    UNDETERMINED,
                    f"{name} on its {side} edge is undetermined: a fit in {where} lowers the loss by "
                    f"{max(change, 0.0):.2%}, less than the loss's own noise ({noise:.2%}): the data do not pin "
                    "it beyond the edge (a flat direction; widening the box would move it far for nothing)",
                    change,
                    noise,
                )
            )
        else:
            out.append(
                Edge(
                    name,
                    side,
                    TOO_SMALL,
                    f"{name} on its {side} edge: a fit in {where} lowers the loss by {change:.2%}, more than its noise "
                    f"({noise:.2%}): the box is too small there",
                    change,
                    noise,
                )
            )
    return out


def _best_beyond(problem, params, i: int, side: str, far: float) -> float:
    """The lowest MSE (N²) of a short local least-squares search from ``params`` in the box widened on
    parameter ``i``'s ``side`` to ``far`` (every coordinate free: a parameter on an edge trades with
    others), log-scaled coordinates searched in log10; exact Jacobians where the problem has them."""
    from scipy.optimize import least_squares

    lower, upper = np.array(problem.lower, dtype=float), np.array(problem.upper, dtype=float)
    if side == "upper":
        upper[i] = far
    else:
        lower[i] = far
    log = np.asarray(problem.log_scaled, dtype=bool)

    def physical(q):
        return np.where(log, 10.0 ** np.where(log, q, 0.0), q)

    def coords(P):
        return np.where(log, np.log10(np.where(log, P, 1.0)), P)

    def residual(q):
        r = problem.residual_batch(physical(q)[None, :])[0]
        return np.where(np.isfinite(r), r, 1e150)

    def jacobian(q):
        found = problem.residual_jacobian(physical(q)) if hasattr(problem, "residual_jacobian") else None
        if found is None or found[1] is None:
            return _differences(residual, q)
        return found[1] * np.where(log, physical(q) * np.log(10.0), 1.0)

    lo, hi = coords(lower), coords(upper)
    start = np.clip(coords(np.asarray(params, dtype=float)), lo, hi)
    try:
        fit = least_squares(residual, start, jac=jacobian, bounds=(lo, hi), max_nfev=PROBE_ITERATIONS, x_scale="jac")
    except (ValueError, FloatingPointError):
        return np.inf
    return float(np.mean(fit.fun**2))


def _differences(residual, q, h: float = 1e-6):
    r0 = residual(q)
    out = np.empty((len(r0), len(q)))
    for j in range(len(q)):
        e = np.zeros(len(q))
        e[j] = h * max(abs(q[j]), 1.0)
        out[:, j] = (residual(q + e) - r0) / e[j]
    return out


def widen(problem, result, optimizer: str, budget: int, seed, options) -> tuple:
    """(result, notes): while the fit ends on an edge where the box is too small (``classify``) and
    budget is left, that edge moved one step out (never past a model limit) and the search run again on
    the rest of the budget; the better result kept, its ``nfev`` the total. ``notes`` say what was done."""
    from bwbench.engine import fitting

    notes: list[str] = []
    if not hasattr(problem, "loss_batch") or not np.isfinite(result.mse):
        return result, notes
    limits = problem.model.parameter_limits(problem.state) if hasattr(problem, "model") else {}
    for _ in range(MAX_WIDENINGS):
        left = budget - result.nfev
        if left < 10 * problem.dim or not result.at_bound:
            break
        params = np.array([result.params[n] for n in problem.param_names])
        small = [e for e in classify(problem, params, result.at_bound) if e.kind == TOO_SMALL]
        small = [e for e in small if not limits.get(e.name, {}).get(e.side)]
        if not small:
            break
        moved = []
        for e in small:
            i = list(problem.param_names).index(e.name)
            value = step(problem, i, e.side)
            if e.side == "upper":
                problem.upper[i] = value
            else:
                problem.lower[i] = value
            moved.append(f"{e.name} to [{problem.lower[i]:.4g}, {problem.upper[i]:.4g}]")
        again = fitting.run(problem, optimizer, left, seed, options)
        better = again.mse < result.mse
        notes.append(
            f"box widened by the fit ({'; '.join(e.text for e in small)}): {', '.join(moved)}, and the search "
            f"run again on the {left} evaluations left: "
            + (f"MSE {result.mse:.4g} → {again.mse:.4g} N²" if better else "no better fit there")
        )
        total = result.nfev + again.nfev
        result = replace(again if better else result, nfev=total, budget=budget)
        if not better:
            break
    return result, notes


def refuse_past_limits(model, state, names, lower, upper, given: dict) -> None:
    """``UserError`` when ``--bounds`` (``given``: {name: (lower, upper)}) widens the default box (``names``,
    ``lower``, ``upper``) past one of the model's limits (``Model.parameter_limits``): beyond it the
    model is not the model."""
    from bwbench.errors import UserError

    limits = model.parameter_limits(state)
    names = list(names)
    for name, (lo, hi) in (given or {}).items():
        if name not in names:
            continue
        i = names.index(name)
        for side, value, edge, beyond in (
            ("lower", lo, lower[i], lo < lower[i]),
            ("upper", hi, upper[i], hi > upper[i]),
        ):
            why = limits.get(name, {}).get(side)
            if why and beyond:
                raise UserError(
                    f"--bounds: {name} {side} {value:g} is past the model's limit {edge:g} ({why}); a box "
                    "may stop short of it, not go beyond"
                )
