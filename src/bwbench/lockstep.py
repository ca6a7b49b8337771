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

LANES = 4  # measured on AMD EPYC (Zen 4), one core

_STIFF_WORK = _RK4_STIFFNESS_PER_SUBSTEP * _RK4_MAX_SUBSTEPS  # as in model._advance_z
_NEWTON_ITERATIONS = 60  # as in model._backward_euler

# Lane modes. A round is four phases; an RK4 lane computes stage q's power in phase q, so the
# common path has no dispatch. A backward-Euler lane takes one power per phase. A lane whose piece
# ended is given its next piece (or row) after phase 3 and starts it in the next phase 0.
_RK, _IMPLICIT, _WAIT, _NEXT, _IDLE = range(5)
_BE_START, _NEWTON = 0, 1  # backward-Euler step: |z0|^n pending, or |z|^n at a Newton iterate

# Float fields of a lane, S[lane, field]: the piece's z, dx, direction, RK4 step and stages, the
# pending power's argument, the branch's A, n, β+γ, β−γ, z_s, n·A/z_s, backward-Euler step h,
# attractor, bracket and f(hi).
(_ZC, _DX, _DIR, _H, _K1, _K2, _K3, _ZARG, _A, _N, _BG, _BM, _ZS, _RATE,
 _BH, _BATT, _BLO, _BHI, _BFHI, _N_FLOAT) = range(20)
