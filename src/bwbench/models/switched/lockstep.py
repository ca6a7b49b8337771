"""Several parameter sets simulated together, interleaved so their powers |z|ⁿ run as vector code.

The scalar kernel (``bwbench.models.switched.kernel``) is latency-bound: each RK4 stage waits for a
power whose argument comes from the stage before (~20 ns, four per step), while the CPU can run
several independent ones in that time. Here a group of K rows (lanes; rows of similar stiffness)
walks the samples together. Per piece of a sample interval, each round computes every lane's
pending power in one loop, then the arithmetic: RK4 stages with per-lane substep counts (a lane
sits out the substeps it does not need), the stiff lanes' backward-Euler steps in the same rounds.
The power loop has no condition and calls ``power.power_inline`` (inlined arithmetic), which LLVM
vectorises: 8 lanes per AVX-512 instruction, ~2.5 ns per power against ~7 ns for libm's pow called
lane by lane (it was two thirds of this kernel's time). A lane that blows up stops and reports +inf;
the others go on.

Each lane performs exactly the scalar kernel's floating-point operations in the same order (the
excitation pieces come from the same helper, the force and MSE from the same functions, the power
from the same ``bwbench.models.power`` code, whose vector form gives the bits of its scalar calls),
so the results are bit-identical to ``switched_bouc_wen.mse_batch(..., kernel="scalar")``: no
fastmath, and no libm call whose vector version would differ from the scalar one (as SVML's would).
"""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.power import power, power_inline
from bwbench.models.switched import kernel
from bwbench.models.switched.kernel import (
    AT_ATTRACTOR,
    IMPLICIT_SUBSTEPS,
    RK4_MAX_SUBSTEPS,
    RK4_STIFFNESS_PER_SUBSTEP,
    force_from_z,
    mse_of_force,
    newton_done,
    rk4_substeps,
    takes_implicit,
)
from bwbench.models.switched.lockstep_inputs import excitation_pieces, load_rows

LANES = 16  # rows per group; on AMD EPYC (Zen 4), one core: 4 is ~15% slower, 8 ~3%, 24 the same
SCALAR_WORK = 32.0  # stiffness × longest dx above which a row runs in the scalar kernel (``_run``)

_STIFF_WORK = RK4_STIFFNESS_PER_SUBSTEP * RK4_MAX_SUBSTEPS  # as in kernel._advance_z
_NEWTON_ITERATIONS = 60  # as in kernel.backward_euler
_BE_START, _NEWTON, _DONE = 0, 1, 2  # a lane's backward-Euler state: pending power
_MODE_Z, _MODE_MSE = 0, 1  # what a group writes: z rows, or MSEs


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rate_from_pow(z, p, direction, A, beta_plus_gamma, beta_minus_gamma):
    """kernel._rate with p = |z|^n already computed (ignored at z = 0, as there)."""
    if z == 0.0:
        return A
    if (z > 0.0) == (direction > 0.0):
        return A - beta_plus_gamma * p
    return A - beta_minus_gamma * p


@numba.njit(cache=True, inline="always", error_model="numpy")
def _work(z, p, dx, direction, n, bg, bm, z_s, attractor_rate):
    """kernel._advance_z's stiffness·|dx| at the start of a piece, p = |z|^n."""
    stiffness = attractor_rate
    if z != 0.0:
        c = bg if (z > 0.0) == (direction > 0.0) else bm
        local = n * abs(c) * p / abs(z)
        if (n >= 1.0 or abs(z) > z_s) and local > stiffness:
            stiffness = local
    return stiffness * abs(dx)


