"""The per-trajectory part of the linear solve (``bwbench.problems.hysteresis.linear.solve``), compiled with numba."""

from __future__ import annotations

import numba
import numpy as np


def w_solve(Z, good, col, QT, r0, nw, want_residual, residual, RG, Qty):
    """The per-trajectory part of the solve for each row of Z (m, L): ``_w_row`` on each row, on
    numba's threads when there are enough rows for each of them to be worth a thread's start (on a
    busy machine a parallel loop waits for a thread that has no core), else
    in this thread. Same results either way (the rows are independent)."""
    m = Z.shape[0]
    q = QT.shape[0]
    C = np.zeros((m, q, nw))
    Rw = np.zeros((m, nw, nw))
    qwy = np.zeros((m, nw))
    h = np.zeros((m, nw))
    rss = np.full(m, np.inf)
    full = np.zeros(m, dtype=np.bool_)
    g = np.zeros((m, q))
    r0_2 = sum_squares(r0)
    threads = numba.get_num_threads()
    if threads > 1 and m >= 2 * threads:
        _w_parallel(Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full, RG, Qty, g)
    else:
        _w_serial(Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full, RG, Qty, g)
    return C, Rw, qwy, h, rss, full, g


def mse_rows(Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded):
    """``LinearDesign.mse``'s work in one compiled call: per row of Z (m, L) its unbounded RSS (+inf
    where the trajectory or the solve is not finite) and whether its coefficients break a bound
    (``bounded``: any finite bound). ``sw``: √weights (L,), or empty for none. The same ``_w_row`` and
    ``_fixed_coefficients`` as ``w_solve`` on the same numbers, so the same bits: a one-point
    optimiser's loss then pays one call into numba instead of a dozen small array operations."""
    threads = numba.get_num_threads()
    args = (Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded)
    return _mse_parallel(*args) if threads > 1 and Z.shape[0] >= 2 * threads else _mse_serial(*args)


@numba.njit(cache=True, error_model="numpy")
def _mse_row(i, Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded, rss_out, bad):
    L = Z.shape[1]
    q = QT.shape[0]
    row = np.empty((1, L))
    for l in range(L):
        z = Z[i, l]
        if not np.isfinite(z):
            return
        row[0, l] = z * sw[l] if sw.shape[0] else z
    good = np.ones(1, dtype=np.bool_)
    C = np.zeros((1, q, nw))
    Rw = np.zeros((1, nw, nw))
    qwy = np.zeros((1, nw))
    h = np.zeros((1, nw))
    rss = np.full(1, np.inf)
    full = np.zeros(1, dtype=np.bool_)
    g = np.zeros((1, q))
    _w_row(0, row, good, col, QT, r0, r0_2, nw, False, np.empty((0, L)), C, Rw, qwy, h, rss, full)
    _fixed_coefficients(0, good, C, h, RG, Qty, g)
    # as LinearDesign._unbounded: a finite but huge trajectory can overflow the solve
    if not np.isfinite(rss[0]):
        return
    for k in range(nw):
        if not np.isfinite(h[0, k]):
            return
        for j in range(q):
            if not np.isfinite(C[0, j, k]):
                return
    rss_out[i] = rss[0]
    if bounded:
        for j in range(q):
            if g[0, j] < lower[j] or g[0, j] > upper[j]:
                bad[i] = True
        for k in range(nw):
            if h[0, k] < lower[q + k] or h[0, k] > upper[q + k]:
                bad[i] = True


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _mse_serial(Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded):
    rss = np.full(Z.shape[0], np.inf)
    bad = np.zeros(Z.shape[0], dtype=np.bool_)
    for i in range(Z.shape[0]):
        _mse_row(i, Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded, rss, bad)
    return rss, bad


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _mse_parallel(Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded):
    rss = np.full(Z.shape[0], np.inf)
    bad = np.zeros(Z.shape[0], dtype=np.bool_)
    for i in numba.prange(Z.shape[0]):
        _mse_row(i, Z, sw, col, QT, r0, r0_2, nw, RG, Qty, lower, upper, bounded, rss, bad)
    return rss, bad


@numba.njit(cache=True, error_model="numpy")
def sum_squares(r):
    """Σ r², one running sum: ‖r0‖² as ``w_solve`` and ``mse_rows`` take it (the same bits)."""
    s = 0.0
    for l in range(r.shape[0]):
        s += r[l] * r[l]
    return s


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _w_parallel(Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full, RG, Qty, g):
    for i in numba.prange(Z.shape[0]):
        _w_row(i, Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full)
        _fixed_coefficients(i, good, C, h, RG, Qty, g)


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _w_serial(Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full, RG, Qty, g):
    for i in range(Z.shape[0]):
        _w_row(i, Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full)
        _fixed_coefficients(i, good, C, h, RG, Qty, g)


@numba.njit(cache=True, error_model="numpy")
def _fixed_coefficients(i, good, C, h, RG, Qty, g):
    """Row i's coefficients of the fixed columns, g = RG⁻¹·(Qᵀy − QᵀW·h) by back-substitution (RG upper
    triangular, q × q): here rather than one scipy call per solve, whose argument checks cost more than
    this arithmetic when a one-point optimiser solves one row at a time. 0 for a row that is not good."""
    if not good[i]:
        return
    q = RG.shape[0]
    for j in range(q - 1, -1, -1):
        e = Qty[j]
        for k in range(h.shape[1]):
            e -= C[i, j, k] * h[i, k]
        for j2 in range(j + 1, q):
            e -= RG[j, j2] * g[i, j2]
        g[i, j] = e / RG[j, j]


