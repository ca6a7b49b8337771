"""Spencer's model under a control that changes during the record: per-interval parameters.

The same integration as ``spencer_kernel`` (ROS34PW2, step-size control, the same step budget and
initial state), with the identifiable parameters θ = (x_y, n, η, v_y, r₀, κ₀) given per sample
interval (held over it: the control averaged over the interval) and per sample (the rates written
at the samples). A command that switches between two samples acts from the interval after the
switch; a filtered control changes smoothly and its interval mean is exact for the held command.
"""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.spencer.kernel import (
    STATUS_BLOW_UP,
    STATUS_OK,
    STATUS_STEP_BUDGET,
    STEPS_PER_SAMPLE,
    TOL,
    integrate_interval,
    kernel_arrays,
    rates_at,
    step_allowance,
    with_reciprocals,
)
from bwbench.models.spencer.sensitivity import integrate_interval_sens, ydot_sens_at


@numba.njit(cache=True, error_model="numpy")
def _reciprocals(P):
    out = np.empty((P.shape[0], 8))
    for k in range(P.shape[0]):
        out[k] = with_reciprocals(P[k])
    return out


@numba.njit(cache=True, error_model="numpy")
def _run(Q_int, Q_smp, t, x, v, a, y, w, stop, out, used, start, total, tol, pace):
    if out.shape[0]:
        out[0], _ = rates_at(y, w, x[0], v[0], Q_smp[0])
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    for k in range(stop):
        allowance = step_allowance(used, start + k, total, pace)
        y, w, h, steps = integrate_interval(
            y, w, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1], Q_int[k], h, y_scale, allowance, tol
        )
        used += steps
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan, used, (STATUS_STEP_BUDGET if steps >= allowance else STATUS_BLOW_UP)
        if out.shape[0]:
            out[k + 1], _ = rates_at(y, w, x[k + 1], v[k + 1], Q_smp[k + 1])
    return y, w, used, STATUS_OK


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _ydot_varying(P_int, P_smp, t, x, v, a, preroll, out, tol, pace):
    total = pace * (x.shape[0] - 1 + preroll)
    Q_int, Q_smp = _reciprocals(P_int), _reciprocals(P_smp)
    y, w = x[0], 0.0
    used = 0
    if preroll > 0:
        y, w, used, status = _run(Q_int, Q_smp, t, x, v, a, y, w, preroll, out[:0], used, 0, total, tol, pace)
        if status != STATUS_OK:
            return status
        y += x[0] - x[preroll]
    return _run(Q_int, Q_smp, t, x, v, a, y, w, x.shape[0] - 1, out, used, preroll, total, tol, pace)[3]


def ydot_varying(P_int, P_smp, signal, tol=TOL, pace=STEPS_PER_SAMPLE):
    """(ẏ (mm/s) at the samples (L,), +inf where the simulation did not finish; status) for θ per interval
    ``P_int`` (L − 1, 6) and per sample ``P_smp`` (L, 6)."""
    from bwbench.models.spencer.start import kernel_inputs

    t, x, v, a = kernel_inputs(signal)
    P_int, P_smp = kernel_arrays(P_int, P_smp)
    out = np.empty(x.shape[0])
    good = bool(np.all(np.isfinite(P_int)) and np.all(P_int[:, 0] > 0) and np.all(P_smp[:, 0] > 0))
    # the kernel starts at rest at the first sample it is given: the start rule is the problem's (models/start.py)
    status = _ydot_varying(P_int, P_smp, t, x, v, a, 0, out, tol, int(pace)) if good else STATUS_BLOW_UP
    if status != STATUS_OK:
        out[:] = np.inf
    return out, status


# -- sensitivities under a varying control ------------------------------------------------------------------
# θ = B·c per interval: the sensitivities S_c = ∂(y, w)/∂c of D coefficients obey Ṡ_c = J·S_c + (∂f/∂θ)·B_k on
# interval k. ``spencer_sensitivity._interval_sens`` integrates, for six columns S and the interval's θ,
# Φ·S + Ψ (Φ the state's transition, Ψ the sensitivities to θ from S = 0), on the plain simulation's steps. So
# one call from S = 0 gives Ψ, one call per block of six columns of S_c gives Φ·S_c + Ψ, and
# S_c ← Φ·S_c + Ψ·B_k: exact, the state stepped as the plain kernel steps it.


