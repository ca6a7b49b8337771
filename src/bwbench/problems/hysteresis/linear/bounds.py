"""Bounds on the coefficients an identifiable formulation solves: which, and the bounded solve.

**Which bounds** (``physical_bounds``, the identifiable problems' default; a ``--bounds`` file or a
study's ``[bounds]`` may set any solved coefficient by name, e.g. ``{"m": [0, 0.01], "c+": [0, 50]}``):

- a fitted inertia m in [0, ``M_MAX``] = [0, 1] N·s²/mm (0 to 1 t): a negative mass is no mass, and
  no specimen or damper on a test machine moves a tonne (1 t is the paper's normalisation, m = 1);
- the model's own physical limits on its solved coefficients (``Model.coefficient_limits``), on the
  same condition as the viscous sign below: Spencer's accumulator stiffness k₁ ≥ 0, the classic
  Bouc-Wen's spring k ≥ 0 and hysteretic weight h ≥ 0;
- a viscous coefficient (unit N·s/mm: c₁ of Spencer's model) ≥ 0 when the data follow docs/file-formats.md's
  sign convention, i.e. the measured loops dissipate energy (∮F·dx > 0): a dashpot cannot push the
  way it moves. Data whose loops run the other way get no sign bound, nor does a model whose
  branches may carry either sign (``Model.viscous_sign_bound``: the switched model's c± — the
  paper's ξ₋ < 0 makes c₋ < 0 on specimens whose loops dissipate).

**The solve.** The unbounded least-squares solution of each row comes from the fast path
(``linear_solve``), together with its triangular factor: X = [Q | Q_w]·R, b = [Q | Q_w]ᵀ·y. A row
whose solution breaks a bound is re-solved on the p × p system ‖R·β − b‖², which has the same
minimiser as ‖X·β − y‖² and differs from it by the constant RSS of the unbounded fit: O(p³) per
bounded row (p ≤ 9), nothing per sample. First, batched over the rows that break the same bounds,
the solution with those coefficients held on their bounds, accepted where it is the bounded optimum
(KKT: the rest inside their bounds, the gradient pushing each held one outwards); the other rows go
to bounded least squares (scipy ``lsq_linear``, BVLS). Rows that break no bound pay nothing beyond
the check.
"""

from __future__ import annotations

import numba
import numpy as np

M_MAX = 1.0  # N·s²/mm (1 t): the largest inertia a solved m may take by default
VISCOUS_UNIT = "N·s/mm"


def physical_bounds(
    layout, signal, f, coefficient_units: dict, viscous_sign: bool = True, model_bounds: dict | None = None
) -> tuple[dict, list[str]]:
    """({coefficient: (lower, upper)}, notes) of the module docstring for one record (or a stacked
    set: ``signal`` with ``segments``) and its force ``f`` (N); ``viscous_sign`` False: no sign bound
    on the viscous coefficients (a model whose branches may carry either sign, ``Model.viscous_sign_bound``);
    ``model_bounds``: the model's own {coefficient: (lower, upper, why)} (``Model.coefficient_limits``),
    which hold, like the viscous sign, when the measured loops dissipate."""
    from bwbench.data.plausibility import loop_work

    bounds: dict = {}
    notes: list = []
    if layout.mass:
        bounds[layout.mass] = (0.0, M_MAX)
    viscous = [n for n, unit in coefficient_units.items() if unit == VISCOUS_UNIT]
    model_bounds = {n: b for n, b in (model_bounds or {}).items() if n in coefficient_units}
    if not viscous and not model_bounds:
        return bounds, notes
    if not viscous_sign:
        notes.append(
            f"{', '.join(viscous)} of either sign: the model's branches may carry a negative viscous term "
            "while the loop dissipates (the paper's ξ₋ < 0)"
        )
        return bounds, notes
    parts = getattr(signal, "segments", None) or (slice(0, len(f)),)
    x = np.asarray(
        getattr(signal, "x_recorded", None) if getattr(signal, "x_recorded", None) is not None else signal.x,
        dtype=float,
    )
    work = sum(loop_work(x[part], np.asarray(f, dtype=float)[part])[0] for part in parts)
    if work > 0:
        bounds.update({n: (0.0, np.inf) for n in viscous})
        if viscous:
            notes.append(
                f"{', '.join(viscous)} ≥ 0: the measured loops dissipate energy (∮F·dx > 0), so a viscous "
                "force opposes the motion"
            )
        for name, (lo, hi, why) in model_bounds.items():
            bounds[name] = (float(lo), float(hi))
            notes.append(why)
    else:
        notes.append(
            f"{', '.join(viscous + list(model_bounds))} of either sign: the measured loops run clockwise "
            "(∮F·dx ≤ 0), against the sign convention (force positive in tension, displacement positive "
            "in elongation)"
        )
    return bounds, notes


