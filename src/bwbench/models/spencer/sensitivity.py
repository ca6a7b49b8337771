"""Spencer's model with its forward sensitivities: ẏ and ∂ẏ/∂θ at the samples, for exact Jacobians.

The state (y, w) of ``spencer_kernel`` and its derivatives S_y = ∂y/∂θ, S_w = ∂w/∂θ for the six
identifiable parameters θ = (x_y, n, η, v_y, r₀, κ₀) are integrated together, by the same
ROS34PW2 steps under the same step control (the error is measured on (y, w) only, so the steps are
those of the plain simulation and ẏ is the same numbers):

    Ṡ_y = ∂ẏ/∂y·S_y + ∂ẏ/∂w·S_w + ∂ẏ/∂θ,   Ṡ_w = ∂ẇ/∂y·S_y + ∂ẇ/∂w·S_w + ∂ẇ/∂θ,

from S = 0 at the first state (rest at the first sample the kernel is given). ∂ẏ/∂θ at a sample is then ∂ẏ/∂y·S_y + ∂ẏ/∂w·S_w + ∂ẏ/∂θ. The switch between loading and
unloading (c = 1 or η) is a kink of the rates, differentiated on either side (it is crossed at
isolated instants). The sensitivities take the Rosenbrock-W stages with the same matrix W as the
state (the 2×2 Jacobian of the rates, for each θ_j: W applied to (S_y, S_w)): the augmented system's
own Jacobian has the coupling ∂(∂f/∂u·S)/∂u below that block diagonal, which a W-method may leave out
at no loss of order. So S is the sensitivity of the ODE integrated to third order on the plain
simulation's steps (not the derivative of the discrete steps): it agrees with central differences of
the plain kernel to the integration tolerance.
"""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.power import exp, log
from bwbench.models.spencer.kernel import (
    A21,
    A31,
    A32,
    B1,
    B2,
    B3,
    B4,
    C2,
    C3,
    E1,
    E2,
    E3,
    E4,
    G21,
    G31,
    G32,
    G41,
    G42,
    G43,
    STATUS_BLOW_UP,
    STATUS_OK,
    STATUS_STEP_BUDGET,
    STEPS_PER_SAMPLE,
    TOL,
    hermite_excitation,
    kernel_arrays,
    step_allowance,
    step_factor,
    step_inverse,
    with_reciprocals,
)

_XY, _N, _ETA, _VY, _R0, _K0, _INV_S, _INV_XY = range(8)  # θ, then ``with_reciprocals``' two
_D = 6


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rates_sens(y, w, Sy, Sw, x, xd, p, dSy, dSw):
    """(ẏ, ẇ) at (y, w), and into dSy, dSw the rates of the sensitivities S_y, S_w (each (6,))."""
    inv_s = p[_INV_S]
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) * inv_s
    u = xd - yd
    loading = w * u > 0.0
    c = 1.0 if loading else p[_ETA]
    # |w|^n through ln|w|, which its derivatives need anyway: ∂|w|^n/∂w = n·|w|^n/w and
    # ∂|w|^n/∂n = |w|^n·ln|w| (both 0 at w = 0: n ≥ 1 in every box). The plain kernel's
    # ``abs_power`` is the same log and exp: the same bits.
    if w != 0.0:
        lw = log(abs(w))
        pw = exp(p[_N] * lw)
        dpw_dw = p[_N] * pw / w
        dpw_dn = pw * lw
    else:
        pw = 0.0
        dpw_dw = 0.0
        dpw_dn = 0.0
    sat = 1.0 - c * pw
    inv_xy = p[_INV_XY]
    wd = u * inv_xy * sat
    dyd_dy = -p[_K0] * inv_s
    dyd_dw = p[_VY] * inv_s
    # Total derivatives: the state's part for every θ_j, then the explicit ∂/∂θ_j of the few that have one.
    for j in range(_D):
        dyd = dyd_dy * Sy[j] + dyd_dw * Sw[j]
        dSy[j] = dyd
        dSw[j] = (-dyd * sat - u * c * dpw_dw * Sw[j]) * inv_xy
    for j, extra in ((_VY, w * inv_s), (_R0, u * inv_s), (_K0, (x - y) * inv_s)):
        dSy[j] += extra
        dSw[j] -= extra * sat * inv_xy
    dSw[_N] -= u * c * dpw_dn * inv_xy
    if not loading:
        dSw[_ETA] -= u * pw * inv_xy
    dSw[_XY] -= wd * inv_xy
    return yd, wd, u, c, pw, sat


