"""Spencer et al. (1997)'s MR-damper model: the compiled integration of its internal states.

In the symmetry-free coordinates of ``bwbench.models.spencer`` (mm, s, N), per unit c₁:

    ẏ = (v_y·w + r₀·ẋ + κ₀·(x − y)) / (1 + r₀)
    ẇ = ((ẋ − ẏ)/x_y)·(1 − c·|w|^n),   c = 1 if w·(ẋ − ẏ) > 0 (loading), η otherwise

and the force is F = c₁·ẏ + k₁·x + f₀. y (mm) is the internal displacement, w = z/z_s the
evolutionary variable in units of its saturation value. The excitation between two samples: ẋ is
the cubic Hermite interpolant of (ẋ, ẍ) at the samples, x the sample's x plus its integral. The
velocity, recorded or estimated, drives the model: a derivative of the noisy displacement between
samples would not (with 1 µm of encoder noise at 500 Hz it wiggles by ~1 mm/s inside each interval,
and an MR damper's pre-yield damping of ~20 N·s/mm turns that into ~20 N of force).

Integration: Dormand–Prince 5(4) with step-size control (tolerance 1e-9 per step on w and on y
relative to the record's amplitude), the step carried from one sample interval to the next. The
stiffness reaches (v_y/(1 + r₀))·(1 + |η|)/x_y + n·|ẋ − ẏ|/x_y: for an MR damper (x_y ≈ 0.02 mm,
v_y ≈ 20–40 mm/s) 10³–10⁴ s⁻¹, where the explicit method's stability bounds the step at ~3/λ —
about ten times the step classical RK4 needed for the same accuracy (it was 3–6× slower, and less
accurate where the relative velocity reverses: a kink of the rates that the error control finds by
itself). An interval that needs more than ``_MAX_STEPS`` steps (a corner of the search box) is
finished by the L-stable backward Euler, so such parameter sets cost bounded time and stay stable.
A state that is not finite makes the whole row +inf.
"""

from __future__ import annotations

import math

import numba
import numpy as np

_IMPLICIT_SUBSTEPS = 64  # backward-Euler steps for the rest of an interval too stiff for Dormand–Prince
_XY, _N, _ETA, _VY, _R0, _K0 = range(6)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _excitation(tau, h, x0, v0, v1, a0, a1):
    """x (mm) and ẋ (mm/s) at fraction tau of an interval of length h (s): ẋ is the cubic Hermite
    interpolant of (ẋ, ẍ) at its ends, x the sample x0 plus its integral."""
    t2 = tau * tau
    t3 = t2 * tau
    t4 = t3 * tau
    xd = (2 * t3 - 3 * t2 + 1) * v0 + (t3 - 2 * t2 + tau) * h * a0 + (-2 * t3 + 3 * t2) * v1 + (t3 - t2) * h * a1
    x = x0 + h * ((tau - t3 + 0.5 * t4) * v0 + (0.5 * t2 - 2 * t3 / 3 + 0.25 * t4) * h * a0
                  + (t3 - 0.5 * t4) * v1 + (0.25 * t4 - t3 / 3) * h * a1)
    return x, xd


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rates(y, w, x, xd, p):
    """(ẏ, ẇ) at state (y, w) and excitation (x, ẋ) for parameters p = (x_y, n, η, v_y, r₀, κ₀)."""
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) / (1.0 + p[_R0])
    u = xd - yd
    c = 1.0 if w * u > 0.0 else p[_ETA]
    wd = u / p[_XY] * (1.0 - c * math.pow(abs(w), p[_N]))
    return yd, wd


@numba.njit(cache=True, error_model="numpy")
def _backward_euler(y, w, x, xd, h, p):
    """One backward-Euler step of length h (s) to the excitation (x, ẋ) at its end; damped Newton.

    Returns (y, w) or NaNs when Newton does not converge.
    """
    s = 1.0 + p[_R0]
    y1, w1 = y, w
    for _ in range(50):
        yd, wd = _rates(y1, w1, x, xd, p)
        g1 = y1 - y - h * yd
        g2 = w1 - w - h * wd
        u = xd - yd
        c = 1.0 if w1 * u > 0.0 else p[_ETA]
        pw = math.pow(abs(w1), p[_N])
        dyd_dy = -p[_K0] / s
        dyd_dw = p[_VY] / s
        sat = 1.0 - c * pw
        dwd_dy = -dyd_dy / p[_XY] * sat
        dsat = -c * p[_N] * pw / abs(w1) * (1.0 if w1 > 0 else -1.0) if w1 != 0.0 else 0.0
        dwd_dw = -dyd_dw / p[_XY] * sat + u / p[_XY] * dsat
        a11, a12 = 1.0 - h * dyd_dy, -h * dyd_dw
        a21, a22 = -h * dwd_dy, 1.0 - h * dwd_dw
        det = a11 * a22 - a12 * a21
        if det == 0.0 or not np.isfinite(det):
            return np.nan, np.nan
        dy = (a22 * g1 - a12 * g2) / det
        dw = (a11 * g2 - a21 * g1) / det
        y1 -= dy
        w1 -= dw
        if abs(dy) <= 1e-13 * (abs(y1) + 1e-9) and abs(dw) <= 1e-13 * (abs(w1) + 1e-12):
            return y1, w1
    return np.nan, np.nan


