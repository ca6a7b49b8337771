"""An independent reference for the degrading, pinching Bouc-Wen model (``bwbn``): scipy ``solve_ivp`` in
time of Foliente (1995)'s equations in their published parameters (z and ε = ∫z·u̇·dt, A = 1), written
from the paper's equations, not from bwbench.models; and the column-test motion it is driven by."""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp


def growing_cycles(period=1.0, rate=200.0):
    """Cycles of growing amplitude (5 → 30 mm over 6 cycles), as a column test; no sample on a reversal."""

    def x_of(s):
        return (5 + 25 * np.clip(s / (6 * period), 0, 1)) * np.sin(2 * np.pi * s / period)

    def v_of(s):
        ramp = 25 / (6 * period) * (s < 6 * period)
        amp = 5 + 25 * np.clip(s / (6 * period), 0, 1)
        return ramp * np.sin(2 * np.pi * s / period) + amp * 2 * np.pi / period * np.cos(2 * np.pi * s / period)

    t = np.arange(0.0, 6 * period, 1.0 / rate) + 0.37 / rate
    return x_of, v_of, t


def reference_force(P, t, x_of, v_of):
    """F = c·u̇ + α·k·u + (1 − α)·k·z, ż = h·(u̇ − ν·(β·|u̇|·|z|^(n−1)·z + γ·u̇·|z|ⁿ))/η, ε̇ = z·u̇."""
    k, alpha, c, beta, gamma, n, dnu, deta, zs, p, q, psi, dpsi, lam = P

    def rhs(s, y):
        z, eps = y
        v = v_of(s)
        nu, eta = 1 + dnu * eps, 1 + deta * eps
        z_u = (1 / (nu * (beta + gamma))) ** (1 / n)
        z1 = zs * (1 - np.exp(-p * eps))
        z2 = (psi + dpsi * eps) * (lam + z1)
        h = 1 - z1 * np.exp(-(((z * np.sign(v) - q * z_u) / z2) ** 2))
        dz = h * (v - nu * (beta * abs(v) * abs(z) ** (n - 1) * z + gamma * v * abs(z) ** n)) / eta
        return [dz, z * v]

    sol = solve_ivp(
        rhs, (t[0], t[-1]), [0.0, 0.0], t_eval=t, method="DOP853", rtol=1e-10, atol=1e-12, max_step=t[1] - t[0]
    )
    return c * v_of(t) + alpha * k * x_of(t) + (1 - alpha) * k * sol.y[0]
