"""Independent references for the Spencer and classic Bouc-Wen models: scipy ``solve_ivp`` in time,
in the models' own published parameters (not bwbench's symmetry-free coordinates), driven by an
excitation given as functions x(t), ẋ(t).

Deliberately written from the equations of docs/design.md (#models-as-plug-ins, #the-model), not from bwbench.models.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicHermiteSpline
from scipy.optimize import brentq


def hermite_excitation(t, x, v, a):
    """x(t), ẋ(t) as the models see the samples: ẋ the cubic Hermite interpolant of (ẋ, ẍ), x the
    sample before t plus the integral of ẋ since it."""
    speed = CubicHermiteSpline(t, v, a)
    integral = speed.antiderivative()

    def position(tt):
        tt = np.asarray(tt, dtype=float)
        k = np.clip(np.searchsorted(t, tt, side="right") - 1, 0, len(t) - 1)
        return x[k] + integral(tt) - integral(t[k])

    return position, speed


def spencer_force(p: dict, t, x_of, v_of, rtol=1e-11, method="DOP853", preroll=False):
    """F (N) at times t of Spencer et al. (1997)'s model from rest (y = x, z = 0) at t[0], DOP853 (explicit,
    adaptive: the stiffness here, ≤ 1e5 /s, costs it small steps, not instability); ``method="Radau"`` for a
    stiffer corner. ``preroll``: a record in motion starts instead from the state one cycle of its own
    motion leads to (``preroll_sample``)."""
    c0, c1, k0, k1, x0 = p["c0"], p["c1"], p["k0"], p["k1"], p["x0"]
    alpha, beta, gamma, A, n = p["alpha"], p["beta"], p["gamma"], p["A"], p["n"]

    def ydot(tt, y, z):
        return (alpha * z + c0 * v_of(tt) + k0 * (x_of(tt) - y)) / (c0 + c1)

    def rhs(tt, s):
        y, z = s
        yd = ydot(tt, y, z)
        u = v_of(tt) - yd
        return [yd, -gamma * abs(u) * z * abs(z) ** (n - 1) - beta * u * abs(z) ** n + A * u]

    start = [float(x_of(t[0])), 0.0]
    k = preroll_sample(x_of(t), v_of(t)) if preroll else 0
    if k:  # started in motion: from the state one cycle of the record's motion leads to
        pre = solve_ivp(rhs, (t[0], t[k]), start, method=method, rtol=rtol, atol=1e-13, max_step=float(t[1] - t[0]))
        assert pre.success, pre.message
        start = [pre.y[0, -1] + float(x_of(t[0]) - x_of(t[k])), pre.y[1, -1]]
    sol = solve_ivp(
        rhs, (t[0], t[-1]), start, method=method, rtol=rtol, atol=1e-13, t_eval=t, max_step=float(t[1] - t[0])
    )
    assert sol.success, sol.message
    y, z = sol.y
    return c1 * np.array([ydot(tt, yy, zz) for tt, yy, zz in zip(t, y, z)]) + k1 * (x_of(t) - x0)


def preroll_sample(x, v) -> int:
    """First sample after two velocity reversals where x passes x[0] again in the starting direction
    (0 when the record starts at rest or never does): where a record in motion is taken to start."""
    direction = np.sign(v[0])
    if direction == 0:
        return 0
    reversals = np.cumsum(np.r_[0, (v[1:] * v[:-1] < 0)])
    d = (x - x[0]) * direction
    for k in range(1, len(x)):
        if reversals[k] >= 2 and v[k] * direction > 0 and d[k - 1] < 0 <= d[k]:
            return k
    return 0


def classic_force(p7, t, x_of, v_of, a_of, rtol=1e-11):
    """F (N) of the classic Bouc-Wen model (A, n, α, β, γ, ξ, ωn) from z = 0, DOP853 in time between
    the zeros of ẋ (found by root bracketing on the sample grid, so every kink is a step end)."""
    A, n, alpha, beta, gamma, xi, wn = p7
    v_t = v_of(t)
    edges = [t[0]]
    for k in np.flatnonzero(np.sign(v_t[1:]) * np.sign(v_t[:-1]) < 0):
        edges.append(brentq(v_of, t[k], t[k + 1], xtol=1e-15))
    edges.append(t[-1])

    def rhs(tt, z):
        xd = v_of(tt)
        return [xd * (A - (beta + gamma * np.sign(z[0] * xd)) * abs(z[0]) ** n)]

    z_at = np.empty_like(t)
    z0 = 0.0
    for lo, hi in zip(edges[:-1], edges[1:]):
        sol = solve_ivp(rhs, (lo, hi), [z0], method="DOP853", rtol=rtol, atol=1e-14, dense_output=True)
        assert sol.success, sol.message
        inside = (t >= lo) & (t <= hi)
        z_at[inside] = sol.sol(t[inside])[0]
        z0 = sol.y[0, -1]
    return a_of(t) + 2 * xi * wn * v_t + alpha * wn**2 * x_of(t) + (1 - alpha) * wn**2 * z_at


def random_motion(seed: int, amplitude: float, f_max: float, components: int = 8):
    """A smooth random displacement: a sum of sines with random frequencies (≤ f_max Hz), phases and
    amplitudes (scaled to ``amplitude`` mm at most); returns x(t), ẋ(t), ẍ(t)."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.1 * f_max, f_max, components)
    phase = rng.uniform(0, 2 * np.pi, components)
    amp = rng.uniform(0.2, 1.0, components)
    amp *= amplitude / amp.sum()
    w = 2 * np.pi * f

    def x(tt):
        return np.sum(
            amp[:, None] * np.sin(np.multiply.outer(w, tt).reshape(len(w), -1) + phase[:, None]), axis=0
        ).reshape(np.shape(tt))

    def v(tt):
        return np.sum(
            (amp * w)[:, None] * np.cos(np.multiply.outer(w, tt).reshape(len(w), -1) + phase[:, None]), axis=0
        ).reshape(np.shape(tt))

    def a(tt):
        return np.sum(
            (-amp * w * w)[:, None] * np.sin(np.multiply.outer(w, tt).reshape(len(w), -1) + phase[:, None]), axis=0
        ).reshape(np.shape(tt))

    return x, v, a
