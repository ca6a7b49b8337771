"""Spencer's model with its forward sensitivities: ẏ and ∂ẏ/∂θ at the samples, for exact Jacobians.

The state (y, w) of ``spencer_kernel`` and its derivatives S_y = ∂y/∂θ, S_w = ∂w/∂θ for the six
identifiable parameters θ = (x_y, n, η, v_y, r₀, κ₀) are integrated together, by the same
Dormand–Prince 5(4) steps under the same step control (the error is measured on (y, w) only, so the
steps are those of the plain simulation and ẏ is the same numbers):

    Ṡ_y = ∂ẏ/∂y·S_y + ∂ẏ/∂w·S_w + ∂ẏ/∂θ,   Ṡ_w = ∂ẇ/∂y·S_y + ∂ẇ/∂w·S_w + ∂ẇ/∂θ,

from S = 0 at the first state (rest, or the pre-roll's start: the state after the pre-roll carries
its S). ∂ẏ/∂θ at a sample is then ∂ẏ/∂y·S_y + ∂ẏ/∂w·S_w + ∂ẏ/∂θ. The switch between loading and
unloading (c = 1 or η) is a kink of the rates, differentiated on either side (it is crossed at
isolated instants). An interval that would need the backward-Euler fallback of ``spencer_kernel``
(a stiff corner) gives no sensitivities (``STATUS_NO_SENSITIVITY``): the caller takes differences.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bwbench.models.spencer_kernel import (
    _A,
    _C,
    _E,
    _MAX_STEPS,
    _TOL,
    STATUS_BLOW_UP,
    STATUS_OK,
    STATUS_STEP_BUDGET,
    STEPS_PER_SAMPLE,
    _excitation,
    preroll_end,
)

STATUS_NO_SENSITIVITY = 3
_XY, _N, _ETA, _VY, _R0, _K0 = range(6)
_D = 6


@numba.njit(cache=True, error_model="numpy")
def _rates_sens(y, w, Sy, Sw, x, xd, p, dSy, dSw):
    """(ẏ, ẇ) at (y, w), and into dSy, dSw the rates of the sensitivities S_y, S_w (each (6,))."""
    s = 1.0 + p[_R0]
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) / s
    u = xd - yd
    loading = w * u > 0.0
    c = 1.0 if loading else p[_ETA]
    aw = abs(w)
    # |w|^n through ln|w|, which its derivatives need anyway: ∂|w|^n/∂w = n·|w|^n/w and
    # ∂|w|^n/∂n = |w|^n·ln|w| (both 0 at w = 0: n ≥ 1 in every box).
    if w != 0.0:
        lw = math.log(aw)
        pw = math.exp(p[_N] * lw)
        dpw_dw = p[_N] * pw / w
        dpw_dn = pw * lw
    else:
        pw = 0.0
        dpw_dw = 0.0
        dpw_dn = 0.0
    sat = 1.0 - c * pw
    wd = u / p[_XY] * sat
    dyd_dy = -p[_K0] / s
    dyd_dw = p[_VY] / s
    # Total derivatives: the state's part for every θ_j, then the explicit ∂/∂θ_j of the few that have one.
    inv_xy = 1.0 / p[_XY]
    for j in range(_D):
        dyd = dyd_dy * Sy[j] + dyd_dw * Sw[j]
        dSy[j] = dyd
        dSw[j] = (-dyd * sat - u * c * dpw_dw * Sw[j]) * inv_xy
    for j, extra in ((_VY, w / s), (_R0, u / s), (_K0, (x - y) / s)):
        dSy[j] += extra
        dSw[j] -= extra * sat * inv_xy
    dSw[_N] -= u * c * dpw_dn * inv_xy
    if not loading:
        dSw[_ETA] -= u * pw * inv_xy
    dSw[_XY] -= wd * inv_xy
    return yd, wd


@numba.njit(cache=True, error_model="numpy")
def _ydot_sens_at(y, w, Sy, Sw, x, xd, p, out_S):
    """ẏ at a sample, and its total derivative ∂ẏ/∂θ into out_S (6,)."""
    dSw = np.empty(_D)
    yd, _ = _rates_sens(y, w, Sy, Sw, x, xd, p, out_S, dSw)
    return yd


@numba.njit(cache=True, error_model="numpy")
def _interval_sens(y, w, Sy, Sw, t0, t1, x0, v0, v1, a0, a1, p, h, y_scale, allowance, ky, kw, kSy, kSw, Sy_stage,
                   Sw_stage):
    """``spencer_kernel._interval`` with the sensitivities (Sy, Sw updated in place). Returns
    (y, w, h, steps, status); status STATUS_NO_SENSITIVITY where the plain kernel would switch to
    backward Euler, STATUS_STEP_BUDGET past ``allowance`` steps, STATUS_BLOW_UP on a state that is
    not finite."""
    span = t1 - t0
    s = 0.0
    x, xd = _excitation(0.0, span, x0, v0, v1, a0, a1)
    ky[0], kw[0] = _rates_sens(y, w, Sy, Sw, x, xd, p, kSy[0], kSw[0])
    steps = 0
    while s < span:
        if steps >= _MAX_STEPS:
            return np.nan, np.nan, h, steps, STATUS_NO_SENSITIVITY
        if steps >= allowance:
            return np.nan, np.nan, h, steps, STATUS_STEP_BUDGET
        steps += 1
        h = min(h, span - s)
        for j in range(1, 7):
            dy = 0.0
            dw = 0.0
            for q in range(_D):
                Sy_stage[q] = 0.0
                Sw_stage[q] = 0.0
            for m in range(j):
                dy += _A[j, m] * ky[m]
                dw += _A[j, m] * kw[m]
                for q in range(_D):
                    Sy_stage[q] += _A[j, m] * kSy[m, q]
                    Sw_stage[q] += _A[j, m] * kSw[m, q]
            for q in range(_D):
                Sy_stage[q] = Sy[q] + h * Sy_stage[q]
                Sw_stage[q] = Sw[q] + h * Sw_stage[q]
            x, xd = _excitation((s + _C[j] * h) / span, span, x0, v0, v1, a0, a1)
            ky[j], kw[j] = _rates_sens(y + h * dy, w + h * dw, Sy_stage, Sw_stage, x, xd, p, kSy[j], kSw[j])
        y_new = y + h * (_A[6, 0] * ky[0] + _A[6, 2] * ky[2] + _A[6, 3] * ky[3] + _A[6, 4] * ky[4] + _A[6, 5] * ky[5])
        w_new = w + h * (_A[6, 0] * kw[0] + _A[6, 2] * kw[2] + _A[6, 3] * kw[3] + _A[6, 4] * kw[4] + _A[6, 5] * kw[5])
        ey = 0.0
        ew = 0.0
        for m in range(7):
            ey += _E[m] * ky[m]
            ew += _E[m] * kw[m]
        err = max(abs(h * ey) / (_TOL * y_scale), abs(h * ew) / (_TOL * max(1.0, abs(w_new))))
        if not np.isfinite(err) or not np.isfinite(w_new):
            if h <= 1e-14 * span:
                return np.nan, np.nan, h, steps, STATUS_BLOW_UP
            h *= 0.2
            continue
        if err <= 1.0:
            s += h
            y, w = y_new, w_new
            for q in range(_D):
                Sy[q] += h * (_A[6, 0] * kSy[0, q] + _A[6, 2] * kSy[2, q] + _A[6, 3] * kSy[3, q]
                              + _A[6, 4] * kSy[4, q] + _A[6, 5] * kSy[5, q])
                Sw[q] += h * (_A[6, 0] * kSw[0, q] + _A[6, 2] * kSw[2, q] + _A[6, 3] * kSw[3, q]
                              + _A[6, 4] * kSw[4, q] + _A[6, 5] * kSw[5, q])
                kSy[0, q] = kSy[6, q]
                kSw[0, q] = kSw[6, q]
            ky[0], kw[0] = ky[6], kw[6]  # first same as last
        factor = 0.9 * err ** -0.2 if err > 0.0 else 5.0
        h *= min(5.0, max(0.2, factor))
    return y, w, h, steps, STATUS_OK


@numba.njit(cache=True, error_model="numpy")
def _run_sens(p, t, x, v, a, y, w, Sy, Sw, stop, out, out_S, budget):
    """``spencer_kernel._run`` with the sensitivities; writes ẏ and ∂ẏ/∂θ when ``out`` is not empty.
    Returns (y, w, steps left, status)."""
    if out.shape[0]:
        out[0] = _ydot_sens_at(y, w, Sy, Sw, x[0], v[0], p, out_S[0])
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    ky, kw = np.empty(7), np.empty(7)  # the stages' work space, once per run
    kSy, kSw = np.empty((7, _D)), np.empty((7, _D))
    Sy_stage, Sw_stage = np.empty(_D), np.empty(_D)
    for k in range(stop):
        y, w, h, steps, status = _interval_sens(y, w, Sy, Sw, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1],
                                                p, h, y_scale, budget, ky, kw, kSy, kSw, Sy_stage, Sw_stage)
        budget -= steps
        if status != STATUS_OK:
            return np.nan, np.nan, budget, status
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan, budget, STATUS_BLOW_UP
        if out.shape[0]:
            out[k + 1] = _ydot_sens_at(y, w, Sy, Sw, x[k + 1], v[k + 1], p, out_S[k + 1])
    return y, w, budget, STATUS_OK


@numba.njit(cache=True, error_model="numpy")
def _ydot_sens_into(p, t, x, v, a, preroll, out, out_S):
    """ẏ (mm/s) and ∂ẏ/∂θ at every sample (as ``spencer_kernel._ydot_into``); the status."""
    budget = STEPS_PER_SAMPLE * (x.shape[0] - 1 + preroll)
    y, w = x[0], 0.0
    Sy = np.zeros(_D)
    Sw = np.zeros(_D)
    if preroll > 0:
        y, w, budget, status = _run_sens(p, t, x, v, a, y, w, Sy, Sw, preroll, out[:0], out_S[:0], budget)
        if status != STATUS_OK:
            return status
        y += x[0] - x[preroll]
    y, w, budget, status = _run_sens(p, t, x, v, a, y, w, Sy, Sw, x.shape[0] - 1, out, out_S, budget)
    return status


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _ydot_sens_serial(TH, t, x, v, a, preroll, out, out_S, status):
    for i in range(TH.shape[0]):
        status[i] = _ydot_sens_into(TH[i], t, x, v, a, preroll, out[i], out_S[i])
        if status[i] != STATUS_OK:
            out[i, :] = np.inf
            out_S[i] = np.nan


def ydot_sensitivity_batch(TH, t, x, v, a):
    """(ẏ (m, L) mm/s, ∂ẏ/∂θ (m, L, 6), status (m,)) of each θ row of TH (m, 6); rows that did not
    finish are +inf (ẏ) and NaN (∂ẏ/∂θ), their status saying why (``STATUS_*``)."""
    TH = np.ascontiguousarray(TH, dtype=float)
    out = np.empty((TH.shape[0], x.shape[0]))
    out_S = np.empty((TH.shape[0], x.shape[0], _D))
    status = np.zeros(TH.shape[0], dtype=np.int8)
    _ydot_sens_serial(TH, t, x, v, a, preroll_end(x, v), out, out_S, status)
    return out, out_S, status