@numba.njit(cache=True, inline="always", error_model="numpy")
def _start_sens(y, w, Sy, Sw, x, xd, p, dSy, dSw):
    """``_rates_sens`` at a step's start, with the matrix W of the step: (ẏ, ẇ, ∂ẏ/∂y, ∂ẏ/∂w, ∂ẇ/∂y,
    ∂ẇ/∂w), the plain kernel's ``_rates_jacobian`` to the bit from the same |w|^n."""
    yd, wd, u, c, pw, sat = _rates_sens(y, w, Sy, Sw, x, xd, p, dSy, dSw)
    j11 = -p[_K0] * p[_INV_S]
    j12 = p[_VY] * p[_INV_S]
    dsat = -c * p[_N] * pw / w if w != 0.0 else 0.0
    ux = u * p[_INV_XY]
    return yd, wd, j11, j12, -j11 * p[_INV_XY] * sat, -j12 * p[_INV_XY] * sat + ux * dsat


@numba.njit(cache=True, error_model="numpy")
def ydot_sens_at(y, w, Sy, Sw, x, xd, p, out_S):
    """ẏ at a sample, and its total derivative ∂ẏ/∂θ into out_S (6,): ``_rates_sens``' ẏ part alone
    (no |w|^n: one log and exp fewer per sample)."""
    inv_s = p[_INV_S]
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) * inv_s
    u = xd - yd
    dyd_dy = -p[_K0] * inv_s
    dyd_dw = p[_VY] * inv_s
    for j in range(_D):
        out_S[j] = dyd_dy * Sy[j] + dyd_dw * Sw[j]
    out_S[_VY] += w * inv_s
    out_S[_R0] += u * inv_s
    out_S[_K0] += (x - y) * inv_s
    return yd


@numba.njit(cache=True, inline="always", error_model="numpy")
def _stage_sens(kSy, kSw, i, fSy, fSw, gy, gw, j11, j12, j21, j22, i11, i12, i21, i22, h):
    """kS_i = (I − h·γ·W)⁻¹·(h·Ṡ(stage) + h·W·Σ_j γ_ij·kS_j) for each θ column; ``gy``, ``gw`` hold Σ_j γ_ij·kS_j."""
    for q in range(_D):
        r1 = h * (fSy[q] + j11 * gy[q] + j12 * gw[q])
        r2 = h * (fSw[q] + j21 * gy[q] + j22 * gw[q])
        kSy[i, q] = i11 * r1 + i12 * r2
        kSw[i, q] = i21 * r1 + i22 * r2


