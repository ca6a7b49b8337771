"""One trajectory's residual and its variable-projection Jacobian through the linear solve
(``LinearDesign.residual_jacobian``): the per-row part of ``LinearDesign.solve`` without the batch's
bookkeeping, and the Jacobian's sums compiled, one pass over the samples each.

With X = [G | W(θ)] (G the fixed columns, W the masked w-columns, all weighted like the solve), the
free columns X_F (those not held on a bound), β̂ the solved coefficients and r = Xβ̂ − y:

    ∂r/∂θ = D − X_F·(X_FᵀX_F)⁻¹·(X_FᵀD + Σ_k e_k·(∂W_k/∂θ)ᵀ·r),   D = Σ_k β̂_k·∂W_k/∂θ

(the sum over the free w-columns k; D runs over every w-column, held ones with their bound value).
X_FᵀX_F = R_FᵀR_F with R_F the triangular factor of the solve's R restricted to the free columns
(X = Q·R with orthonormal Q: X_F = Q·R[:, F], re-triangularised by a small Householder QR). Compiled,
because written in numpy (boolean masks, einsum, triangular solves on 3 × 6 matrices) the projection
cost as much as the simulation with sensitivities it projects (docs/speed.md).
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, error_model="numpy")
def _triangular_factor(A):
    """R (n × n, upper triangular, diagonal ≥ 0 up to sign) of A (m × n, m ≥ n) by Householder: AᵀA = RᵀR."""
    A = A.copy()
    m, n = A.shape
    for j in range(n):
        norm = 0.0
        for i in range(j, m):
            norm += A[i, j] * A[i, j]
        norm = np.sqrt(norm)
        if norm == 0.0:
            continue
        alpha = -norm if A[j, j] >= 0.0 else norm
        v = np.zeros(m)
        v[j] = A[j, j] - alpha
        for i in range(j + 1, m):
            v[i] = A[i, j]
        vv = 0.0
        for i in range(j, m):
            vv += v[i] * v[i]
        if vv == 0.0:
            continue
        for c in range(j, n):
            s = 0.0
            for i in range(j, m):
                s += v[i] * A[i, c]
            s *= 2.0 / vv
            for i in range(j, m):
                A[i, c] -= s * v[i]
    return A[:n, :].copy()


@numba.njit(cache=True, error_model="numpy")
def _solve_normal(R, C):
    """(RᵀR)⁻¹·C for upper triangular R (n × n) and C (n × d): two triangular solves."""
    n, d = C.shape
    Y = C.copy()
    for j in range(d):
        for i in range(n):  # Rᵀ·u = c
            s = Y[i, j]
            for k in range(i):
                s -= R[k, i] * Y[k, j]
            Y[i, j] = s / R[i, i]
        for i in range(n - 1, -1, -1):  # R·y = u
            s = Y[i, j]
            for k in range(i + 1, n):
                s -= R[i, k] * Y[k, j]
            Y[i, j] = s / R[i, i]
    return Y


@numba.njit(cache=True, error_model="numpy")
def projected_jacobian(G, z, dZ, col, sw, R, beta, held, r, check_orthogonal):
    """(∂r/∂θ (L, d), ok) of the module docstring. G (L, q) the weighted fixed columns, z (L,) and dZ
    (L, d) the trajectory and its sensitivities, col (L,) each sample's w-column, sw (L,) √weights, R
    (p, p) the solve's factor, beta (p,) its coefficients (held ones on their bound), held (p,) bool, r
    (L,) the weighted residual. ``ok`` False where the result is not finite or, with
    ``check_orthogonal``, r is not orthogonal to the free columns (the active set read off the solution
    is not the one the solve used)."""
    L, d = dZ.shape
    q = G.shape[1]
    p = beta.shape[0]
    D = np.empty((L, d))
    for l in range(L):
        c = beta[q + col[l]] * sw[l]
        for j in range(d):
            D[l, j] = c * dZ[l, j]
    free = np.empty(p, dtype=np.int64)
    pf = 0
    for i in range(p):
        if not held[i]:
            free[pf] = i
            pf += 1
    free = free[:pf]
    C = np.zeros((pf, d))
    Xr = np.zeros(pf)
    for a in range(pf):
        i = free[a]
        if i < q:
            for l in range(L):
                g = G[l, i]
                Xr[a] += g * r[l]
                for j in range(d):
                    C[a, j] += g * D[l, j]
        else:
            k = i - q
            for l in range(L):
                if col[l] != k:
                    continue
                w = z[l] * sw[l]
                Xr[a] += w * r[l]
                for j in range(d):
                    C[a, j] += w * D[l, j] + dZ[l, j] * sw[l] * r[l]
    RF = np.empty((p, pf))
    for a in range(pf):
        RF[:, a] = R[:, free[a]]
    R2 = _triangular_factor(RF)
    if check_orthogonal:
        # ‖Q_Fᵀr‖ = ‖R_F⁻ᵀ·X_Fᵀr‖ against the residual's norm
        u = np.empty(pf)
        for i in range(pf):
            s = Xr[i]
            for k in range(i):
                s -= R2[k, i] * u[k]
            u[i] = s / R2[i, i]
        rr = 0.0
        for l in range(L):
            rr += r[l] * r[l]
        if np.sqrt(np.sum(u * u)) > 1e-8 * max(np.sqrt(rr), 1e-300) * np.sqrt(pf):
            return D, False
    Y = _solve_normal(R2, C)
    for a in range(pf):
        i = free[a]
        if i < q:
            for l in range(L):
                g = G[l, i]
                for j in range(d):
                    D[l, j] -= g * Y[a, j]
        else:
            k = i - q
            for l in range(L):
                if col[l] != k:
                    continue
                w = z[l] * sw[l]
                for j in range(d):
                    D[l, j] -= w * Y[a, j]
    ok = True
    for l in range(L):
        if not np.isfinite(r[l]):
            ok = False
        for j in range(d):
            if not np.isfinite(D[l, j]):
                ok = False
    return D, ok


def residual_jacobian(design, z, dZ):
    """``LinearDesign.residual_jacobian``: (weighted residual (L,), ∂r/∂θ (L, d)) of trajectory z (L,)
    with sensitivities dZ (L, d), or None (a trajectory or solve that is not finite, a dependent
    column, an active set the solution does not bear out)."""
    from bwbench.problems.hysteresis.linear.bounds import on_bound

    z = np.asarray(z, dtype=float)
    dZ = np.asarray(dZ, dtype=float)
    if not np.all(np.isfinite(dZ)):
        return None  # sensitivities that overflowed: no derivative to carry through the solve
    found = _solve_row(design, z)
    if found is None:
        return None
    residual, beta, bound_active, R = found
    sw = np.ones(design.L) if design.sw is None else design.sw
    r = residual * sw
    held = np.zeros(len(beta), dtype=bool)
    if bound_active:
        held = on_bound(beta, design.lower) | on_bound(beta, design.upper)
    G = design.G if len(design.g_names) else np.zeros((design.L, 0))
    J, ok = projected_jacobian(
        np.ascontiguousarray(G, dtype=float),
        np.ascontiguousarray(z),
        np.ascontiguousarray(dZ),
        design._col,
        np.ascontiguousarray(sw, dtype=float),
        R,
        np.ascontiguousarray(beta),
        held,
        np.ascontiguousarray(r),
        bool(held.any()),  # the free coefficients must be the least-squares ones given the held
    )
    return (r, J) if ok else None


def _solve_row(design, z):
    """``design.solve(z[None], residual=True)`` for one row, the same arithmetic: (residual (model −
    data, L), the free coefficients (bounded where a bound is active), whether one is, R (p, p)); None
    where the solution is not finite or a w-column is dependent (not full rank)."""
    from bwbench.problems.hysteresis.linear.bounds import bounded_row

    Zg, good, fit_res, C, Rw, qwy, h, rss, full, g = design._unbounded(z[None, :], True)
    if not (good[0] and full[0]):
        return None
    q, nw = design.Q.shape[1], len(design.w_names)
    R = np.zeros((q + nw, q + nw))
    R[:q, :q] = design.RG
    R[:q, q:] = C[0]
    R[q:, q:] = Rw[0]
    beta = np.concatenate([g[0], h[0]])
    residual = -fit_res[0] if design.sw is None else -fit_res[0] / design.sw
    rss_total = rss[0]
    bound_active = False
    if design._bounded:
        with np.errstate(invalid="ignore"):
            below, above = beta < design.lower, beta > design.upper
        if np.any(below | above):
            b = np.concatenate([design.Qty, qwy[0]])
            beta, extra = bounded_row(design, R, b, below, above, beta, Zg[0], residual)
            rss_total = rss_total + extra
            bound_active = True
    if not np.isfinite(rss_total / design.L):
        return None
    return residual, beta, bound_active, R