@numba.njit(cache=True, inline="always", error_model="numpy")
def _dot(a, b):
    """Σ a·b over two rows of equal length, in 8 partial sums: 8 independent chains of additions,
    which the CPU overlaps (one running sum waits ~4 cycles per sample), in a fixed order, so every
    call on the same numbers gives the same bits."""
    n = a.shape[0]
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
    m = n - n % 8
    for l in range(0, m, 8):
        s0 += a[l] * b[l]
        s1 += a[l + 1] * b[l + 1]
        s2 += a[l + 2] * b[l + 2]
        s3 += a[l + 3] * b[l + 3]
        s4 += a[l + 4] * b[l + 4]
        s5 += a[l + 5] * b[l + 5]
        s6 += a[l + 6] * b[l + 6]
        s7 += a[l + 7] * b[l + 7]
    tail = 0.0
    for l in range(m, n):
        tail += a[l] * b[l]
    return ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7)) + tail


@numba.njit(cache=True, error_model="numpy")
def _w_row(i, Z, good, col, QT, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full):
    """The per-trajectory part of the solve for row i of Z (m, L), QT = Qᵀ (q, L), in two or three
    passes over it.

    Pass 1: the nw masked w-columns W (rows of a scratch array), c1 = QᵀW and ‖W‖². Pass 2: W̃ = W − Q·c1,
    then W̃ᵀW̃, c2 = QᵀW̃ (re-orthogonalisation: W̃' = W̃ − Q·c2 has W̃'ᵀW̃' = W̃ᵀW̃ − c2ᵀc2 and
    W̃'ᵀr0 = W̃ᵀr0 since Qᵀr0 = 0) and W̃ᵀr0. Then a Cholesky factor Rw of the small Gram matrix,
    qwy = Rw⁻ᵀ·W̃'ᵀr0, h = Rw⁻¹·qwy and RSS = ‖r0‖² − ‖qwy‖². Pass 3, only when that subtraction
    would lose more than 4 digits or residuals are wanted: the residual explicitly. A w-column
    within 1e-10 of the span of the others gets h = 0 and ``full`` False. The sums over samples are
    ``_dot``s of whole rows (no running sums kept in arrays, whose every update waited for the last).
    """
    L = Z.shape[1]
    q = QT.shape[0]
    if not good[i]:
        return
    W = np.zeros((nw, L))
    for l in range(L):
        W[col[l], l] = Z[i, l]
    c1 = np.zeros((nw, q))
    norm2 = np.zeros(nw)
    for k in range(nw):
        norm2[k] = _dot(W[k], W[k])
        for j in range(q):
            c1[k, j] = _dot(W[k], QT[j])
    # W̃ = W − Q·c1, in place, sample by sample (no sum over samples: vectorised)
    for k in range(nw):
        for j in range(q):
            cj = c1[k, j]
            for l in range(L):
                W[k, l] -= QT[j, l] * cj
    G = np.zeros((nw, nw))
    c2 = np.zeros((nw, q))
    b = np.zeros(nw)
    for k in range(nw):
        b[k] = _dot(W[k], r0)
        for j in range(q):
            c2[k, j] = _dot(W[k], QT[j])
        for k2 in range(k, nw):
            G[k, k2] = _dot(W[k], W[k2])
    for k in range(nw):
        for k2 in range(k, nw):
            for j in range(q):
                G[k, k2] -= c2[k, j] * c2[k2, j]
    for k in range(nw):
        for j in range(q):
            C[i, j, k] = c1[k, j] + c2[k, j]
    # Cholesky of the (at most 2×2) Gram matrix; a dependent column is dropped (h = 0).
    ok = True
    for k in range(nw):
        d = G[k, k]
        for k0 in range(k):
            d -= Rw[i, k0, k] * Rw[i, k0, k]
        if d > 1e-20 * norm2[k] and d > 0.0:
            Rw[i, k, k] = np.sqrt(d)
            for k2 in range(k + 1, nw):
                e = G[k, k2]
                for k0 in range(k):
                    e -= Rw[i, k0, k] * Rw[i, k0, k2]
                Rw[i, k, k2] = e / Rw[i, k, k]
            e = b[k]
            for k0 in range(k):
                e -= Rw[i, k0, k] * qwy[i, k0]
            qwy[i, k] = e / Rw[i, k, k]
        else:
            ok = False
            Rw[i, k, k] = 1.0
            for k2 in range(k + 1, nw):
                Rw[i, k, k2] = 0.0
    for k in range(nw - 1, -1, -1):
        e = qwy[i, k]
        for k2 in range(k + 1, nw):
            e -= Rw[i, k, k2] * h[i, k2]
        h[i, k] = e / Rw[i, k, k]
    full[i] = ok
    r = r0_2
    for k in range(nw):
        r -= qwy[i, k] * qwy[i, k]
    if want_residual or r < 1e-4 * r0_2:
        ceff = np.zeros(q)  # Σ_k h_k·(c1_k + c2_k): the Q-part of the fitted w-columns
        for k in range(nw):
            for j in range(q):
                ceff[j] += h[i, k] * C[i, j, k]
        e = residual[i] if want_residual else np.empty(L)
        for l in range(L):
            e[l] = r0[l] - h[i, col[l]] * Z[i, l]
        for j in range(q):
            cj = ceff[j]
            for l in range(L):
                e[l] += QT[j, l] * cj
        r = _dot(e, e)
    rss[i] = r