@numba.njit(cache=True, error_model="numpy")
def integrate_interval_sens(
    y,
    w,
    Sy,
    Sw,
    t0,
    t1,
    x0,
    v0,
    v1,
    a0,
    a1,
    p,
    h,
    y_scale,
    allowance,
    tol,
    kSy,
    kSw,
    fSy,
    fSw,
    tmp_y,
    tmp_w,
    gy,
    gw,
    fSy0,
    fSw0,
):
    """``kernel._interval`` with the sensitivities (Sy, Sw updated in place). Returns
    (y, w, h, steps, status); STATUS_STEP_BUDGET past ``allowance`` steps, STATUS_BLOW_UP on a state
    that is not finite. The state's arithmetic is the plain kernel's, stage for stage."""
    span = t1 - t0
    s = 0.0
    steps = 0
    xs, xds = x0, v0  # the excitation at s, as in the plain kernel
    fresh = True  # the rates at s (stage 1's) and W are to be computed: none of them depends on h
    fy0 = fw0 = j11 = j12 = j21 = j22 = 0.0
    while s < span:
        if steps >= allowance:
            return np.nan, np.nan, h, steps, STATUS_STEP_BUDGET
        steps += 1
        h = min(h, span - s)
        if fresh:
            fy0, fw0, j11, j12, j21, j22 = _start_sens(y, w, Sy, Sw, xs, xds, p, fSy0, fSw0)
            fresh = False
        i11, i12, i21, i22 = step_inverse(h, j11, j12, j21, j22)
        # stage 1
        r1, r2 = h * fy0, h * fw0
        k1y, k1w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        for q in range(_D):
            gy[q] = 0.0
            gw[q] = 0.0
        _stage_sens(kSy, kSw, 0, fSy0, fSw0, gy, gw, j11, j12, j21, j22, i11, i12, i21, i22, h)
        # stage 2
        x, xd = hermite_excitation((s + C2 * h) / span, span, x0, v0, v1, a0, a1)
        for q in range(_D):
            tmp_y[q] = Sy[q] + A21 * kSy[0, q]
            tmp_w[q] = Sw[q] + A21 * kSw[0, q]
            gy[q] = G21 * kSy[0, q]
            gw[q] = G21 * kSw[0, q]
        fy, fw, _, _, _, _ = _rates_sens(y + A21 * k1y, w + A21 * k1w, tmp_y, tmp_w, x, xd, p, fSy, fSw)
        g1, g2 = G21 * k1y, G21 * k1w
        r1, r2 = h * (fy + j11 * g1 + j12 * g2), h * (fw + j21 * g1 + j22 * g2)
        k2y, k2w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        _stage_sens(kSy, kSw, 1, fSy, fSw, gy, gw, j11, j12, j21, j22, i11, i12, i21, i22, h)
        # stage 3
        x, xd = hermite_excitation((s + C3 * h) / span, span, x0, v0, v1, a0, a1)
        for q in range(_D):
            tmp_y[q] = Sy[q] + A31 * kSy[0, q] + A32 * kSy[1, q]
            tmp_w[q] = Sw[q] + A31 * kSw[0, q] + A32 * kSw[1, q]
            gy[q] = G31 * kSy[0, q] + G32 * kSy[1, q]
            gw[q] = G31 * kSw[0, q] + G32 * kSw[1, q]
        fy, fw, _, _, _, _ = _rates_sens(
            y + A31 * k1y + A32 * k2y, w + A31 * k1w + A32 * k2w, tmp_y, tmp_w, x, xd, p, fSy, fSw
        )
        g1, g2 = G31 * k1y + G32 * k2y, G31 * k1w + G32 * k2w
        r1, r2 = h * (fy + j11 * g1 + j12 * g2), h * (fw + j21 * g1 + j22 * g2)
        k3y, k3w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        _stage_sens(kSy, kSw, 2, fSy, fSw, gy, gw, j11, j12, j21, j22, i11, i12, i21, i22, h)
        # stage 4 (at u + k_3, the step's end)
        xe, xde = hermite_excitation((s + h) / span, span, x0, v0, v1, a0, a1)
        for q in range(_D):
            tmp_y[q] = Sy[q] + kSy[2, q]
            tmp_w[q] = Sw[q] + kSw[2, q]
            gy[q] = G41 * kSy[0, q] + G42 * kSy[1, q] + G43 * kSy[2, q]
            gw[q] = G41 * kSw[0, q] + G42 * kSw[1, q] + G43 * kSw[2, q]
        fy, fw, _, _, _, _ = _rates_sens(y + k3y, w + k3w, tmp_y, tmp_w, xe, xde, p, fSy, fSw)
        g1, g2 = G41 * k1y + G42 * k2y + G43 * k3y, G41 * k1w + G42 * k2w + G43 * k3w
        r1, r2 = h * (fy + j11 * g1 + j12 * g2), h * (fw + j21 * g1 + j22 * g2)
        k4y, k4w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        _stage_sens(kSy, kSw, 3, fSy, fSw, gy, gw, j11, j12, j21, j22, i11, i12, i21, i22, h)
        y_new = y + B1 * k1y + B2 * k2y + B3 * k3y + B4 * k4y
        w_new = w + B1 * k1w + B2 * k2w + B3 * k3w + B4 * k4w
        ey = E1 * k1y + E2 * k2y + E3 * k3y + E4 * k4y
        ew = E1 * k1w + E2 * k2w + E3 * k3w + E4 * k4w
        err = max(abs(ey) / (tol * y_scale), abs(ew) / (tol * max(1.0, abs(w_new))))
        if not np.isfinite(err) or not np.isfinite(w_new):
            if h <= 1e-14 * span:
                return np.nan, np.nan, h, steps, STATUS_BLOW_UP
            h *= 0.2
            continue
        if err <= 1.0:
            s += h
            y, w = y_new, w_new
            xs, xds = xe, xde
            fresh = True
            for q in range(_D):
                Sy[q] += B1 * kSy[0, q] + B2 * kSy[1, q] + B3 * kSy[2, q] + B4 * kSy[3, q]
                Sw[q] += B1 * kSw[0, q] + B2 * kSw[1, q] + B3 * kSw[2, q] + B4 * kSw[3, q]
        h *= step_factor(err)
    return y, w, h, steps, STATUS_OK