@numba.njit(cache=True, error_model="numpy")
def _run_group(H, rows, dxs, branch, slot, active, mode, Z, P, x, v, a, f_meas, out, zbuf, fbuf):
    """Rows ``rows`` of H (m, 8), one per lane, through all samples together (output: _finish);
    ``zbuf`` (L, ≥ K) and ``fbuf`` (L) are scratch."""
    # Everything per sample stays inside this function and its scalar-only helpers: numba
    # reference-counts the arrays passed to a call with atomic instructions, which are full
    # barriers on x86 and would serialise the lanes again.
    K = rows.shape[0]
    pA, pn, pbg, pbm, pzs, prate = load_rows(H, rows)  # [branch, lane]
    zbuf[0, :K] = 0.0
    z_slot = np.zeros((2, K))  # z₊ (or the shared z) and z₋
    alive = np.ones(K, dtype=np.bool_)
    n_alive = K
    # Per lane within a piece: substeps (0: z left as is, -1: backward Euler), the z a substep
    # starts from, the pending power's argument, RK4 step and stages; backward-Euler state; the
    # current branch's parameters, contiguous, copied when the branch changes.
    msub, bstate, bdone, bit = np.zeros((4, K), dtype=np.int64)
    zc, zarg, pw, hs, k1, k2, k3, batt, blo, bhi, bfhi, cA, cn, cbg, cbm = np.zeros((15, K))
    b_loaded = -1
    for k in range(x.shape[0] - 1):
        for j in range(2):
            dx = dxs[k, j]
            if dx == 0.0:  # kernel._advance_z leaves z as it is
                continue
            b = branch[k, j]
            s = slot[k, j]
            if b != b_loaded:
                cA[:] = pA[b]
                cn[:] = pn[b]
                cbg[:] = pbg[b]
                cbm[:] = pbm[b]
                b_loaded = b
            direction = 1.0 if dx > 0.0 else -1.0
            # Each stage is a loop of bare powers, then a loop of the arithmetic around them. The
            # power loop has no condition: every lane computes one (an idle lane's is not read), so
            # LLVM turns the loop into vector instructions (``power_inline`` is plain inlined arithmetic).
            for lane in range(K):
                z = z_slot[s, lane]
                zc[lane] = z
                msub[lane] = 1 if alive[lane] and np.isfinite(z) else 0
            for lane in range(K):
                pw[lane] = power_inline(abs(zc[lane]), cn[lane])
            max_m = 0
            n_implicit = 0
            for lane in range(K):  # first stage, whose |z|^n also gives the substep count
                if not msub[lane]:
                    continue
                z = zc[lane]
                p = pw[lane]
                work = _work(z, p, dx, direction, cn[lane], cbg[lane], cbm[lane], pzs[b, lane], prate[b, lane])
                if takes_implicit(work, z, direction, pzs[b, lane]):
                    msub[lane] = -1
                    zarg[lane] = z
                    bstate[lane] = _BE_START
                    bdone[lane] = 0
                    batt[lane] = direction * pzs[b, lane]
                    n_implicit += 1
                    continue
                m = rk4_substeps(work)
                msub[lane] = m
                max_m = max(max_m, m)
                hs[lane] = dx / m
                kq = _rate_from_pow(z, p, direction, cA[lane], cbg[lane], cbm[lane])
                k1[lane] = kq
                zarg[lane] = z + 0.5 * hs[lane] * kq
            bh = dx / IMPLICIT_SUBSTEPS
            # Rounds: every pending power (an RK4 stage, or a backward-Euler lane's next one) in
            # one loop, then the arithmetic. RK4 lanes share the substep i and stage q (a lane
            # sits out the substeps it does not need); stage 1 comes first, the setup made k1.
            i = 0
            q = 1
            while i < max_m or n_implicit > 0:
                for lane in range(K):  # unconditional, to be vectorised (see above)
                    pw[lane] = power_inline(abs(zarg[lane]), cn[lane])
                if n_implicit > 0:
                    for lane in range(K):
                        if msub[lane] != -1 or bstate[lane] == _DONE:
                            continue
                        z_new, st, blo[lane], bhi[lane], bfhi[lane], bit[lane] = _implicit_round(
                            bstate[lane],
                            zarg[lane],
                            pw[lane],
                            zc[lane],
                            bh,
                            cA[lane],
                            cn[lane],
                            cbg[lane],
                            cbm[lane],
                            batt[lane],
                            blo[lane],
                            bhi[lane],
                            bfhi[lane],
                            bit[lane],
                        )
                        if st == _NEWTON:
                            zarg[lane] = z_new
                            bstate[lane] = _NEWTON
                            continue
                        if np.isnan(z_new):  # no bracket: not stiff after all; RK4 over what is left
                            z_new = _rk_fallback(
                                zc[lane],
                                bh * (IMPLICIT_SUBSTEPS - bdone[lane]),
                                direction,
                                cA[lane],
                                cn[lane],
                                cbg[lane],
                                cbm[lane],
                            )
                            bdone[lane] = IMPLICIT_SUBSTEPS
                        elif z_new == zc[lane] and z_new != 0.0:  # a fixed point: kernel._advance_z stops
                            bdone[lane] = IMPLICIT_SUBSTEPS
                        else:
                            bdone[lane] += 1
                        zc[lane] = z_new
                        zarg[lane] = z_new
                        bstate[lane] = _BE_START
                        if bdone[lane] == IMPLICIT_SUBSTEPS:
                            bstate[lane] = _DONE
                            n_implicit -= 1
                            z_slot[s, lane] = z_new
                if i >= max_m:
                    continue
                if q == 0:
                    for lane in range(K):
                        if msub[lane] > i:
                            kq = _rate_from_pow(zc[lane], pw[lane], direction, cA[lane], cbg[lane], cbm[lane])
                            k1[lane] = kq
                            zarg[lane] = zc[lane] + 0.5 * hs[lane] * kq
                elif q == 1:
                    for lane in range(K):
                        if msub[lane] > i:
                            kq = _rate_from_pow(zarg[lane], pw[lane], direction, cA[lane], cbg[lane], cbm[lane])
                            k2[lane] = kq
                            zarg[lane] = zc[lane] + 0.5 * hs[lane] * kq
                elif q == 2:
                    for lane in range(K):
                        if msub[lane] > i:
                            kq = _rate_from_pow(zarg[lane], pw[lane], direction, cA[lane], cbg[lane], cbm[lane])
                            k3[lane] = kq
                            zarg[lane] = zc[lane] + hs[lane] * kq
                else:
                    for lane in range(K):
                        if msub[lane] > i:
                            kq = _rate_from_pow(zarg[lane], pw[lane], direction, cA[lane], cbg[lane], cbm[lane])
                            h = hs[lane]
                            z = zc[lane] + h * (k1[lane] + 2.0 * k2[lane] + 2.0 * k3[lane] + kq) / 6.0
                            zc[lane] = z
                            zarg[lane] = z
                            if not np.isfinite(z):
                                msub[lane] = i + 1  # no further substeps, as in the scalar kernel
                            if msub[lane] == i + 1:
                                z_slot[s, lane] = z
                q += 1
                if q == 4:
                    q = 0
                    i += 1
        sa = active[k]
        for lane in range(K):
            if alive[lane]:
                z = z_slot[sa, lane]
                if np.isfinite(z):
                    zbuf[k + 1, lane] = z  # sample-major: one contiguous store per sample
                else:
                    alive[lane] = False
                    n_alive -= 1
        if n_alive == 0:
            break
    z_row = np.empty(x.shape[0])
    for lane in range(K):
        if alive[lane]:
            z_row[:] = zbuf[:, lane]
        _finish(mode, rows[lane], alive[lane], z_row, Z, P, x, v, a, f_meas, fbuf, out)


