"""The per-trajectory part of the linear solve (``bwbench.problems.hysteresis.linear.solve``), compiled with numba."""

from __future__ import annotations

import numba
import numpy as np


def w_solve(Z, good, col, Q, r0, nw, want_residual, residual):
    """The per-trajectory part of the solve for each row of Z (m, L): ``_w_row`` on each row, on
    numba's threads when there are enough rows for each of them to be worth a thread's start (on a
    busy machine a parallel loop waits for a thread that has no core: ~10–100 ms per call), else
    in this thread. Same results either way (the rows are independent)."""
    m = Z.shape[0]
    q = Q.shape[1]
    C = np.zeros((m, q, nw))
    Rw = np.zeros((m, nw, nw))
    qwy = np.zeros((m, nw))
    h = np.zeros((m, nw))
    rss = np.full(m, np.inf)
    full = np.zeros(m, dtype=np.bool_)
    r0_2 = _sum_squares(r0)
    threads = numba.get_num_threads()
    if threads > 1 and m >= 2 * threads:
        _w_parallel(Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full)
    else:
        _w_serial(Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full)
    return C, Rw, qwy, h, rss, full


@numba.njit(cache=True, error_model="numpy")
def _sum_squares(r):
    s = 0.0
    for l in range(r.shape[0]):
        s += r[l] * r[l]
    return s


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _w_parallel(Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full):
    for i in numba.prange(Z.shape[0]):
        _w_row(i, Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full)


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _w_serial(Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full):
    for i in range(Z.shape[0]):
        _w_row(i, Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full)


@numba.njit(cache=True, error_model="numpy")
def _w_row(i, Z, good, col, Q, r0, r0_2, nw, want_residual, residual, C, Rw, qwy, h, rss, full):
    """The per-trajectory part of the solve for row i of Z (m, L), in two or three passes over it.

    Pass 1: c1 = QᵀW and ‖W‖² (W: the nw masked w-columns). Pass 2: W̃ = W − Q·c1 on the fly,
    accumulating W̃ᵀW̃, c2 = QᵀW̃ (re-orthogonalisation: W̃' = W̃ − Q·c2 has W̃'ᵀW̃' = W̃ᵀW̃ − c2ᵀc2
    and W̃'ᵀr0 = W̃ᵀr0 since Qᵀr0 = 0) and W̃ᵀr0. Then a Cholesky factor Rw of the small Gram
    matrix, qwy = Rw⁻ᵀ·W̃'ᵀr0, h = Rw⁻¹·qwy and RSS = ‖r0‖² − ‖qwy‖². Pass 3, only when that
    subtraction would lose more than 4 digits or residuals are wanted: the residual explicitly.
    A w-column within 1e-10 of the span of the others gets h = 0 and ``full`` False.
    """
    L = Z.shape[1]
    q = Q.shape[1]
    if not good[i]:
        return
    c1 = np.zeros((nw, q))
    norm2 = np.zeros(nw)
    for l in range(L):
        k, z = col[l], Z[i, l]
        norm2[k] += z * z
        for j in range(q):
            c1[k, j] += z * Q[l, j]
    G = np.zeros((nw, nw))
    c2 = np.zeros((nw, q))
    b = np.zeros(nw)
    t = np.zeros(nw)
    for l in range(L):
        for k in range(nw):
            s = Z[i, l] if col[l] == k else 0.0
            for j in range(q):
                s -= Q[l, j] * c1[k, j]
            t[k] = s
            b[k] += s * r0[l]
            for j in range(q):
                c2[k, j] += s * Q[l, j]
        for k in range(nw):
            for k2 in range(k, nw):
                G[k, k2] += t[k] * t[k2]
    for k in range(nw):
        for k2 in range(k, nw):
            for j in range(q):
                G[k, k2] -= c2[k, j] * c2[k2, j]
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
        r = 0.0
        for l in range(L):
            e = r0[l] - h[i, col[l]] * Z[i, l]
            for j in range(q):
                e += Q[l, j] * ceff[j]
            r += e * e
            if want_residual:
                residual[i, l] = e
    rss[i] = r