@numba.njit(cache=True, error_model="numpy")
def _run_sens(p, t, x, v, a, y, w, Sy, Sw, stop, out, out_S, used, start, total, tol, pace):
    """``kernel._run`` with the sensitivities; writes ẏ and ∂ẏ/∂θ when ``out`` is not empty.
    Returns (y, w, steps used, status)."""
    kSy, kSw = np.empty((4, _D)), np.empty((4, _D))  # the stages' work space, once per run
    fSy, fSw, tmp_y, tmp_w, gy, gw = np.empty(_D), np.empty(_D), np.empty(_D), np.empty(_D), np.empty(_D), np.empty(_D)
    fSy0, fSw0 = np.empty(_D), np.empty(_D)  # stage 1's, kept while a step is retried
    if out.shape[0]:
        out[0] = ydot_sens_at(y, w, Sy, Sw, x[0], v[0], p, out_S[0])
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    for k in range(stop):
        allowance = step_allowance(used, start + k, total, pace)
        y, w, h, steps, status = integrate_interval_sens(
            y,
            w,
            Sy,
            Sw,
            t[k],
            t[k + 1],
            x[k],
            v[k],
            v[k + 1],
            a[k],
            a[k + 1],
            p,
            h,
            y_scale,
            allowance,
            tol,
            kSy,
            kSw,
            fSy,
            fSw,
            tmp_y,
            tmp_w,
            gy,
            gw,
            fSy0,
            fSw0,
        )
        used += steps
        if status != STATUS_OK:
            return np.nan, np.nan, used, status
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan, used, STATUS_BLOW_UP
        if out.shape[0]:
            out[k + 1] = ydot_sens_at(y, w, Sy, Sw, x[k + 1], v[k + 1], p, out_S[k + 1])
    return y, w, used, STATUS_OK


@numba.njit(cache=True, error_model="numpy")
def _ydot_sens_into(p, t, x, v, a, out, out_S, tol, pace):
    """ẏ (mm/s) and ∂ẏ/∂θ at every sample (as ``kernel._ydot_into``); the status."""
    p = with_reciprocals(p)
    Sy = np.zeros(_D)
    Sw = np.zeros(_D)
    total = pace * (x.shape[0] - 1)
    return _run_sens(p, t, x, v, a, x[0], 0.0, Sy, Sw, x.shape[0] - 1, out, out_S, 0, 0, total, tol, pace)[3]


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _ydot_sens_serial(TH, t, x, v, a, out, out_S, status, tol, pace):
    for i in range(TH.shape[0]):
        status[i] = _ydot_sens_into(TH[i], t, x, v, a, out[i], out_S[i], tol, pace)
        if status[i] != STATUS_OK:
            out[i, :] = np.inf
            out_S[i] = np.nan


def ydot_sensitivity_batch(TH, t, x, v, a, tol=TOL, pace=STEPS_PER_SAMPLE):
    """(ẏ (m, L) mm/s, ∂ẏ/∂θ (m, L, 6), status (m,)) of each θ row of TH (m, 6); rows that did not
    finish are +inf (ẏ) and NaN (∂ẏ/∂θ), their status saying why (``STATUS_*``). ``tol``, ``pace``: as
    ``kernel.ydot_batch``'s."""
    TH = np.ascontiguousarray(TH, dtype=float)
    t, x, v, a = kernel_arrays(t, x, v, a)
    out = np.empty((TH.shape[0], x.shape[0]))
    out_S = np.empty((TH.shape[0], x.shape[0], _D))
    status = np.zeros(TH.shape[0], dtype=np.int8)
    _ydot_sens_serial(TH, t, x, v, a, out, out_S, status, tol, int(pace))
    return out, out_S, status