@numba.njit(cache=True, error_model="numpy")
def _implicit_round(st, z, p, z0, h, A, n, bg, bm, z_att, lo, hi, f_hi, it):
    """One power's worth of kernel.backward_euler: p = |z|^n at z = z0 (start) or an iterate.

    Returns (z, _NEWTON, bracket lo, hi, f(hi), iterations) when iterate z needs its power next,
    else (step result, -1, ...), the result being NaN for "no bracket" as in the scalar function.
    """
    direction = 1.0 if h > 0.0 else -1.0
    if st == _BE_START:
        f_lo = -h * _rate_from_pow(z0, p, direction, A, bg, bm)
        f_hi = z_att - z0
        if f_lo == 0.0 or abs(f_hi) <= AT_ATTRACTOR * abs(z_att):  # on the attractor, as there
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
    dg = -c * n * pz / z if z != 0.0 else -np.inf
    df = 1.0 - h * dg
    z_new = z - f / df if np.isfinite(df) and df != 0.0 else 0.5 * (lo + hi)
    if newton_done(z, z_new, lo, hi):
        return z_new, -1, lo, hi, f_hi, it + 1
    if not (min(lo, hi) < z_new < max(lo, hi)):
        z_new = 0.5 * (lo + hi)
    if abs(z_new - z) <= 1e-14 * (abs(z) + 1e-300) or it + 1 == _NEWTON_ITERATIONS:
        return z_new, -1, lo, hi, f_hi, it + 1
    return z_new, _NEWTON, lo, hi, f_hi, it + 1


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rate_of(z, n, direction, A, bg, bm):
    return _rate_from_pow(z, power(abs(z), n), direction, A, bg, bm)


@numba.njit(cache=True, error_model="numpy")
def _rk_fallback(z, dx, direction, A, n, bg, bm):
    """The RK4 with which kernel._advance_z finishes a piece after a bracket-less implicit step."""
    m = rk4_substeps(_STIFF_WORK)
    h = dx / m
    for _ in range(m):
        k1 = _rate_of(z, n, direction, A, bg, bm)
        k2 = _rate_of(z + 0.5 * h * k1, n, direction, A, bg, bm)
        k3 = _rate_of(z + 0.5 * h * k2, n, direction, A, bg, bm)
        k4 = _rate_of(z + h * k3, n, direction, A, bg, bm)
        z = z + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        if not np.isfinite(z):
            return z
    return z


