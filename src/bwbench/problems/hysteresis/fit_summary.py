"""Standard errors, correlations and a text report of one fit: ``FitResult.summary()``,
``.correlation()`` and ``.report()``.

The errors are the linearised ones of nonlinear least squares, as lmfit and ``scipy.optimize.curve_fit``
give them: cov = s²·(JᵀJ)⁻¹ with J the Jacobian of the residual (model − measured force, N) at the
optimum and s² = Σr²/(n − p) the residual variance. J is taken over every free parameter at once:

- the searched ones (central differences in the search box's own unit coordinates, one-sided at an
  edge, then mapped to physical units);
- in the identifiable formulation also the solved linear coefficients β: the force is linear in
  them, so their columns are the design's. Taking the searched θ and β together in one J is the
  variable-projection covariance (Golub & Pereyra): the uncertainty of β includes what it inherits
  from θ, not only the conditional one of a linear fit at fixed θ.

A joint fit's residuals carry the file weights (√(N·wᵢ/Lᵢ)), so Σr² is N × its loss. Coefficients
held fixed (a mass the data do not excite, a dropped branch) have no error; derived ones (the model's
direct parameters of the same force, an offset tied to another) get theirs by the delta method.
A direction along which the residual does not change (an exact invariance of the model, a linear
branch's n and η) makes the errors of the parameters on it infinite: the data do not determine them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bwbench.analysis.identifiability import ZERO_RATIO

STEP = 1e-4  # finite-difference step: of the search box's unit range (θ), relative (solved β)
ON_NULL = 1e-2  # a gradient with more than this share along a zero direction: not determined
ROLES = ("searched", "solved", "held", "derived")


@dataclass(frozen=True, eq=False)
class Uncertainty:
    """The linearised uncertainty of one fit. ``free``: the searched then solved names, the order of
    ``cov`` (physical units; rows of an undetermined parameter are inf); ``stderr``: every reported
    name → standard error (NaN for a held value, inf for an undetermined one); ``roles``: name →
    searched/solved/held/derived; ``s2``: residual variance (N², weighted in a joint fit); ``n``:
    residuals; ``chi2``: Σr² (N²)."""

    free: tuple
    cov: np.ndarray
    stderr: dict
    roles: dict
    s2: float
    n: int
    chi2: float

    @property
    def undetermined(self) -> list:
        return [n for n in self.free if not math.isfinite(self.stderr[n])]

    def correlation(self) -> np.ndarray:
        sd = np.sqrt(np.diag(self.cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = self.cov / np.outer(sd, sd)
        corr[~np.isfinite(corr)] = np.nan
        np.fill_diagonal(corr, [1.0 if math.isfinite(s) and s > 0 else np.nan for s in sd])
        return corr


def _parts(problem):
    """[(signal, measured force, the samples in the loss, their residual weights)] of each file of ``problem``."""
    if hasattr(problem, "parts"):
        sw = np.sqrt(problem.sample_weight)
        return [(p.signal, p.specimen.f, p.start.loss, sw[s]) for p, s in zip(problem.parts, problem.signal.segments)]
    return [(problem.signal, problem.specimen.f, problem.start.loss, np.ones(problem.n_data))]


class _FreeVector:
    """The free parameters of a fit as one scaled vector v = [u (searched, unit box), b (solved β/scale)],
    and the residual and derived parameters as functions of it."""

    def __init__(self, fit):
        self.fit = fit
        self.problem = problem = fit.problem
        self.params = dict(fit.params)
        self.searched = list(problem.param_names)
        theta = np.array([self.params[n] for n in self.searched], dtype=float)
        self.u0 = np.clip(problem.to_unit(theta), 0.0, 1.0)
        self.design = getattr(problem, "design", None) if problem.formulation == "identifiable" else None
        self.solved = list(self.design.free_names) if self.design is not None else []
        beta = np.array([self.params.get(n, np.nan) for n in self.solved], dtype=float)
        self.scale = np.where(np.isfinite(beta) & (beta != 0), np.abs(beta), 1.0)
        self.v0 = np.concatenate([self.u0, beta / self.scale])
        self.d = len(self.searched)
        self._parts = _parts(problem)
        self.tied = dict(self.design.tied) if self.design is not None else {}

    @property
    def names(self) -> list:
        return self.searched + self.solved

    def split(self, v):
        v = np.asarray(v, dtype=float)
        theta = self.problem.from_unit(v[: self.d])
        coef = {n: self.params.get(n, np.nan) for n in getattr(self.problem, "linear_names", ())}
        coef.update(zip(self.solved, map(float, v[self.d :] * self.scale)))
        for tied, source in self.tied.items():
            coef[tied] = coef[source]
        return theta, coef

    def residual(self, v) -> np.ndarray:
        theta, coef = self.split(v)
        if self.design is None:
            return self.problem.residual_batch(theta[None, :])[0]
        from bwbench.problems.hysteresis.fitted_model import FittedModel
        from bwbench.problems.hysteresis.model_problem import start_settings

        p = self.problem
        values = {**dict(zip(self.searched, map(float, theta))), **coef}
        model = FittedModel(p.model.name, "identifiable", values, p.state, p.excitation, {}, *start_settings(p))
        return np.concatenate([(model.force(signal, f) - f)[loss] * w for signal, f, loss, w in self._parts])

    def derived(self, v) -> dict:
        """Tied offsets and the model's direct parameters of the same force, by name."""
        theta, coef = self.split(v)
        out = {t: coef[t] for t in self.tied}
        if self.design is None:
            return out
        direct = self.problem.model.to_direct(theta, coef, self.problem.state)
        if direct is not None:
            out.update(
                zip(
                    (q.name for q in self.problem.model.direct_parameters(self.problem.state)),
                    map(float, np.asarray(direct, dtype=float)),
                )
            )
        return out

    def physical_scale(self) -> np.ndarray:
        """d(physical)/d(v) of every free coordinate (the box mapping is per coordinate)."""
        h = STEP
        up, lo = np.clip(self.u0 + h, 0, 1), np.clip(self.u0 - h, 0, 1)
        dtheta = (self.problem.from_unit(up) - self.problem.from_unit(lo)) / (up - lo)
        return np.concatenate([dtheta, self.scale])