# Dormand–Prince 5(4) tableau (the nodes c, the stage weights A, the 5th-order weights B and the
# difference E between the 5th- and 4th-order weights, for the error estimate).
_C = np.array([0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0])
_A = np.array([
    [0, 0, 0, 0, 0, 0],
    [1 / 5, 0, 0, 0, 0, 0],
    [3 / 40, 9 / 40, 0, 0, 0, 0],
    [44 / 45, -56 / 15, 32 / 9, 0, 0, 0],
    [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729, 0, 0],
    [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656, 0],
    [35 / 384, 0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84],
])
_E = np.array([71 / 57600, 0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40])
_TOL = 1e-9  # per step, on w (no unit, |w| ≲ 1) and on y relative to the record's amplitude
_MAX_STEPS = 4096  # per sample interval; beyond it the interval is finished by backward Euler


@numba.njit(cache=True, error_model="numpy")
def _interval(y, w, t0, t1, x0, v0, v1, a0, a1, p, h, y_scale, allowance):
    """Advance (y, w) over [t0, t1] with Dormand–Prince 5(4) and step-size control; ``h`` is the
    step (s) to try first (the last accepted one of the previous interval). Returns (y, w, h, steps
    tried); (NaN, NaN, h, steps) once more than ``allowance`` steps were tried (the simulation's step
    budget, ``_run``).

    The explicit method's stability bounds the step at ~3/λ where the system is stiff (an MR damper
    in saturation), ~10× the RK4 step that accuracy needed there; the error control shortens the step
    where the relative velocity reverses (a kink of the rates) without being told where."""
    span = t1 - t0
    s = 0.0
    ky = np.empty(7)
    kw = np.empty(7)
    x, xd = _excitation(0.0, span, x0, v0, v1, a0, a1)
    ky[0], kw[0] = _rates(y, w, x, xd, p)
    steps = 0
    while s < span:
        if steps >= _MAX_STEPS:
            # Too stiff even for this: the rest of the interval by the L-stable implicit step.
            rest = span - s
            for i in range(_IMPLICIT_SUBSTEPS):
                x, xd = _excitation((s + rest * (i + 1.0) / _IMPLICIT_SUBSTEPS) / span, span, x0, v0, v1, a0, a1)
                y, w = _backward_euler(y, w, x, xd, rest / _IMPLICIT_SUBSTEPS, p)
                if not np.isfinite(w):
                    break
            return y, w, h, steps
        if steps >= allowance:
            return np.nan, np.nan, h, steps
        steps += 1
        h = min(h, span - s)
        for j in range(1, 7):
            dy = 0.0
            dw = 0.0
            for m in range(j):
                dy += _A[j, m] * ky[m]
                dw += _A[j, m] * kw[m]
            x, xd = _excitation((s + _C[j] * h) / span, span, x0, v0, v1, a0, a1)
            ky[j], kw[j] = _rates(y + h * dy, w + h * dw, x, xd, p)
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
                return np.nan, np.nan, h, steps
            h *= 0.2
            continue
        if err <= 1.0:
            s += h
            y, w = y_new, w_new
            ky[0], kw[0] = ky[6], kw[6]  # first same as last
        factor = 0.9 * err ** -0.2 if err > 0.0 else 5.0
        h *= min(5.0, max(0.2, factor))
    return y, w, h, steps


@numba.njit(cache=True, error_model="numpy")
def preroll_end(x, v) -> int:
    """The first sample after one full cycle of the record's own motion where it passes its starting
    displacement in its starting direction (after two reversals); 0 when there is none or the record
    starts at rest. See ``_ydot_into``."""
    s0 = 1.0 if v[0] > 0.0 else (-1.0 if v[0] < 0.0 else 0.0)
    if s0 == 0.0:
        return 0
    reversals = 0
    for k in range(1, x.shape[0]):
        if v[k] * v[k - 1] < 0.0:
            reversals += 1
        if reversals >= 2 and v[k] * s0 > 0.0 and (x[k - 1] - x[0]) * s0 < 0.0 <= (x[k] - x[0]) * s0:
            return k
    return 0