@numba.njit(cache=True, error_model="numpy")
def _run_sens_varying(
    Q_int, Q_smp, B_int, B_smp, t, x, v, a, y, w, Sc_y, Sc_w, stop, out, out_S, used, start, total, tol, pace
):
    D = Sc_y.shape[0]
    blocks = (D + 5) // 6
    kSy, kSw = np.empty((4, 6)), np.empty((4, 6))
    fSy, fSw, tmp_y, tmp_w, gy, gw = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6)
    fSy0, fSw0 = np.empty(6), np.empty(6)
    Py, Pw, By, Bw, E, zero = np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.empty(6), np.zeros(6)
    if out.shape[0]:
        out[0] = ydot_sens_at(y, w, zero, zero, x[0], v[0], Q_smp[0], E)
        for d in range(D):
            s = 0.0
            for j in range(6):
                s += E[j] * B_smp[0, j, d]
            out_S[0, d] = s
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    for k in range(stop):
        allowance = step_allowance(used, start + k, total, pace)
        p = Q_int[k]
        Py[:] = 0.0
        Pw[:] = 0.0
        y1, w1, h1, steps, status = integrate_interval_sens(
            y, w, Py, Pw, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1], p, h, y_scale, allowance, tol,
            kSy, kSw, fSy, fSw, tmp_y, tmp_w, gy, gw, fSy0, fSw0,
        )  # fmt: skip
        used += steps
        if status != STATUS_OK:
            return np.nan, np.nan, used, status
        if not (np.isfinite(y1) and np.isfinite(w1)):
            return np.nan, np.nan, used, STATUS_BLOW_UP
        for b in range(blocks):
            for q in range(6):
                col = 6 * b + q
                By[q] = Sc_y[col] if col < D else 0.0
                Bw[q] = Sc_w[col] if col < D else 0.0
            integrate_interval_sens(
                y, w, By, Bw, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1], p, h, y_scale, allowance, tol,
                kSy, kSw, fSy, fSw, tmp_y, tmp_w, gy, gw, fSy0, fSw0,
            )  # fmt: skip
            for q in range(6):
                col = 6 * b + q
                if col < D:
                    Sc_y[col] = By[q] - Py[q]
                    Sc_w[col] = Bw[q] - Pw[q]
        for d in range(D):
            ay = 0.0
            aw = 0.0
            for j in range(6):
                ay += Py[j] * B_int[k, j, d]
                aw += Pw[j] * B_int[k, j, d]
            Sc_y[d] += ay
            Sc_w[d] += aw
        y, w, h = y1, w1, h1
        if out.shape[0]:
            pk = Q_smp[k + 1]
            out[k + 1] = ydot_sens_at(y, w, zero, zero, x[k + 1], v[k + 1], pk, E)
            dyd_dy = -pk[5] * pk[6]
            dyd_dw = pk[3] * pk[6]
            for d in range(D):
                s = dyd_dy * Sc_y[d] + dyd_dw * Sc_w[d]
                for j in range(6):
                    s += E[j] * B_smp[k + 1, j, d]
                out_S[k + 1, d] = s
    return y, w, used, STATUS_OK


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _ydot_sens_varying(P_int, P_smp, B_int, B_smp, t, x, v, a, preroll, out, out_S, tol, pace):
    total = pace * (x.shape[0] - 1 + preroll)
    Q_int, Q_smp = _reciprocals(P_int), _reciprocals(P_smp)
    D = B_int.shape[2]
    Sc_y, Sc_w = np.zeros(D), np.zeros(D)
    y, w = x[0], 0.0
    used = 0
    if preroll > 0:
        y, w, used, status = _run_sens_varying(
            Q_int,
            Q_smp,
            B_int,
            B_smp,
            t,
            x,
            v,
            a,
            y,
            w,
            Sc_y,
            Sc_w,
            preroll,
            out[:0],
            out_S[:0],
            used,
            0,
            total,
            tol,
            pace,
        )
        if status != STATUS_OK:
            return status
        y += x[0] - x[preroll]
    return _run_sens_varying(
        Q_int,
        Q_smp,
        B_int,
        B_smp,
        t,
        x,
        v,
        a,
        y,
        w,
        Sc_y,
        Sc_w,
        x.shape[0] - 1,
        out,
        out_S,
        used,
        preroll,
        total,
        tol,
        pace,
    )[3]


def ydot_sensitivity_varying(P_int, P_smp, B_int, B_smp, signal, tol=TOL, pace=STEPS_PER_SAMPLE):
    """(ẏ (L,), ∂ẏ/∂c (L, D), status) for θ per interval ``P_int`` (L − 1, 6) and per sample ``P_smp`` (L, 6)
    with ∂θ/∂c per interval ``B_int`` (L − 1, 6, D) and per sample ``B_smp`` (L, 6, D)."""
    from bwbench.models.spencer.start import kernel_inputs

    t, x, v, a = kernel_inputs(signal)
    P_int, P_smp, B_int, B_smp = kernel_arrays(P_int, P_smp, B_int, B_smp)
    out = np.empty(x.shape[0])
    out_S = np.empty((x.shape[0], B_int.shape[2]))
    good = bool(np.all(np.isfinite(P_int)) and np.all(P_int[:, 0] > 0) and np.all(P_smp[:, 0] > 0))
    status = (
        _ydot_sens_varying(P_int, P_smp, B_int, B_smp, t, x, v, a, 0, out, out_S, tol, int(pace))
        if good
        else STATUS_BLOW_UP
    )
    if status != STATUS_OK:
        out[:] = np.inf
        out_S[:] = np.nan
    return out, out_S, status