def _difference(function, v0, d, step=STEP):
    """Central differences of a vector function of v at v0, one-sided where the first d coordinates
    (unit box) meet an edge: (len(output), len(v))."""
    columns = []
    for i in range(len(v0)):
        hi, lo = v0.copy(), v0.copy()
        hi[i] += step
        lo[i] -= step
        if i < d:
            hi[i], lo[i] = min(hi[i], 1.0), max(lo[i], 0.0)
        with np.errstate(invalid="ignore", over="ignore"):
            columns.append((np.asarray(function(hi), float) - np.asarray(function(lo), float)) / (hi[i] - lo[i]))
    return np.column_stack(columns)


def uncertainty(fit) -> Uncertainty:
    """The ``Uncertainty`` of a ``FitResult`` (see the module docstring); every error NaN when the fit
    has no finite optimum or the model blows up next to it."""
    free = _FreeVector(fit)
    roles = roles_of(fit, free)
    names = free.names
    nan = {n: math.nan for n in roles}
    r0 = free.residual(free.v0) if np.all(np.isfinite(free.v0)) else np.array([np.inf])
    n, p = len(r0), len(names)
    chi2 = float(r0 @ r0) if np.all(np.isfinite(r0)) else math.inf
    if not math.isfinite(chi2) or n <= p:
        return Uncertainty(tuple(names), np.full((p, p), np.nan), nan, roles, math.nan, n, chi2)
    J = _difference(free.residual, free.v0, free.d)
    if not np.all(np.isfinite(J)):  # the model blows up next to the optimum
        return Uncertainty(tuple(names), np.full((p, p), np.nan), nan, roles, chi2 / (n - p), n, chi2)
    s2 = chi2 / (n - p)
    _, S, Vt = np.linalg.svd(J, full_matrices=False)
    zero = S <= ZERO_RATIO * S[0] if S[0] > 0 else np.ones_like(S, dtype=bool)
    keep = ~zero
    cov_v = (Vt[keep].T / S[keep] ** 2) @ Vt[keep] * s2
    null = Vt[zero]  # rows: directions the residual does not see

    def undetermined(gradient):
        norm = float(np.linalg.norm(gradient))
        return norm > 0 and bool(np.any(np.abs(null @ gradient) > ON_NULL * norm))

    D = free.physical_scale()
    cov = cov_v * np.outer(D, D)
    bad = np.array([undetermined(np.eye(p)[i]) for i in range(p)], dtype=bool)
    cov[bad, :] = cov[:, bad] = np.inf
    stderr = dict(nan)
    stderr.update(zip(names, np.sqrt(np.diag(cov))))
    derived0 = free.derived(free.v0)
    if derived0:
        keys = list(derived0)
        Jd = _difference(lambda v: [free.derived(v).get(k, np.nan) for k in keys], free.v0, free.d)
        for k, row in zip(keys, Jd):
            if not np.all(np.isfinite(row)):
                continue
            stderr[k] = math.inf if undetermined(row) else float(np.sqrt(max(row @ cov_v @ row, 0.0)))
    return Uncertainty(tuple(names), cov, stderr, roles, s2, n, chi2)