def free_bounds(design) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds (arrays over ``design.free_names``) from ``design.bounds`` by name; a
    continuous offset takes the tightest of the bounds of the coefficients tied to it."""
    lower = np.full(len(design.free_names), -np.inf)
    upper = np.full(len(design.free_names), np.inf)
    for j, name in enumerate(design.free_names):
        sharing = [name] + [t for t, source in design.tied.items() if source == name]
        for n in sharing:
            lo, hi = design.bounds.get(n, (-np.inf, np.inf))
            lower[j], upper[j] = max(lower[j], lo), min(upper[j], hi)
    return lower, upper


def apply_bounds(design, out, Zw, qwy, good) -> None:
    """Re-solve, in place in ``out`` (a ``LinearSolution``), every good row whose unbounded coefficients
    break ``design.lower``/``upper``. ``Zw``: the rows' w trajectories as the design saw them (weighted);
    ``qwy``: the kernel's Q_wᵀ·y per row."""
    beta = out.coef_ls
    with np.errstate(invalid="ignore"):
        below, above = beta < design.lower, beta > design.upper
    bad = good & np.any(below | above, axis=1)
    for i in np.flatnonzero(bad):
        b = np.concatenate([design.Qty, qwy[i]])
        residual = None if out.residual is None else out.residual[i]
        new, extra = bounded_row(design, out.R[i], b, below[i], above[i], beta[i], Zw[i], residual)
        out.mse[i] = (out.rss_ls[i] + extra) / design.L
        out.coef[i, design.free_index] = new
        design._tie(out.coef[i : i + 1])
        out.bound_active[i] = True


def bounded_row(design, R, b, below, above, beta, Zw, residual) -> tuple[np.ndarray, float]:
    """(coefficients, RSS added to the unbounded one) of one row whose unbounded coefficients ``beta``
    break the bounds ``below``/``above``: the clamped guess where it is the optimum (``_clamped_row``),
    else bounded least squares (scipy ``lsq_linear``, BVLS) on its p × p system ‖R·β − b‖². The row's
    ``residual`` (model − data, or None), is moved to the new coefficients in place (``Zw``: its w
    trajectory as the design saw it, weighted)."""
    new, ok = _clamped_row(
        np.ascontiguousarray(R), np.ascontiguousarray(b, dtype=float), below, above, design.lower, design.upper
    )
    if not ok:  # the clamped guess is not the optimum: the library's bounded solver
        from scipy.optimize import lsq_linear

        fit = lsq_linear(R, b, bounds=(design.lower, design.upper), method="bvls")
        x = np.clip(fit.x, design.lower, design.upper)
        # BVLS may leave a coefficient it holds a unit in the last place inside its bound: put it
        # on the bound, as the clamped solutions are (what ``on_bound`` reads as held)
        x = np.where(on_bound(x, design.lower), design.lower, x)
        new = np.where(on_bound(x, design.upper), design.upper, x)
    extra = float(np.sum((R @ new - b) ** 2))
    if residual is not None:
        q = design.Q.shape[1]
        delta = new - beta
        change = design.G @ delta[:q]
        for j in range(len(design.w_names)):
            change += delta[q + j] * np.where(design._col == j, Zw, 0.0)
        residual += change if design.sw is None else change / design.sw
    return new, extra