_N_BRANCH_FIELDS = 6  # _A.._RATE, copied from the row's branch at the start of a piece
# Integer fields, I[lane, field]: row, interval k, piece j, mode, fresh piece, substeps and
# substep, backward-Euler state, steps done, Newton iterations.
_ROW, _KK, _JJ, _MODE, _FRESH, _M, _I, _BSTATE, _BDONE, _BIT, _N_INT = range(11)

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
def _run_chunk(H, lo, hi, dxs, branch, slot, active, K, mode, Z, P, x, v, a, f_meas, out):
    """Rows lo..hi-1 of ``H`` (m, 8) through K lanes.

    mode _MODE_Z writes each row's z into ``Z`` (+inf rows on blow-up); _MODE_MSE writes the MSE
    of row r of ``P`` against ``f_meas`` into ``out[r]`` (+inf on blow-up).
    """
    # Everything per sample stays in this one function, with scalar-only helpers: numba
    # reference-counts the arrays passed to a call with atomic instructions, which are full
    # barriers on x86 and would serialise the lanes again.
    n_samples = x.shape[0]
    zbuf = np.empty((K, n_samples))
    fbuf = np.empty(n_samples)
    S = np.zeros((K, _N_FLOAT))
    I = np.zeros((K, _N_INT), dtype=np.int64)
    I[:, _ROW] = -1
    I[:, _MODE] = _NEXT
    branch_params = np.empty((K, 2, _N_BRANCH_FIELDS))
    z_slot = np.zeros((K, 2))
    next_row = lo
    while True:
        busy = False
        for lane in range(K):
            if I[lane, _MODE] != _NEXT:
                busy = busy or I[lane, _MODE] != _IDLE
                continue
            # Store the piece just integrated, then set up the lane's next piece, taking the
            # next row (or going idle) when its row is done or blew up.
            r = I[lane, _ROW]
            k = I[lane, _KK]
            j = I[lane, _JJ]
            if r >= 0:
                z_slot[lane, slot[k, j]] = S[lane, _ZC]
                j += 1
            while True:
                if r < 0:
                    if next_row >= hi:
                        I[lane, _MODE] = _IDLE
                        break
                    r = next_row
                    next_row += 1
                    _load_row(H, r, branch_params[lane])
                    z_slot[lane, 0] = 0.0
                    z_slot[lane, 1] = 0.0
                    zbuf[lane, 0] = 0.0
                    k = 0
                    j = 0
                if k == n_samples - 1:
                    _finish(mode, r, True, zbuf[lane], Z, P, x, v, a, f_meas, fbuf, out)
                    r = -1
                    continue
                if j == 2:  # interval done: report the active z
                    z_act = z_slot[lane, active[k]]
                    if not np.isfinite(z_act):
                        _finish(mode, r, False, zbuf[lane], Z, P, x, v, a, f_meas, fbuf, out)
                        r = -1
                        continue
                    zbuf[lane, k + 1] = z_act
                    k += 1
                    j = 0
                    continue
                dx = dxs[k, j]
                z = z_slot[lane, slot[k, j]]
                if dx == 0.0 or not np.isfinite(z):  # model._advance_z leaves z as it is
                    j += 1
                    continue
                b = branch[k, j]
                for f in range(_N_BRANCH_FIELDS):
                    S[lane, _A + f] = branch_params[lane, b, f]
                S[lane, _ZC] = z
                S[lane, _DX] = dx
                S[lane, _DIR] = 1.0 if dx > 0.0 else -1.0
                I[lane, _FRESH] = 1
                I[lane, _MODE] = _WAIT
                busy = True
                break
            I[lane, _ROW] = r
            I[lane, _KK] = k
            I[lane, _JJ] = j
        if not busy:
            return
        for phase in range(4):
            for lane in range(K):
                md = I[lane, _MODE]
                if phase == 0 and md == _WAIT:
                    md = _RK
                    I[lane, _MODE] = _RK
                if md == _RK:
                    za = S[lane, _ZC] if phase == 0 else S[lane, _ZARG]
                    p = math.pow(abs(za), S[lane, _N])
                    A = S[lane, _A]
                    kq = _rate_from_pow(za, p, S[lane, _DIR], A, S[lane, _BG], S[lane, _BM])
                    if phase == 0:
                        if I[lane, _FRESH]:  # model._advance_z up to the substep count
                            I[lane, _FRESH] = 0
                            dx = S[lane, _DX]
                            work = _work(za, p, dx, S[lane, _DIR], S[lane, _N], S[lane, _BG], S[lane, _BM],
                                         S[lane, _ZS], S[lane, _RATE])
                            if work > _STIFF_WORK:  # backward Euler from the next phase on
                                S[lane, _BH] = dx / _IMPLICIT_SUBSTEPS
                                S[lane, _BATT] = S[lane, _DIR] * S[lane, _ZS]
                                S[lane, _ZARG] = za
                                I[lane, _BDONE] = 0
                                I[lane, _BSTATE] = _BE_START
                                I[lane, _MODE] = _IMPLICIT
                                continue
                            m = _substeps(work)
                            I[lane, _M] = m
                            I[lane, _I] = 0
                            S[lane, _H] = dx / m
                        S[lane, _K1] = kq
                        S[lane, _ZARG] = za + 0.5 * S[lane, _H] * kq
                    elif phase == 1:
                        S[lane, _K2] = kq
                        S[lane, _ZARG] = S[lane, _ZC] + 0.5 * S[lane, _H] * kq
                    elif phase == 2:
                        S[lane, _K3] = kq
                        S[lane, _ZARG] = S[lane, _ZC] + S[lane, _H] * kq
                    else:
                        h = S[lane, _H]
                        z = S[lane, _ZC] + h * (S[lane, _K1] + 2.0 * S[lane, _K2] + 2.0 * S[lane, _K3] + kq) / 6.0
                        S[lane, _ZC] = z
                        I[lane, _I] += 1
                        if not np.isfinite(z) or I[lane, _I] == I[lane, _M]:
                            I[lane, _MODE] = _NEXT
                elif md == _IMPLICIT:
                    zl = S[lane, _ZARG]
                    p = math.pow(abs(zl), S[lane, _N])
                    z_new, st, blo, bhi, bfhi, bit = _implicit_round(
                        I[lane, _BSTATE], zl, p, S[lane, _ZC], S[lane, _BH], S[lane, _A], S[lane, _N],
                        S[lane, _BG], S[lane, _BM], S[lane, _BATT], S[lane, _BLO], S[lane, _BHI],
                        S[lane, _BFHI], I[lane, _BIT])
                    S[lane, _BLO] = blo
                    S[lane, _BHI] = bhi
                    S[lane, _BFHI] = bfhi
                    I[lane, _BIT] = bit
                    if st == _NEWTON:
                        S[lane, _ZARG] = z_new
                        I[lane, _BSTATE] = _NEWTON
                    elif np.isnan(z_new):  # no bracket: RK4 over what is left, from the next phase 0
                        dx = S[lane, _BH] * (_IMPLICIT_SUBSTEPS - I[lane, _BDONE])
                        m = _substeps(_STIFF_WORK)
                        S[lane, _DX] = dx
                        S[lane, _H] = dx / m
                        I[lane, _M] = m
                        I[lane, _I] = 0
                        I[lane, _FRESH] = 0
                        I[lane, _MODE] = _WAIT
                    else:
                        S[lane, _ZC] = z_new
                        I[lane, _BDONE] += 1
                        if I[lane, _BDONE] == _IMPLICIT_SUBSTEPS:
                            I[lane, _MODE] = _NEXT
                        else:
                            S[lane, _ZARG] = z_new
                            I[lane, _BSTATE] = _BE_START