def roles_of(fit, free=None) -> dict:
    """{name: role} of every reported parameter of ``fit``, in the summary's order."""
    free = free or _FreeVector(fit)
    roles = dict.fromkeys(free.searched, "searched")
    roles.update(dict.fromkeys(free.solved, "solved"))
    for name in getattr(fit.problem, "linear_names", ()):
        roles.setdefault(name, "derived" if name in free.tied else "held")
    for name in fit.params:
        roles.setdefault(name, "derived")
    return roles


def at_edge(fit, free=None) -> dict:
    """{name: True} of the searched parameters on an edge of their box and the solved coefficients on a
    bound of the linear solve."""
    free = free or _FreeVector(fit)
    out = dict.fromkeys(fit.result.at_bound, True)
    if free.design is not None:
        for name, lo, hi in zip(free.solved, free.design.lower, free.design.upper):
            value = fit.params.get(name, np.nan)
            tol = 1e-9 * max(abs(value), 1.0)
            if (np.isfinite(lo) and abs(value - lo) <= tol) or (np.isfinite(hi) and abs(value - hi) <= tol):
                out[name] = True
    return out


def box_of(fit, free=None) -> dict:
    """{name: (lower, upper)}: the search box of the searched names, the linear solve's bounds of the solved."""
    free = free or _FreeVector(fit)
    p = fit.problem
    out = {n: (float(lo), float(hi)) for n, lo, hi in zip(p.param_names, p.lower, p.upper)}
    if free.design is not None:
        out.update({n: (float(lo), float(hi)) for n, lo, hi in zip(free.solved, free.design.lower, free.design.upper)})
    return out


def summary(fit, unc: Uncertainty):
    """The DataFrame of ``FitResult.summary()``: one row per parameter (index ``name``): value, stderr,
    unit, role, at_edge, lower, upper."""
    import pandas as pd

    free = _FreeVector(fit)
    edge, box = at_edge(fit, free), box_of(fit, free)
    units = fit.units
    rows = []
    for name, role in unc.roles.items():
        lo, hi = box.get(name, (math.nan, math.nan))
        rows.append(
            {
                "name": name,
                "value": float(fit.params.get(name, math.nan)),
                "stderr": unc.stderr.get(name),
                "unit": units.get(name, ""),
                "role": role,
                "at_edge": bool(edge.get(name, False)),
                "lower": lo,
                "upper": hi,
            }
        )
    frame = pd.DataFrame(rows).set_index("name")
    frame["stderr"] = frame["stderr"].astype(float)
    return frame


def correlation(unc: Uncertainty):
    """The free parameters' correlation matrix as a DataFrame (NaN for an undetermined parameter)."""
    import pandas as pd

    return pd.DataFrame(unc.correlation(), index=list(unc.free), columns=list(unc.free))


def information_criteria(chi2: float, n: int, p: int) -> tuple[float, float]:
    """(AIC, BIC) of a least-squares fit as lmfit states them: n·ln(χ²/n) + 2p and n·ln(χ²/n) + ln(n)·p."""
    if not (math.isfinite(chi2) and chi2 > 0):
        return math.nan, math.nan
    base = n * math.log(chi2 / n)
    return base + 2 * p, base + math.log(n) * p


