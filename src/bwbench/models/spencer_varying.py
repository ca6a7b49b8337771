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

from bwbench.models.spencer_kernel import (
    _TOL,
    STATUS_BLOW_UP,
    STATUS_OK,
    STATUS_STEP_BUDGET,
    STEPS_PER_SAMPLE,
    _allowance,
    _interval,
    _rates,
    kernel_arrays,
    preroll_end,
    with_reciprocals,
)


@numba.njit(cache=True, error_model="numpy")
def _reciprocals(P):
    out = np.empty((P.shape[0], 8))
    for k in range(P.shape[0]):
        out[k] = with_reciprocals(P[k])
    return out


@numba.njit(cache=True, error_model="numpy")
def _run(Q_int, Q_smp, t, x, v, a, y, w, stop, out, used, start, total, tol, pace):
    if out.shape[0]:
        out[0], _ = _rates(y, w, x[0], v[0], Q_smp[0])
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    for k in range(stop):
        allowance = _allowance(used, start + k, total, pace)
        y, w, h, steps = _interval(
            y, w, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1], Q_int[k], h, y_scale, allowance, tol
        )
        used += steps
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan, used, (STATUS_STEP_BUDGET if steps >= allowance else STATUS_BLOW_UP)
        if out.shape[0]:
            out[k + 1], _ = _rates(y, w, x[k + 1], v[k + 1], Q_smp[k + 1])
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


def ydot_varying(P_int, P_smp, signal, tol=_TOL, pace=STEPS_PER_SAMPLE):
    """(ẏ (mm/s) at the samples (L,), +inf where the simulation did not finish; status) for θ per interval
    ``P_int`` (L − 1, 6) and per sample ``P_smp`` (L, 6)."""
    from bwbench.models.spencer_start import _kernel_inputs

    t, x, v, a = _kernel_inputs(signal)
    P_int, P_smp = kernel_arrays(P_int, P_smp)
    out = np.empty(x.shape[0])
    good = bool(np.all(np.isfinite(P_int)) and np.all(P_int[:, 0] > 0) and np.all(P_smp[:, 0] > 0))
    status = _ydot_varying(P_int, P_smp, t, x, v, a, preroll_end(x, v), out, tol, int(pace)) if good else STATUS_BLOW_UP
    if status != STATUS_OK:
        out[:] = np.inf
    return out, status