def on_bound(beta, bound) -> np.ndarray:
    """Which coefficients sit on their (finite) bound, to the rounding of the bounded solve."""
    with np.errstate(invalid="ignore"):
        return np.isfinite(bound) & (np.abs(beta - bound) <= 1e-12 * np.maximum(np.abs(bound), np.max(np.abs(beta))))


@numba.njit(cache=True, error_model="numpy")
def _clamped_row(R, b, below, above, lower, upper):
    """The least-squares solution of ‖R·β − b‖² (R p × p) with exactly the coefficients of ``below``/
    ``above`` held on their bounds, and whether it is the bounded optimum: the others within their
    bounds and the gradient pushing each held one outwards (the KKT conditions of the convex problem).
    The free coefficients solve the normal equations of the columns of R they own, scaled to unit norm
    (so that they stay well conditioned), by Cholesky. Compiled: in numpy (batched over the rows that
    broke the same bounds) a one-row call is all small-array overhead."""
    p = R.shape[0]
    held = below | above
    beta = np.zeros(p)
    for j in range(p):
        if held[j]:
            beta[j] = lower[j] if below[j] else upper[j]
    rhs = b.copy()  # b − R_H·β_H
    for j in range(p):
        if held[j]:
            for i in range(p):
                rhs[i] -= R[i, j] * beta[j]
    free = np.flatnonzero(~held)
    n = free.shape[0]
    A = np.empty((p, n))
    scale = np.ones(n)
    for a in range(n):
        norm = 0.0
        for i in range(p):
            A[i, a] = R[i, free[a]]
            norm += A[i, a] * A[i, a]
        if norm > 0.0:
            scale[a] = np.sqrt(norm)
        for i in range(p):
            A[i, a] /= scale[a]
    M = np.zeros((n, n))
    c = np.zeros(n)
    for a in range(n):
        for i in range(p):
            c[a] += A[i, a] * rhs[i]
        for a2 in range(a + 1):
            sv = 0.0
            for i in range(p):
                sv += A[i, a] * A[i, a2]
            M[a, a2] = sv
            M[a2, a] = sv
    Lc = np.zeros((n, n))  # Cholesky M = Lc·Lcᵀ
    for i in range(n):
        for j in range(i + 1):
            sv = M[i, j]
            for k in range(j):
                sv -= Lc[i, k] * Lc[j, k]
            if i == j:
                if not sv > 0.0:
                    return beta, False  # singular: not this guess (BVLS decides)
                Lc[i, i] = np.sqrt(sv)
            else:
                Lc[i, j] = sv / Lc[j, j]
    x = c.copy()
    for i in range(n):
        for k in range(i):
            x[i] -= Lc[i, k] * x[k]
        x[i] /= Lc[i, i]
    for i in range(n - 1, -1, -1):
        for k in range(i + 1, n):
            x[i] -= Lc[k, i] * x[k]
        x[i] /= Lc[i, i]
    for a in range(n):
        beta[free[a]] = x[a] / scale[a]
    residual = -b
    for i in range(p):
        for j in range(p):
            residual[i] += R[i, j] * beta[j]
    gradient = np.zeros(p)
    for j in range(p):
        for i in range(p):
            gradient[j] += R[i, j] * residual[i]
    tol = 1e-9 * max(np.max(np.abs(gradient)), 1e-300)
    for j in range(p):
        if not np.isfinite(beta[j]):
            return beta, False
        if held[j]:
            if (below[j] and gradient[j] < -tol) or (above[j] and not below[j] and gradient[j] > tol):
                return beta, False  # the gradient pulls a held coefficient inwards
        elif beta[j] < lower[j] or beta[j] > upper[j]:
            return beta, False
    return beta, True
