"""An independent reference for the switched model: scipy solve_ivp (DOP853, rtol 1e-10) in time,
integrated piecewise between the analytic velocity reversals of a sine excitation.

Deliberately written from the equations, not from bwbench.models.switched.simulation: time instead of displacement
as the integration variable, scipy instead of numba, analytic instead of located reversals.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def sine_excitation(t, amplitude, period, offset=0.0):
    w = 2 * np.pi / period
    x = offset + amplitude * np.sin(w * t)
    v = amplitude * w * np.cos(w * t)
    a = -amplitude * w * w * np.sin(w * t)
    return x, v, a


def reference_force(params, t, amplitude, period, state="shared", rtol=1e-10):
    p = np.asarray(params, dtype=float)
    plus, minus = p[:7], p[7:]
    w = 2 * np.pi / period
    x, v, a = sine_excitation(t, amplitude, period)
    # Reversals: cos(w t) = 0 -> t = (k + 1/2) period / 2.
    k = np.arange(0, int(np.ceil(2 * t[-1] / period)) + 2)
    reversals = (k + 0.5) * period / 2
    edges = np.concatenate([[t[0]], reversals[(reversals > t[0]) & (reversals < t[-1])], [t[-1]]])

    def rhs(tt, z, pars):
        A, n, _, beta, gamma, _, _ = pars
        xdot = amplitude * w * np.cos(w * tt)
        zz = z[0]
        return [xdot * (A - (beta + gamma * np.sign(zz * xdot)) * abs(zz) ** n)]

    z_plus, z_minus = 0.0, 0.0
    z_at = np.empty_like(t)
    for lo, hi in zip(edges[:-1], edges[1:]):
        mid = 0.5 * (lo + hi)
        branch_plus = np.cos(w * mid) >= 0
        pars = plus if branch_plus else minus
        use_minus = state == "split" and not branch_plus
        z0 = z_minus if use_minus else z_plus
        # A sample exactly on a reversal belongs to the branch its own velocity selects.
        inside = (t >= lo) & (t <= hi) & ((v >= 0) == branch_plus)
        sol = solve_ivp(rhs, (lo, hi), [z0], method="DOP853", rtol=rtol, atol=1e-14, args=(pars,), dense_output=True)
        assert sol.success, sol.message
        z_at[inside] = sol.sol(t[inside])[0]
        z_end = sol.y[0, -1]
        if use_minus:
            z_minus = z_end
        else:
            z_plus = z_end
    F = np.empty_like(t)
    for i in range(len(t)):
        s = plus if v[i] >= 0 else minus
        A, n, alpha, beta, gamma, xi, wn = s
        F[i] = a[i] + 2 * xi * wn * v[i] + alpha * wn**2 * x[i] + (1 - alpha) * wn**2 * z_at[i]
    return F


def reference_force_of_motion(params, t, motion, reversals, state="shared", rtol=1e-9):
    """The switched model's force (N) at times t (s) for any exact motion ``motion(t) -> (x, v, a)``
    whose velocity changes sign only at ``reversals`` (s): z integrated in time by LSODA between them.

    Shared state only; a sample exactly on a reversal takes the branch of its own velocity.
    """
    if state != "shared":
        raise ValueError("reference_force_of_motion: shared state only")
    p = np.asarray(params, dtype=float)
    x, v, a = motion(t)
    edges = np.concatenate([[t[0]], [r for r in reversals if t[0] < r < t[-1]], [t[-1]]])
    z, z_at = 0.0, np.empty_like(t)
    for lo, hi in zip(edges[:-1], edges[1:]):
        plus = motion(np.array([0.5 * (lo + hi)]))[1][0] >= 0
        A, n, _, beta, gamma, _, _ = p[:7] if plus else p[7:]

        def rhs(tt, zz, A=A, n=n, beta=beta, gamma=gamma):
            xdot = motion(np.array([tt]))[1][0]
            return [xdot * (A - (beta + gamma * np.sign(zz[0] * xdot)) * abs(zz[0]) ** n)]

        sol = solve_ivp(rhs, (lo, hi), [z], method="LSODA", rtol=rtol, atol=1e-12, dense_output=True)
        assert sol.success, sol.message
        inside = (t >= lo) & (t <= hi)
        z_at[inside] = sol.sol(t[inside])[0]
        z = sol.y[0, -1]
    branch = np.where(v[:, None] >= 0, p[None, :7], p[None, 7:])
    _, _, alpha, _, _, xi, wn = branch.T
    return a + 2 * xi * wn * v + alpha * wn**2 * x + (1 - alpha) * wn**2 * z_at