@numba.njit(cache=True, error_model="numpy")
def _run(p, t, x, v, a, y, w, stop, out, budget):
    """Integrate from (y, w) at sample 0 to sample ``stop``, writing ẏ into ``out`` when it is not
    empty, on at most ``budget`` Dormand–Prince steps. Returns (y, w, steps left): (NaN, NaN, ≥ 0)
    on blow-up, (NaN, NaN, −1) when the step budget ran out."""
    if out.shape[0]:
        out[0], _ = _rates(y, w, x[0], v[0], p)
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    for k in range(stop):
        y, w, h, steps = _interval(y, w, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1], p, h, y_scale, budget)
        budget -= steps
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan, (budget if budget > 0 else -1)
        if out.shape[0]:
            out[k + 1], _ = _rates(y, w, x[k + 1], v[k + 1], p)
    return y, w, budget


# The work a simulation may do: this many Dormand–Prince steps per sample interval on average, over
# the whole record (pre-roll included). A fit of a measured MR-damper test takes 1–10 per interval
# (stability bounds the step at ~3/λ, λ ≈ 10³–10⁴ s⁻¹); a corner of the search box with a yield
# displacement of a micrometre would take thousands per interval (seconds per simulation). Such a
# simulation stops and its loss is +inf, the reason counted (``STATUS_STEP_BUDGET``).
STEPS_PER_SAMPLE = 64
STATUS_OK, STATUS_BLOW_UP, STATUS_STEP_BUDGET = 0, 1, 2


@numba.njit(cache=True, error_model="numpy")
def _ydot_into(p, t, x, v, a, preroll, out):
    """ẏ (mm/s) at every sample into ``out``; the status (``STATUS_*``).

    Initial state: a record that starts at rest starts from rest (y = x, w = 0). A record that starts
    in motion was recorded in the middle of a test; its first state is then taken as the one the
    model reaches after one cycle of the record's own motion (``preroll`` = ``preroll_end``): the
    model is run from rest to that sample, and the record is run again from the state reached
    there (y shifted by the same x). For a periodic test that is its steady state; without it the
    first ~40 ms of an MR-damper test recorded in motion carry a transient of ~200 N.
    """
    budget = STEPS_PER_SAMPLE * (x.shape[0] - 1 + preroll)
    y, w = x[0], 0.0
    if preroll > 0:
        y, w, budget = _run(p, t, x, v, a, y, w, preroll, out[:0], budget)
        y += x[0] - x[preroll]
    if not np.isfinite(w):
        return STATUS_STEP_BUDGET if budget < 0 else STATUS_BLOW_UP
    y, w, budget = _run(p, t, x, v, a, y, w, x.shape[0] - 1, out, budget)
    if not np.isfinite(w):
        return STATUS_STEP_BUDGET if budget < 0 else STATUS_BLOW_UP
    return STATUS_OK


def ydot_batch(TH, t, x, v, a):
    """(ẏ (mm/s) of each parameter row of TH (m, 6) at the samples: (m, L), +inf rows where the
    simulation did not finish; the status of each row (m,), ``STATUS_*``).

    On numba's threads only when there are enough rows for each thread (on a busy machine a parallel
    loop waits for a thread that has no core: tens of ms per call); the rows are independent, so the
    result is the same either way."""
    out = np.empty((TH.shape[0], x.shape[0]))
    status = np.zeros(TH.shape[0], dtype=np.int8)
    preroll = preroll_end(x, v)
    threads = numba.get_num_threads()
    if threads > 1 and TH.shape[0] >= 2 * threads:
        _ydot_parallel(TH, t, x, v, a, preroll, out, status)
    else:
        _ydot_serial(TH, t, x, v, a, preroll, out, status)
    return out, status


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _ydot_parallel(TH, t, x, v, a, preroll, out, status):
    for i in numba.prange(TH.shape[0]):
        status[i] = _ydot_into(TH[i], t, x, v, a, preroll, out[i])
        if status[i] != STATUS_OK:
            out[i, :] = np.inf


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _ydot_serial(TH, t, x, v, a, preroll, out, status):
    for i in range(TH.shape[0]):
        status[i] = _ydot_into(TH[i], t, x, v, a, preroll, out[i])
        if status[i] != STATUS_OK:
            out[i, :] = np.inf