@numba.njit(cache=True, error_model="numpy")
def _finish(mode, r, ok, z, Z, P, x, v, a, f_meas, fbuf, out):
    """_MODE_Z: row r of Z is z (+inf if not ok); _MODE_MSE: out[r] is the MSE of P[r] (+inf)."""
    if mode == _MODE_Z:
        Z[r, :] = np.inf
        if ok:
            Z[r, :] = z
    elif ok and force_from_z(P[r], x, v, a, z, fbuf):
        out[r] = mse_of_force(fbuf, f_meas)
    else:
        out[r] = np.inf


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _serial(H, order, K, dxs, branch, slot, active, mode, Z, P, x, v, a, f_meas, out):
    zbuf = np.empty((x.shape[0], K))
    fbuf = np.empty(x.shape[0])
    for lo in range(0, order.shape[0], K):
        _run_group(H, order[lo : lo + K], dxs, branch, slot, active, mode, Z, P, x, v, a, f_meas, out, zbuf, fbuf)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _parallel(H, order, K, dxs, branch, slot, active, mode, Z, P, x, v, a, f_meas, out):
    n_groups = (order.shape[0] + K - 1) // K
    for g in numba.prange(n_groups):
        rows = order[g * K : (g + 1) * K]
        zbuf = np.empty((x.shape[0], K))
        fbuf = np.empty(x.shape[0])
        _run_group(H, rows, dxs, branch, slot, active, mode, Z, P, x, v, a, f_meas, out, zbuf, fbuf)


def _stiffness_key(H):
    """Larger for stiffer rows: the largest loading-attractor relaxation rate n·A/z_s (1/mm)."""
    A, n, beta_plus_gamma = H[:, [0, 4]], H[:, [1, 5]], H[:, [2, 6]] + H[:, [3, 7]]
    with np.errstate(all="ignore"):
        key = np.max(n * A / (A / beta_plus_gamma) ** (1.0 / n), axis=1)  # NaN if either is NaN
    return np.where(np.isnan(key), np.inf, key)


def _run(H, t, x, v, split, mode, Z, P, a, f_meas, out):
    m = H.shape[0]
    if x.shape[0] == 0:
        raise ValueError("the excitation needs at least one sample")
    if m == 0:
        return
    K = -(-m // -(-m // LANES))  # at most LANES rows per group, the groups as even as can be
    # One array type for every call (read-only inputs copied): one compilation of the kernel.
    t, x, v, a, f_meas = (np.require(arr, np.float64, ["C", "W"]) for arr in (t, x, v, a, f_meas))
    pieces = excitation_pieces(t, x, v, split)
    # Rows of similar stiffness side by side, so that lanes needing many substeps or backward
    # Euler share a group and overlap their powers too (each row's result is independent of it).
    key = _stiffness_key(H)
    order = np.argsort(key, kind="stable")
    if numba.get_num_threads() == 1 or m < 2 * K:
        # Rows stiff enough for the attractor's rate alone to ask for this many RK4 substeps on the
        # record's longest sample interval go to the scalar kernel (the same bits): there the lanes of a
        # group differ in substeps and backward-Euler iterations from piece to piece, each round waits for
        # its slowest lane, and the lockstep would take longer than the scalar kernel on such groups.
        work = key * (float(np.max(np.abs(np.diff(x)))) if x.shape[0] > 1 else 0.0)
        stiff = work[order] > SCALAR_WORK
        if stiff.any():
            rows = np.sort(order[stiff])
            if mode == _MODE_MSE:
                out[rows] = kernel.mse_serial(np.ascontiguousarray(P[rows]), t, x, v, a, f_meas, split)
            else:
                Z[rows] = kernel.hysteretic_batch_scalar(np.ascontiguousarray(H[rows]), t, x, v, split)
            order = order[~stiff]
        if order.shape[0]:
            K = -(-order.shape[0] // -(-order.shape[0] // LANES))
            _serial(H, order, K, *pieces, mode, Z, P, x, v, a, f_meas, out)
        return
    with numba.parallel_chunksize(1):  # groups differ in cost by 10x and more: hand them out one by one
        _parallel(H, order, K, *pieces, mode, Z, P, x, v, a, f_meas, out)


def run_mse(P, t, x, v, a, f_meas, split):
    """The kernel behind ``switched_bouc_wen.mse_batch``: inputs already checked (contiguous float64)."""
    if P.shape[0] == 1 and x.shape[0] > 0:  # nothing to interleave
        return kernel.mse_serial(P, t, x, v, a, f_meas, split)
    out = np.empty(P.shape[0])
    H = np.ascontiguousarray(P[:, list(kernel.HYSTERETIC_INDEX)])
    _run(H, t, x, v, split, _MODE_MSE, np.empty((0, 0)), P, a, f_meas, out)
    return out


def run_hysteretic(H, t, x, v, split):
    """The kernel behind ``switched_bouc_wen.hysteretic_state_batch``: inputs already checked."""
    if H.shape[0] == 1 and x.shape[0] > 0:  # nothing to interleave
        return kernel.hysteretic_batch_scalar(H, t, x, v, split)
    Z = np.empty((H.shape[0], x.shape[0]))
    _run(H, t, x, v, split, _MODE_Z, Z, np.empty((0, 0)), x, x, np.empty(0))
    return Z
