"""Spencer et al. (1997)'s MR-damper model: the compiled integration of its internal states.

In the symmetry-free coordinates of ``bwbench.models.spencer`` (mm, s, N), per unit c₁:

    ẏ = (v_y·w + r₀·ẋ + κ₀·(x − y)) / (1 + r₀)
    ẇ = ((ẋ − ẏ)/x_y)·(1 − c·|w|^n),   c = 1 if w·(ẋ − ẏ) > 0 (loading), η otherwise

and the force is F = c₁·ẏ + k₁·x + f₀. y (mm) is the internal displacement, w = z/z_s the
evolutionary variable in units of its saturation value. The excitation between two samples is the
cubic Hermite interpolant of (x, ẋ) at the samples, so ẋ is continuous and x exact at every sample.

Stiffness. ∂ẇ/∂w reaches (v_y/(1 + r₀))·(1 + |η|)/x_y + n·max(1, |η|)·|ẋ − ẏ|/x_y: for an MR
damper (x_y ≈ 0.02 mm, v_y ≈ 20–40 mm/s) that is 10³–10⁴ s⁻¹, so a 200 Hz record needs ~10–50
explicit steps per sample and a corner of the search box far more. Each sample interval is
integrated with classical RK4 in as many substeps as h·λ ≤ ``_RK4_H_LAMBDA`` asks; beyond
``_RK4_MAX_SUBSTEPS`` the L-stable backward Euler (Newton on the 2×2 system) takes over, so
such parameter sets cost bounded time and stay stable. A state that is not finite makes the whole
row +inf.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# RK4 is stable for h·λ < 2.78; at h·λ ≤ 0.5 the force agrees with solve_ivp (Radau, rtol 1e-10)
# to ~1e-8 of its range (tests/models/test_spencer.py); halving it changes nothing visible.
_RK4_H_LAMBDA = 0.3
_RK4_MAX_SUBSTEPS = 256
_IMPLICIT_SUBSTEPS = 64
_KINK_SPLIT = 16
_XY, _N, _ETA, _VY, _R0, _K0 = range(6)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _hermite(tau, h, x0, x1, v0, v1):
    """x and ẋ of the cubic Hermite interpolant at fraction tau of an interval of length h (s)."""
    t2 = tau * tau
    t3 = t2 * tau
    x = (2 * t3 - 3 * t2 + 1) * x0 + (t3 - 2 * t2 + tau) * h * v0 + (-2 * t3 + 3 * t2) * x1 + (t3 - t2) * h * v1
    xd = ((6 * t2 - 6 * tau) * (x0 - x1)) / h + (3 * t2 - 4 * tau + 1) * v0 + (3 * t2 - 2 * tau) * v1
    return x, xd


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rates(y, w, x, xd, p):
    """(ẏ, ẇ) at state (y, w) and excitation (x, ẋ) for parameters p = (x_y, n, η, v_y, r₀, κ₀)."""
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) / (1.0 + p[_R0])
    u = xd - yd
    c = 1.0 if w * u > 0.0 else p[_ETA]
    wd = u / p[_XY] * (1.0 - c * math.pow(abs(w), p[_N]))
    return yd, wd


@numba.njit(cache=True, inline="always", error_model="numpy")
def _stiffness(w, u, p):
    """A bound on |∂(ẏ, ẇ)/∂(y, w)| (1/s) near state w with relative velocity u (mm/s)."""
    big = max(1.0, abs(p[_ETA]))
    lam = p[_VY] / (1.0 + p[_R0]) * (1.0 + big * max(1.0, math.pow(abs(w), p[_N]))) / p[_XY]
    lam += p[_N] * big * abs(u) * math.pow(max(1.0, abs(w)), p[_N] - 1.0) / p[_XY]
    return lam + p[_K0] / (1.0 + p[_R0])


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


@numba.njit(cache=True, error_model="numpy")
def _rk4_step(y, w, tau0, tau1, h, x0, x1, v0, v1, p):
    """One classical RK4 step from fraction tau0 to tau1 of the interval; also whether the relative
    velocity ẋ − ẏ changed sign between its first and last stage."""
    dt = (tau1 - tau0) * h
    xa, xda = _hermite(tau0, h, x0, x1, v0, v1)
    xb, xdb = _hermite(0.5 * (tau0 + tau1), h, x0, x1, v0, v1)
    xc, xdc = _hermite(tau1, h, x0, x1, v0, v1)
    k1y, k1w = _rates(y, w, xa, xda, p)
    k2y, k2w = _rates(y + 0.5 * dt * k1y, w + 0.5 * dt * k1w, xb, xdb, p)
    k3y, k3w = _rates(y + 0.5 * dt * k2y, w + 0.5 * dt * k2w, xb, xdb, p)
    k4y, k4w = _rates(y + dt * k3y, w + dt * k3w, xc, xdc, p)
    kinked = (xda - k1y) * (xdc - k4y) < 0.0
    return (y + dt * (k1y + 2.0 * k2y + 2.0 * k3y + k4y) / 6.0,
            w + dt * (k1w + 2.0 * k2w + 2.0 * k3w + k4w) / 6.0, kinked)


@numba.njit(cache=True, error_model="numpy")
def _interval(y, w, t0, t1, x0, x1, v0, v1, p):
    """Advance (y, w) over one sample interval [t0, t1]."""
    h = t1 - t0
    yd, _ = _rates(y, w, x0, v0, p)
    lam = _stiffness(w, v0 - yd, p)
    lam = max(lam, _stiffness(w, v1 - yd, p))
    m = int(math.ceil(h * lam / _RK4_H_LAMBDA)) if h * lam > _RK4_H_LAMBDA else 1
    if m > _RK4_MAX_SUBSTEPS:
        for i in range(_IMPLICIT_SUBSTEPS):
            tau = (i + 1.0) / _IMPLICIT_SUBSTEPS
            x, xd = _hermite(tau, h, x0, x1, v0, v1)
            y, w = _backward_euler(y, w, x, xd, h / _IMPLICIT_SUBSTEPS, p)
            if not np.isfinite(w):
                return y, w
        return y, w
    for i in range(m):
        y1, w1, kinked = _rk4_step(y, w, i / m, (i + 1.0) / m, h, x0, x1, v0, v1, p)
        if kinked:
            # The relative velocity reversed inside the substep: the rates have a kink there and
            # RK4 drops to second order, so that one substep is redone in _KINK_SPLIT pieces.
            for j in range(_KINK_SPLIT):
                y, w, _ = _rk4_step(y, w, (i + j / _KINK_SPLIT) / m, (i + (j + 1.0) / _KINK_SPLIT) / m,
                                    h, x0, x1, v0, v1, p)
        else:
            y, w = y1, w1
        if not np.isfinite(w):
            return y, w
    return y, w


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
def _run(p, t, x, v, y, w, stop, out):
    """Integrate from (y, w) at sample 0 to sample ``stop``, writing ẏ into ``out`` when it is not
    empty; returns the final (y, w) (NaN on blow-up)."""
    if out.shape[0]:
        out[0], _ = _rates(y, w, x[0], v[0], p)
    for k in range(stop):
        y, w = _interval(y, w, t[k], t[k + 1], x[k], x[k + 1], v[k], v[k + 1], p)
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan
        if out.shape[0]:
            out[k + 1], _ = _rates(y, w, x[k + 1], v[k + 1], p)
    return y, w


@numba.njit(cache=True, error_model="numpy")
def _ydot_into(p, t, x, v, preroll, out):
    """ẏ (mm/s) at every sample into ``out``; False when the state is not finite.

    Initial state: a record that starts at rest starts from rest (y = x, w = 0). A record that starts
    in motion was recorded in the middle of a test; its first state is then taken as the one the
    model reaches after one cycle of the record's own motion (``preroll`` = ``preroll_end``): the
    model is run from rest to that sample, and the record is run again from the state reached
    there (y shifted by the same x). For a periodic test that is its steady state; without it the
    first ~40 ms of an MR-damper test recorded in motion carry a transient of ~200 N.
    """
    y, w = x[0], 0.0
    if preroll > 0:
        y, w = _run(p, t, x, v, y, w, preroll, out[:0])
        y += x[0] - x[preroll]
    if not np.isfinite(w):
        return False
    y, w = _run(p, t, x, v, y, w, x.shape[0] - 1, out)
    return bool(np.isfinite(w))


@numba.njit(cache=True, parallel=True, error_model="numpy")
def ydot_batch(TH, t, x, v):
    """ẏ (mm/s) of each parameter row of TH (m, 6) at the samples: (m, L); +inf rows on blow-up."""
    out = np.empty((TH.shape[0], x.shape[0]))
    preroll = preroll_end(x, v)
    for i in numba.prange(TH.shape[0]):
        if not _ydot_into(TH[i], t, x, v, preroll, out[i]):
            out[i, :] = np.inf
    return out