@numba.njit(cache=True, inline="always", error_model="numpy")
def _work(z, p, dx, direction, n, bg, bm, z_s, attractor_rate):
    """model._advance_z's stiffness·|dx| at the start of a piece, p = |z|^n."""
    stiffness = attractor_rate
    if z != 0.0:
        c = bg if (z > 0.0) == (direction > 0.0) else bm
        local = n * abs(c) * p / abs(z)
        if (n >= 1.0 or abs(z) > z_s) and local > stiffness:
            stiffness = local
    return stiffness * abs(dx)


@numba.njit(cache=True, error_model="numpy")
def _load_row(H, r, params):
    """Branch parameters of row r into params[branch, :] = A, n, β+γ, β−γ, z_s, n·A/z_s."""
    for b in range(2):
        params[b, 0] = H[r, 4 * b]
        params[b, 1] = H[r, 4 * b + 1]
        params[b, 2] = H[r, 4 * b + 2] + H[r, 4 * b + 3]
        params[b, 3] = H[r, 4 * b + 2] - H[r, 4 * b + 3]
        params[b, 4], params[b, 5] = _attractor(H[r], b)


@numba.njit(cache=True, error_model="numpy")
def _implicit_round(st, z, p, z0, h, A, n, bg, bm, z_att, lo, hi, f_hi, it):
    """One power's worth of model._backward_euler: p = |z|^n at z = z0 (start) or an iterate.

    Returns (z, _NEWTON, bracket lo, hi, f(hi), iterations) when iterate z needs its power next,
    else (step result, -1, ...), the result being NaN for "no bracket" as in the scalar function.
    """
    direction = 1.0 if h > 0.0 else -1.0
    if st == _BE_START:
        f_lo = -h * _rate_from_pow(z0, p, direction, A, bg, bm)
        f_hi = z_att - z0
        if f_lo == 0.0:
            return z0, -1, lo, hi, f_hi, it
        if f_lo * f_hi > 0.0:
            return np.nan, -1, lo, hi, f_hi, it
        return 0.5 * (z0 + z_att), _NEWTON, z0, z_att, f_hi, 0
    f = z - z0 - h * _rate_from_pow(z, p, direction, A, bg, bm)
    if f == 0.0:
        return z, -1, lo, hi, f_hi, it
    if (f > 0.0) == (f_hi > 0.0):
        hi = z
    else:
        lo = z
    # Newton where the derivative is usable, bisection otherwise (as in the scalar function).
    pz = p if z != 0.0 else 0.0
    c = bg if (z > 0.0) == (direction > 0.0) else bm
    dg = -c * n * pz / abs(z) if z != 0.0 else -np.inf
    df = 1.0 - h * dg
    z_new = z - f / df if np.isfinite(df) and df != 0.0 else 0.5 * (lo + hi)
    if not (min(lo, hi) < z_new < max(lo, hi)):
        z_new = 0.5 * (lo + hi)
    if abs(z_new - z) <= 1e-14 * (abs(z) + 1e-300) or it + 1 == _NEWTON_ITERATIONS:
        return z_new, -1, lo, hi, f_hi, it + 1
    return z_new, _NEWTON, lo, hi, f_hi, it + 1


@numba.njit(cache=True, error_model="numpy")
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
def _serial(H, dxs, branch, slot, active, K, mode, Z, P, x, v, a, f_meas, out):
    _run_chunk(H, 0, H.shape[0], dxs, branch, slot, active, K, mode, Z, P, x, v, a, f_meas, out)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _parallel(H, dxs, branch, slot, active, K, mode, Z, P, x, v, a, f_meas, out, n_chunks):
    m = H.shape[0]
    for c in numba.prange(n_chunks):
        lo, hi = c * m // n_chunks, (c + 1) * m // n_chunks
        _run_chunk(H, lo, hi, dxs, branch, slot, active, K, mode, Z, P, x, v, a, f_meas, out)


def _run(H, t, x, v, split, mode, Z, P, a, f_meas, out):
    m = H.shape[0]
    K = min(LANES, m)
    pieces = _excitation_pieces(t, x, v, split)
    threads = numba.get_num_threads()
    if threads == 1 or m < 2 * K:
        _serial(H, *pieces, K, mode, Z, P, x, v, a, f_meas, out)
        return
    # A few chunks per thread, handed out one at a time: rows differ in cost by 10x and more.
    n_chunks = min(4 * threads, m // K)
    with numba.parallel_chunksize(1):
        _parallel(H, *pieces, K, mode, Z, P, x, v, a, f_meas, out, n_chunks)


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
