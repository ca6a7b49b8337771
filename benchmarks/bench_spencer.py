"""Speed of Spencer's MR-damper model: bwbench's compiled kernel against scipy's LSODA on the same
simulation (same parameters, same excitation: ẋ the cubic Hermite interpolant of (ẋ, ẍ) at the samples,
x the sample before plus its integral).

One evaluation = one simulation of one parameter set over a record. Prints milliseconds per
evaluation of each and their ratio, for three tests of the MR-damper generator's kind, and the
largest force difference (relative to the force range), single thread.
Run: `.venv/bin/python benchmarks/bench_spencer.py`.
"""

import time
from types import SimpleNamespace

import numba
import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicHermiteSpline

from bwbench.models.spencer.model import MODEL

# Spencer et al. (1997)'s damper at 1 V, mm units (see tests/models/spencer/test_spencer.py).
P = {
    "c0": 2.45,
    "c1": 28.595,
    "k0": 4.69,
    "k1": 0.5,
    "x0": 143.0,
    "alpha": 83.5,
    "beta": 3.63,
    "gamma": 3.63,
    "A": 301.0,
    "n": 2.0,
}
CASES = [(10.0, 1.0, 1000.0), (25.0, 0.25, 200.0), (2.0, 5.0, 500.0)]  # amplitude mm, Hz, sampling Hz


def lsoda(t, x, v, a):
    speed = CubicHermiteSpline(t, v, a)
    integral = speed.antiderivative()

    def spline(tt):  # the position: the sample before tt plus the integral of the velocity since it
        k = np.clip(np.searchsorted(t, tt, side="right") - 1, 0, len(t) - 1)
        return x[k] + integral(tt) - integral(t[k])

    c0, c1, k0, k1, x0 = P["c0"], P["c1"], P["k0"], P["k1"], P["x0"]
    alpha, beta, gamma, A, n = P["alpha"], P["beta"], P["gamma"], P["A"], P["n"]

    def ydot(tt, y, z):
        return (alpha * z + c0 * speed(tt) + k0 * (spline(tt) - y)) / (c0 + c1)

    def rhs(tt, s):
        y, z = s
        u = speed(tt) - ydot(tt, y, z)
        return [ydot(tt, y, z), -gamma * abs(u) * z * abs(z) ** (n - 1) - beta * u * abs(z) ** n + A * u]

    sol = solve_ivp(rhs, (t[0], t[-1]), [x[0], 0.0], method="LSODA", rtol=1e-8, atol=1e-10, t_eval=t)
    y, z = sol.y
    return c1 * ydot(t, y, z) + k1 * (x - x0)


def main():
    numba.set_num_threads(1)
    p = np.array([P[q.name] for q in MODEL.direct_parameters()])
    print(f"{'test':>24} {'samples':>8} {'bwbench ms':>11} {'LSODA ms':>9} {'ratio':>7} {'max diff/range':>15}")
    for amplitude, frequency, rate in CASES:
        # starts at rest: x = amplitude·(1 − cos), so both integrate from rest without a warm-up cycle
        t = np.arange(0.0, 3.0 / frequency, 1.0 / rate)
        w = 2 * np.pi * frequency
        x, v, a = amplitude * (1 - np.cos(w * t)), amplitude * w * np.sin(w * t), amplitude * w * w * np.cos(w * t)
        signal = SimpleNamespace(t=t, x=x, v=v, a=a)
        MODEL.force_batch(p[None], signal)  # compile
        repeats = 20
        start = time.perf_counter()
        for _ in range(repeats):
            ours = MODEL.force_batch(p[None], signal)[0]
        ours_ms = (time.perf_counter() - start) / repeats * 1e3
        start = time.perf_counter()
        ref = lsoda(t, x, v, a)
        ref_ms = (time.perf_counter() - start) * 1e3
        name = f"{amplitude:g} mm, {frequency:g} Hz, {rate:g} Hz"
        print(
            f"{name:>24} {len(t):>8} {ours_ms:>11.2f} {ref_ms:>9.0f} {ref_ms / ours_ms:>7.0f}× "
            f"{np.max(np.abs(ours - ref)) / np.ptp(ref):>15.1e}"
        )


if __name__ == "__main__":
    main()