def _number(x: float) -> str:
    return f"{x:.6g}" if math.isfinite(x) else ("not determined" if x == math.inf else "–")


def report(fit, unc: Uncertainty, findings, min_correlation: float = 0.1) -> str:
    """The text of ``FitResult.report()``, laid out like lmfit's ``fit_report``; ``findings``: the fit's
    (``FitResult.findings``), listed last with their severity."""
    p, r = fit.problem, fit.result
    frame = summary(fit, unc)
    free = frame[frame["role"].isin(["searched", "solved"])]
    aic, bic = information_criteria(unc.chi2, unc.n, len(free))
    files = ", ".join(f"{f['specimen']} ({f['n']} samples)" for f in fit.files)
    state = f", {p.state} state" if p.state else ""
    lines = [
        "[[Fit]]",
        f"    model              = {p.model.name} ({p.formulation} formulation{state}, {p.excitation} excitation)",
        f"    data               = {files}",
        f"    optimizer          = {r.optimizer}, seed {r.seed}, {r.nfev} of {r.budget} evaluations",
        f"    status             = {'ok' if fit.ok else 'FAILED: ' + str(fit.failure)}",
        "[[Fit Statistics]]",
        f"    # data points      = {unc.n}",
        f"    # variables        = {len(free)} ({int((free['role'] == 'searched').sum())} searched, "
        f"{int((free['role'] == 'solved').sum())} solved)",
        f"    chi-square         = {_number(unc.chi2)} N² (Σ residual²{', weighted' if len(fit.files) > 1 else ''})",
        f"    reduced chi-square = {_number(unc.s2)} N²",
        f"    RMSE               = {_number(fit.rmse_N)} N",
    ]
    if len(fit.files) == 1:
        lines.append(f"    NRMSE              = {_number(fit.files[0]['nrmse'])} (RMSE / max|F measured|)")
    lines += [f"    Akaike info crit   = {_number(aic)}", f"    Bayesian info crit = {_number(bic)}", "[[Variables]]"]
    width = max(len(n) for n in frame.index) + 1
    for name, row in frame.iterrows():
        unit = "" if row["unit"] in ("", "-") else f" {row['unit']}"
        value = _number(row["value"])
        if row["role"] == "held":
            text = f"{value}{unit} (held)"
        elif math.isfinite(row["stderr"]):
            pct = f" ({abs(row['stderr'] / row['value']):.2%})" if row["value"] else ""
            text = f"{value} +/- {row['stderr']:.6g}{unit}{pct} ({row['role']})"
        elif row["stderr"] == math.inf:
            text = f"{value}{unit} (+/- not determined by the data) ({row['role']})"
        else:
            text = f"{value}{unit} (+/- –) ({row['role']})"
        lines.append(f"    {name + ':':<{width}} {text}{' at the edge of its box' if row['at_edge'] else ''}")
    corr = unc.correlation()
    pairs = [
        (abs(corr[i, j]), unc.free[i], unc.free[j], corr[i, j])
        for i in range(len(unc.free))
        for j in range(i + 1, len(unc.free))
        if np.isfinite(corr[i, j]) and abs(corr[i, j]) >= min_correlation
    ]
    if pairs:
        lines.append(f"[[Correlations]] (unreported correlations are < {min_correlation:.3f})")
        for _, a, b, c in sorted(pairs, reverse=True):
            lines.append(f"    C({a}, {b}){' ' * max(0, 2 * width - len(a) - len(b) - 4)} = {c:+.4f}")
    notes = [finding.line for finding in findings]
    undetermined = unc.undetermined
    if undetermined:
        text = (
            f"{len(undetermined)} of the {len(unc.free)} free parameters are not determined by these data "
            f"({', '.join(undetermined)}): the residual does not change along some combination of them"
        )
        if p.formulation != "identifiable" and "identifiable" in p.model.formulations:
            text += (
                "; the identifiable formulation (formulation='identifiable') has none of the model's exact symmetries"
            )
        notes.append(text)
    if notes:
        lines.append("[[Findings]]")
        lines += [f"    {n}" for n in notes]
    return "\n".join(lines)
