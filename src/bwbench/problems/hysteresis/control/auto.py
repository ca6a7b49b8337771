"""``--law auto``: each control level fitted alone first, then for each parameter the smallest law its
per-level values need beyond their standard errors.

For a parameter with values y_l ± s_l at the levels u_l (the plain model fitted jointly to the files
at each level, its linearised standard errors), the candidate laws are tried from the smallest:
constant (1 coefficient), then linear and exponential (2; exponential only for a parameter that stays
positive), then quadratic (3). Each is fitted to the points by weighted least squares (exponential:
log y against u, weights y_l/s_l) and accepted when its χ² = Σ((y_l − law(u_l))/s_l)² is within the
99 % point of χ² on (levels − coefficients) degrees of freedom; of two accepted laws of the same size
the one with the smaller χ² is taken. A law with as many coefficients as levels passes any points
(no degree of freedom left): it is taken only when every smaller law fails, and the reason says so.
A parameter whose per-level standard errors are not finite (not determined at some level) stays
constant. The choice and its reason are reported for every parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

CONFIDENCE = 0.99
ORDER = (("constant", 1), ("linear", 2), ("exponential", 2), ("quadratic", 3))


@dataclass(frozen=True)
class Choice:
    """The law chosen for one parameter and why (``chi2``: law name → (χ², degrees of freedom))."""

    parameter: str
    law: str
    reason: str
    chi2: dict


def _fit(law: str, u, y, s):
    """(χ², predicted values) of ``law`` fitted to the points by weighted least squares."""
    w = 1.0 / s
    if law == "exponential":
        if np.any(y <= 0):
            return math.inf, None
        A = np.column_stack([np.ones_like(u), u]) * (y * w)[:, None]
        coef = np.linalg.lstsq(A, np.log(y) * y * w, rcond=None)[0]
        pred = np.exp(coef[0] + coef[1] * u)
    else:
        degree = {"constant": 0, "linear": 1, "quadratic": 2}[law]
        A = np.vander(u, degree + 1, increasing=True) * w[:, None]
        coef = np.linalg.lstsq(A, y * w, rcond=None)[0]
        pred = np.vander(u, degree + 1, increasing=True) @ coef
    return float(np.sum(((y - pred) / s) ** 2)), pred


def choose(parameter: str, u, y, s, unit: str = "", control: str = "u") -> Choice:
    """The law of one parameter from its per-level values ``y`` ± ``s`` at controls ``u``."""
    u, y, s = (np.asarray(a, dtype=float) for a in (u, y, s))
    points = ", ".join(f"{yi:.4g} ± {si:.2g}" for yi, si in zip(y, s))
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(y))) or np.any(s <= 0):
        return Choice(parameter, "constant", f"not determined at every level ({points}): kept constant", {})
    chi2 = {}
    accepted = None
    for size in (1, 2, 3):
        if size > len(u):
            break
        passing = []
        for law, n in ORDER:
            if n != size:
                continue
            value, _ = _fit(law, u, y, s)
            dof = len(u) - n
            chi2[law] = (value, dof)
            if dof > 0 and value <= stats.chi2.ppf(CONFIDENCE, dof):
                passing.append((value, law))
        if passing:
            accepted = min(passing)[1]
            break
    said = "; ".join(f"{law} χ² {v:.3g} on {d} dof" for law, (v, d) in chi2.items() if math.isfinite(v))
    unit = f" {unit}" if unit and unit not in ("-", "–") else ""
    if accepted is not None:
        limit = stats.chi2.ppf(CONFIDENCE, len(u) - dict(ORDER)[accepted])
        why = f"values {points}{unit} at {control}; {said}; {accepted} is the smallest within the 99 % χ² ({limit:.3g})"
        return Choice(parameter, accepted, why, chi2)
    largest = "quadratic" if len(u) >= 3 else ("linear" if len(u) == 2 else "constant")
    why = f"values {points}{unit} at {control}; {said}; no smaller law fits within the errors: {largest}"
    if len(u) <= 3:
        why += f" (with {len(u)} levels it passes through every point: no check left)"
    return Choice(parameter, largest, why, chi2)


def per_level_fits(specimens, settings: dict, optimizer: str = "lsq-trf", budget: int = 4100, seed: int = 0):
    """{level: (ControlledProblem without laws, FitResult, {name: (value, stderr)})} of the files at each
    control level fitted jointly and alone (every file's control constant)."""
    from bwbench.errors import UserError
    from bwbench.problems.hysteresis.control.problem import build
    from bwbench.problems.hysteresis.fit_result import run_fit

    groups: dict = {}
    for s in specimens:
        u = np.asarray(s.control, dtype=float)
        if np.ptp(u) != 0:
            raise UserError(f"{s.path}: --law auto fits each control level alone: its control varies within the file")
        groups.setdefault(float(u[0]), []).append(s)
    out = {}
    for level in sorted(groups):
        problem = build(groups[level], settings, {})
        fit = run_fit(problem, optimizer, budget, seed, stop="agreed")
        names, cov, _ = problem.covariance(fit.result.params)
        se = dict(zip(names, np.sqrt(np.abs(np.diag(cov)))))
        out[level] = (
            problem,
            fit,
            {n: (float(fit.result.params[n]), float(se.get(n, np.nan))) for n in fit.result.params},
        )
    return out


def choose_laws(fits: dict, control: str, units: dict | None = None) -> list[Choice]:
    """A ``Choice`` for every parameter the per-level fits share (searched and solved)."""
    levels = sorted(fits)
    names = [n for n in fits[levels[0]][2] if all(n in fits[level][2] for level in levels)]
    out = []
    for name in names:
        y = [fits[level][2][name][0] for level in levels]
        s = [fits[level][2][name][1] for level in levels]
        out.append(choose(name, levels, y, s, (units or {}).get(name, ""), control))
    return out
