"""Several parameter sets simulated together, interleaved so their ``pow`` calls overlap.

The scalar kernel (``bwbench.model``) is latency-bound: every RK4 stage waits for a ``pow`` whose
argument comes from the stage before, ~25 ns each, four per step. Here K lanes each run one
parameter set as a small state machine that stops wherever it needs |z|^n. A round computes the
K pending powers back to back (independent, so the CPU overlaps them), then advances every lane
to its next power. Lanes are not synchronised: each has its own sample, substep count, stiff
(backward-Euler) fallback and Newton iteration, and a lane whose row is done (or blew up) takes
the next row of its chunk, so stiff rows do not leave the other lanes idle.

Each lane performs exactly the scalar kernel's floating-point operations in the same order (the
excitation pieces come from the same helper, the force and MSE from the same functions), so the
results are bit-identical to ``model.mse_batch(..., kernel="scalar")``. The only extra ``pow`` is
one whose result is discarded (where the scalar kernel skips it because z = 0).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bwbench import model
from bwbench.model import (
    _IMPLICIT_SUBSTEPS,
    _RK4_MAX_SUBSTEPS,
    _RK4_STIFFNESS_PER_SUBSTEP,
    _attractor,
    _force_from_z,
    _mse_of_force,
    _reversal_pieces,
    _substeps,
)

LANES = 4  # measured best on AMD EPYC (Zen 4): 4 and 8 within noise, 2 and 16 slower

_STIFF_WORK = _RK4_STIFFNESS_PER_SUBSTEP * _RK4_MAX_SUBSTEPS  # as in model._advance_z
_NEWTON_ITERATIONS = 60  # as in model._backward_euler

# What a lane's pending power is for (its pow(arg, n) result feeds that state on the next round).
_PIECE = 0  # none pending: start the next piece, sample or row
_SETUP = 1  # |z|^n at the start of a piece: first RK4 stage and local stiffness
_K1, _K2, _K3, _K4 = 2, 3, 4, 5  # RK4 stages
_FALLBACK = 6  # first stage of the RK4 that finishes a piece after a bracket-less implicit step
_BE_START = 7  # |z0|^n of a backward-Euler step
_NEWTON = 8  # |z|^n at a Newton iterate of that step

_MODE_Z, _MODE_MSE = 0, 1


@numba.njit(cache=True, error_model="numpy")
def _excitation_pieces(t, x, v, split):
    """Per sample interval k and piece j (before/after a reversal): dx (mm), branch, z slot.

    ``slot`` is 1 where the piece drives z₋ (split convention, '−' branch), else 0 (z₊ or the
    shared z); ``active[k]`` is the slot whose z is reported at sample k + 1.
    """
    n = max(x.shape[0] - 1, 0)
    dx = np.zeros((n, 2))
    branch = np.zeros((n, 2), dtype=np.int64)
    slot = np.zeros((n, 2), dtype=np.int64)
    active = np.zeros(n, dtype=np.int64)
    for k in range(n):
        b0 = 0 if v[k] >= 0.0 else 1  # as model._branch
        b1 = 0 if v[k + 1] >= 0.0 else 1
        if b0 == b1:
            dx[k, 0] = x[k + 1] - x[k]
        else:
            dx[k, 0], dx[k, 1] = _reversal_pieces(t[k], t[k + 1], x[k], x[k + 1], v[k], v[k + 1])
        branch[k, 0], branch[k, 1] = b0, b1
        slot[k, 0] = 1 if split and b0 == 1 else 0
        slot[k, 1] = 1 if split and b1 == 1 else 0
        active[k] = slot[k, 1]
    return dx, branch, slot, active


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rate_from_pow(z, p, direction, A, beta_plus_gamma, beta_minus_gamma):
    """model._rate with p = |z|^n already computed (ignored at z = 0, as there)."""
    if z == 0.0:
        return A
    if (z > 0.0) == (direction > 0.0):
        return A - beta_plus_gamma * p
    return A - beta_minus_gamma * p


@numba.njit(cache=True, error_model="numpy")
def _run_chunk(H, lo, hi, pieces, K, mode, Z, P, x, v, a, f_meas, out):
    """Rows lo..hi-1 of ``H`` (m, 8) through K lanes.

    mode _MODE_Z writes each row's z into ``Z`` (+inf rows on blow-up); _MODE_MSE writes the MSE
    of row r of ``P`` against ``f_meas`` into ``out[r]`` (+inf on blow-up).
    """
    dxs, branch, slot, active = pieces
    n_samples = x.shape[0]
    zbuf = np.empty((K, n_samples))
    fbuf = np.empty(n_samples)
    # Each row's branch parameters (index [lane, branch]) and derived constants.
    pA = np.empty((K, 2))
    pn = np.empty((K, 2))
    pbg = np.empty((K, 2))  # β + γ
    pbm = np.empty((K, 2))  # β − γ
    pzs = np.empty((K, 2))
    prate = np.empty((K, 2))
    # Lane state: row, interval k and piece j, the two z's and the piece being integrated.
    row = np.full(K, -1)
    kk = np.zeros(K, dtype=np.int64)
    jj = np.zeros(K, dtype=np.int64)
    z_slot = np.zeros((K, 2))
    state = np.zeros(K, dtype=np.int64)
    zc = np.zeros(K)  # z at the start of the current RK4 substep / backward-Euler step
    dxl = np.zeros(K)
    direction = np.ones(K)
    hstep = np.zeros(K)
    m_sub = np.zeros(K, dtype=np.int64)
    i_sub = np.zeros(K, dtype=np.int64)
    k1 = np.zeros(K)
    k2 = np.zeros(K)
    k3 = np.zeros(K)
    zarg = np.zeros(K)  # the z whose power is pending
    # Backward Euler: step h, attractor, steps done, bracket, Newton iteration count.
    bh = np.zeros(K)
    batt = np.zeros(K)
    bdone = np.zeros(K, dtype=np.int64)
    blo = np.zeros(K)
    bhi = np.zeros(K)
    bfhi = np.zeros(K)
    bit = np.zeros(K, dtype=np.int64)
    pw_arg = np.ones(K)
    pw_exp = np.ones(K)
    pw = np.zeros(K)

    next_row = lo
    busy = K
    while busy > 0:
        for lane in range(K):
            if row[lane] >= 0:
                pw[lane] = math.pow(pw_arg[lane], pw_exp[lane])
        busy = 0
        for lane in range(K):
            st = state[lane]
            p = pw[lane]
            while True:
                r = row[lane]
                if st == _PIECE:
                    k = kk[lane]
                    if r >= 0 and k == n_samples - 1:
                        _finish(mode, r, True, zbuf[lane], Z, P, x, v, a, f_meas, fbuf, out)
                        r = -1
                    elif r >= 0 and jj[lane] == 2:  # interval done: report the active z
                        z_act = z_slot[lane, active[k]]
                        if not np.isfinite(z_act):
                            _finish(mode, r, False, zbuf[lane], Z, P, x, v, a, f_meas, fbuf, out)
                            r = -1
                        else:
                            zbuf[lane, k + 1] = z_act
                            kk[lane] = k + 1
                            jj[lane] = 0
                            continue
                    if r < 0:  # take the chunk's next row, if any
                        if next_row >= hi:
                            row[lane] = -1
                            break
                        r = next_row
                        next_row += 1
                        row[lane] = r
                        for b in range(2):
                            pA[lane, b] = H[r, 4 * b]
                            pn[lane, b] = H[r, 4 * b + 1]
                            pbg[lane, b] = H[r, 4 * b + 2] + H[r, 4 * b + 3]
                            pbm[lane, b] = H[r, 4 * b + 2] - H[r, 4 * b + 3]
                            pzs[lane, b], prate[lane, b] = _attractor(H[r], b)
                        z_slot[lane, 0] = 0.0
                        z_slot[lane, 1] = 0.0
                        zbuf[lane, 0] = 0.0
                        kk[lane] = 0
                        jj[lane] = 0
                        continue
                    j = jj[lane]
                    dx = dxs[k, j]
                    z = z_slot[lane, slot[k, j]]
                    if dx == 0.0 or not np.isfinite(z):  # model._advance_z leaves z as it is
                        jj[lane] = j + 1
                        continue
                    dxl[lane] = dx
                    direction[lane] = 1.0 if dx > 0.0 else -1.0
                    zc[lane] = z
                    zarg[lane] = z
                    st = _SETUP
                    break
                b = branch[kk[lane], jj[lane]]
                A = pA[lane, b]
                n = pn[lane, b]
                bg = pbg[lane, b]
                bm = pbm[lane, b]
                zl = zarg[lane]
                finish_piece = False
                if st == _SETUP:  # model._advance_z up to the substep count
                    stiffness = prate[lane, b]
                    kfirst = A
                    if zl != 0.0:
                        c = bg if (zl > 0.0) == (direction[lane] > 0.0) else bm
                        kfirst = A - c * p
                        local = n * abs(c) * p / abs(zl)
                        if (n >= 1.0 or abs(zl) > pzs[lane, b]) and local > stiffness:
                            stiffness = local
                    work = stiffness * abs(dxl[lane])
                    if work > _STIFF_WORK:
                        bh[lane] = dxl[lane] / _IMPLICIT_SUBSTEPS
                        batt[lane] = direction[lane] * pzs[lane, b]
                        bdone[lane] = 0
                        st = _BE_START
                        continue  # its first power is this one: |z0|^n with z0 = zarg
                    k1[lane] = kfirst
                    m_sub[lane] = _substeps(work)
                    hstep[lane] = dxl[lane] / m_sub[lane]
                    i_sub[lane] = 0
                    zarg[lane] = zc[lane] + 0.5 * hstep[lane] * kfirst
                    st = _K2
                elif st == _K1 or st == _FALLBACK:
                    k1[lane] = _rate_from_pow(zl, p, direction[lane], A, bg, bm)
                    if st == _FALLBACK:
                        m_sub[lane] = _substeps(_STIFF_WORK)
                        hstep[lane] = dxl[lane] / m_sub[lane]
                        i_sub[lane] = 0
                    zarg[lane] = zc[lane] + 0.5 * hstep[lane] * k1[lane]
                    st = _K2
                elif st == _K2:
                    k2[lane] = _rate_from_pow(zl, p, direction[lane], A, bg, bm)
                    zarg[lane] = zc[lane] + 0.5 * hstep[lane] * k2[lane]
                    st = _K3
                elif st == _K3:
                    k3[lane] = _rate_from_pow(zl, p, direction[lane], A, bg, bm)
                    zarg[lane] = zc[lane] + hstep[lane] * k3[lane]
                    st = _K4
                elif st == _K4:
                    k4 = _rate_from_pow(zl, p, direction[lane], A, bg, bm)
                    h = hstep[lane]
                    z = zc[lane] + h * (k1[lane] + 2.0 * k2[lane] + 2.0 * k3[lane] + k4) / 6.0
                    zc[lane] = z
                    i_sub[lane] += 1
                    if not np.isfinite(z) or i_sub[lane] == m_sub[lane]:
                        finish_piece = True
                    else:
                        zarg[lane] = z
                        st = _K1
                else:  # _BE_START or _NEWTON: model._backward_euler from z0 = zc
                    z_new, st = _implicit_round(
                        st, zl, p, zc[lane], bh[lane], A, n, bg, bm, batt[lane], blo, bhi, bfhi, bit, lane
                    )
                    if st == _NEWTON:
                        zarg[lane] = z_new
                    elif np.isnan(z_new):  # no bracket: RK4 over what is left of the piece
                        dxl[lane] = bh[lane] * (_IMPLICIT_SUBSTEPS - bdone[lane])
                        zarg[lane] = zc[lane]
                        st = _FALLBACK
                    else:
                        zc[lane] = z_new
                        bdone[lane] += 1
                        if bdone[lane] == _IMPLICIT_SUBSTEPS:
                            finish_piece = True
                        else:
                            zarg[lane] = z_new
                            st = _BE_START
                if finish_piece:
                    z_slot[lane, slot[kk[lane], jj[lane]]] = zc[lane]
                    jj[lane] += 1
                    st = _PIECE
                    continue
                break
            state[lane] = st
            if row[lane] >= 0:
                pw_arg[lane] = abs(zarg[lane])
                pw_exp[lane] = pn[lane, branch[kk[lane], jj[lane]]]
                busy += 1


@numba.njit(cache=True, inline="always", error_model="numpy")
def _implicit_round(st, z, p, z0, h, A, n, bg, bm, z_att, blo, bhi, bfhi, bit, lane):
    """One ``pow`` worth of model._backward_euler: p = |z|^n at the start or a Newton iterate.

    Returns (z, _NEWTON) when the next iterate z needs its power, else (step result, _PIECE)
    with NaN for "no bracket", as the scalar function returns.
    """
    direction = 1.0 if h > 0.0 else -1.0
    if st == _BE_START:
        f_lo = -h * _rate_from_pow(z0, p, direction, A, bg, bm)
        f_hi = z_att - z0
        if f_lo == 0.0:
            return z0, _PIECE
        if f_lo * f_hi > 0.0:
            return np.nan, _PIECE
        blo[lane] = z0
        bhi[lane] = z_att
        bfhi[lane] = f_hi
        bit[lane] = 0
        return 0.5 * (z0 + z_att), _NEWTON
    lo = blo[lane]
    hi = bhi[lane]
    f = z - z0 - h * _rate_from_pow(z, p, direction, A, bg, bm)
    if f == 0.0:
        return z, _PIECE
    if (f > 0.0) == (bfhi[lane] > 0.0):
        hi = z
    else:
        lo = z
    blo[lane] = lo
    bhi[lane] = hi
    pz = p if z != 0.0 else 0.0
    c = bg if (z > 0.0) == (direction > 0.0) else bm
    dg = -c * n * pz / abs(z) if z != 0.0 else -np.inf
    df = 1.0 - h * dg
    z_new = z - f / df if np.isfinite(df) and df != 0.0 else 0.5 * (lo + hi)
    if not (min(lo, hi) < z_new < max(lo, hi)):
        z_new = 0.5 * (lo + hi)
    if abs(z_new - z) <= 1e-14 * (abs(z) + 1e-300):
        return z_new, _PIECE
    bit[lane] += 1
    if bit[lane] == _NEWTON_ITERATIONS:
        return z_new, _PIECE
    return z_new, _NEWTON


@numba.njit(cache=True, inline="always", error_model="numpy")
def _finish(mode, r, ok, z, Z, P, x, v, a, f_meas, fbuf, out):
    if mode == _MODE_Z:
        if ok:
            Z[r, :] = z
        else:
            Z[r, :] = np.inf
    elif ok and _force_from_z(P[r], x, v, a, z, fbuf):
        out[r] = _mse_of_force(fbuf, f_meas)
    else:
        out[r] = np.inf


@numba.njit(cache=True, error_model="numpy")
def _serial(H, pieces, K, mode, Z, P, x, v, a, f_meas, out):
    _run_chunk(H, 0, H.shape[0], pieces, K, mode, Z, P, x, v, a, f_meas, out)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _parallel(H, pieces, K, mode, Z, P, x, v, a, f_meas, out, n_chunks):
    m = H.shape[0]
    for c in numba.prange(n_chunks):
        _run_chunk(H, c * m // n_chunks, (c + 1) * m // n_chunks, pieces, K, mode, Z, P, x, v, a, f_meas, out)


def _run(H, t, x, v, split, mode, Z, P, a, f_meas, out):
    m = H.shape[0]
    K = min(LANES, m)
    pieces = _excitation_pieces(t, x, v, split)
    threads = numba.get_num_threads()
    if threads == 1 or m < 2 * K:
        _serial(H, pieces, K, mode, Z, P, x, v, a, f_meas, out)
        return
    # A few chunks per thread, handed out one at a time: rows differ in cost by 10x and more.
    n_chunks = min(4 * threads, m // K)
    with numba.parallel_chunksize(1):
        _parallel(H, pieces, K, mode, Z, P, x, v, a, f_meas, out, n_chunks)


def _check_length(x):
    if x.shape[0] == 0:
        raise ValueError("the excitation needs at least one sample")


def run_mse(P, t, x, v, a, f_meas, split):
    """The kernel behind ``model.mse_batch``: inputs already checked (contiguous float64)."""
    _check_length(x)
    out = np.empty(P.shape[0])
    if P.shape[0] == 1:  # nothing to interleave
        return model.mse_batch(P, t, x, v, a, f_meas, "split" if split else "shared", kernel="scalar")
    H = np.ascontiguousarray(P[:, list(model.HYSTERETIC_INDEX)])
    _run(H, t, x, v, split, _MODE_MSE, np.empty((0, 0)), P, a, f_meas, out)
    return out


def run_hysteretic(H, t, x, v, split):
    """The kernel behind ``model.hysteretic_state_batch``: inputs already checked."""
    _check_length(x)
    Z = np.empty((H.shape[0], x.shape[0]))
    _run(H, t, x, v, split, _MODE_Z, Z, np.empty((0, 0)), x, x, np.empty(0))
    return Z


def mse_batch_lockstep(P, t, x, v, a, f_meas, state: str = "shared") -> np.ndarray:
    """``model.mse_batch`` with the lockstep kernel: P (m, 14) → m MSEs (N²), +inf on blow-up."""
    return model.mse_batch(P, t, x, v, a, f_meas, state, kernel="lockstep")


def hysteretic_state_batch_lockstep(H, t, x, v, state: str = "shared") -> np.ndarray:
    """``model.hysteretic_state_batch`` with the lockstep kernel: H (m, 8) → Z (m, L), +inf rows on blow-up."""
    return model.hysteretic_state_batch(H, t, x, v, state, kernel="lockstep")
