"""Sine tests of an MR damper from Spencer et al. (1997): test data that bwbench's model did not make.

Spencer, Dyke, Sain & Carlson, "Phenomenological model for magnetorheological dampers",
J. Eng. Mech. 123(3):230-238 (1997), the "modified Bouc-Wen" model, displacement-driven::

    F  = c1·ẏ + k1·(x − x0)
    ẏ  = (α·z + c0·ẋ + k0·(x − y)) / (c0 + c1)
    ż  = −γ·|ẋ − ẏ|·z·|z|^(n−1) − β·(ẋ − ẏ)·|z|^n + A·(ẋ − ẏ)
    α = αa + αb·u,  c1 = c1a + c1b·u,  c0 = c0a + c0b·u,  u̇ = −η·(u − v)

The voltage v is held constant from before the test starts, so the filter sits at u = v and η is
listed only for completeness. The model runs in the paper's own units (cm, s, N, V) so the table
below is used exactly as printed; displacements are converted from and to mm at the boundary.

Identified values (the paper's table for its prototype damper, units as printed there):

    c0a = 21.0 N·s/cm     c0b = 3.50 N·s/(cm·V)    k0 = 46.9 N/cm
    c1a = 283 N·s/cm      c1b = 2.95 N·s/(cm·V)    k1 = 5.00 N/cm     x0 = 14.3 cm
    αa  = 140 N/cm        αb  = 695 N/(cm·V)       γ = β = 363 cm⁻²   A = 301 (–)
    n   = 2 (–)           η   = 190 s⁻¹

In SI: c0a = 2100 N·s/m, k0 = 4690 N/m, c1a = 28 300 N·s/m, αa = 14 000 N/m, αb = 69 500 N/(m·V),
γ = β = 3.63·10⁶ m⁻², x0 = 0.143 m; z is then in m instead of cm.

The test: x(t) = X·sin(2πft) from rest (x = y = z = 0 at t = 0); the first cycle is a warm-up and
is not recorded; then ``cycles`` whole cycles are sampled at ``rate_hz``. The recorded time
starts at 0 s where the warm-up ends (x = 0, moving up). Spencer's damper is small (this model
gives a peak |F| of 1.5-1.7 kN in the paper's ±1.5 cm, 2.5 Hz, 2.25 V test), so the force is
multiplied by one factor that brings its noise-free peak |F| to ``peak_force_N``: the scaling is
linear in force, i.e. a bigger (or smaller) damper of the same shape (every force term, including
the accumulator preload k1·x0, changes by that factor).

Shape: below the yield velocity α·z_s/c1 (z_s = (A/(γ+β))^(1/n) = 0.644 cm; 3.2 mm/s at 0 V,
18.8 mm/s at 1 V, 38 mm/s at 2.25 V) the force is ≈ c1·ẋ + k1·(x − x0), so a ±25 mm, 0.1 Hz test
(≤ 15.7 mm/s) at ≥ 1 V never yields and records a viscous ellipse; from ~1 Hz up the loop has
the MR plateau. The parameters were identified at 2.5 Hz, ±1.5 cm: far from there is extrapolation.

Sign convention: x and F are positive in the same direction and F is the force the actuator
applies to the damper (what a load cell in series reads), so the loop runs anticlockwise in the
(x, F) plane and ∮F dx > 0 is the energy dissipated per cycle. NOTE: the project's synthetic
specimens (e.g. data/specimens/pom-mt24u01_0.01MPa_r1.csv) have ∮F dx ≈ −2.9·10³ N·mm per cycle,
the opposite sign; negate ``f`` to compare with them.

Measurement: the load cell adds a constant offset (``force_offset_N``) and Gaussian noise of
``force_noise_frac`` × the scaled peak; the encoder adds Gaussian noise of ``displacement_noise_mm``.
Measured damper tests also carry a velocity channel: ``v`` is the exact ẋ plus Gaussian noise of
``velocity_noise_mm_s``, written as a ``velocity_mm_s`` column by ``render(test, velocity=True)``.
Force noise is drawn first, then displacement noise, then (when not zero) velocity noise, from one
``numpy.random.Generator``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

# Spencer et al. (1997) identified values, in the paper's units: N, cm, s, V (see module docstring).
SPENCER_1997 = {
    "c0a": 21.0,
    "c0b": 3.50,
    "k0": 46.9,
    "c1a": 283.0,
    "c1b": 2.95,
    "k1": 5.00,
    "x0": 14.3,
    "alpha_a": 140.0,
    "alpha_b": 695.0,
    "gamma": 363.0,
    "beta": 363.0,
    "A": 301.0,
    "n": 2.0,
    "eta": 190.0,
}
MM_PER_CM = 10.0
# RK4 is stable for h·λ < 2.78. With h·λ ≤ 0.25 (λ bounded in default_substeps) halving h changes
# the force by < 1e-7 of its range at 0.1-5 Hz, 0-2.25 V, ±25 mm, and the force agrees with an
# independent SI-unit Radau solution (rtol 1e-10) to 4e-8 of its range: the margin is cheap.
_H_LAMBDA = 0.25


@dataclass(frozen=True, eq=False)
class SineTest:
    """One simulated test. Times in s, displacements in mm, forces in N.

    ``x``/``f``/``v`` are what the instruments record (noise, offset); ``x_true``/``f_true`` are the
    noise-free displacement and scaled damper force; ``scale`` is the force factor (–) and
    ``peak_unscaled_N`` the noise-free peak |F| of Spencer's damper itself.
    """

    t: np.ndarray
    x: np.ndarray
    f: np.ndarray
    x_true: np.ndarray
    f_true: np.ndarray
    scale: float
    peak_unscaled_N: float
    substeps: int
    v: np.ndarray | None = None


@numba.njit(cache=True)
def _rates(t, y, z, X, w, c0, c1, k0, alpha, gamma, beta, A, n):
    """(ẏ, ż) in cm/s at time t (s) for x = X·sin(wt) (X in cm, w in rad/s)."""
    x = X * math.sin(w * t)
    xd = X * w * math.cos(w * t)
    yd = (alpha * z + c0 * xd + k0 * (x - y)) / (c0 + c1)
    rel = xd - yd
    az = abs(z)
    zn1 = az ** (n - 1.0)
    zd = -gamma * abs(rel) * z * zn1 - beta * rel * zn1 * az + A * rel
    return yd, zd


@numba.njit(cache=True)
def _integrate(t_start, h_warm, n_warm, h, m, n_samples, X, w, c0, c1, k0, k1, x0, alpha, gamma, beta, A, n):
    """Classical RK4 from rest: n_warm steps of h_warm, then m steps of h between samples.

    Returns the unscaled force (N) at t_start + k·m·h, k = 0..n_samples−1.
    """
    y = 0.0
    z = 0.0
    t = 0.0
    out = np.empty(n_samples)
    for k in range(n_warm + (n_samples - 1) * m + 1):
        if k >= n_warm and (k - n_warm) % m == 0:
            i = (k - n_warm) // m
            ti = t_start + i * m * h  # not the accumulated t: keeps sample times exact
            yd, _ = _rates(ti, y, z, X, w, c0, c1, k0, alpha, gamma, beta, A, n)
            out[i] = c1 * yd + k1 * (X * math.sin(w * ti) - x0)
            if i == n_samples - 1:
                break
            t = ti
        step = h_warm if k < n_warm else h
        a1, b1 = _rates(t, y, z, X, w, c0, c1, k0, alpha, gamma, beta, A, n)
        a2, b2 = _rates(t + step / 2, y + step / 2 * a1, z + step / 2 * b1, X, w, c0, c1, k0, alpha, gamma, beta, A, n)
        a3, b3 = _rates(t + step / 2, y + step / 2 * a2, z + step / 2 * b2, X, w, c0, c1, k0, alpha, gamma, beta, A, n)
        a4, b4 = _rates(t + step, y + step * a3, z + step * b3, X, w, c0, c1, k0, alpha, gamma, beta, A, n)
        y += step / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
        z += step / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
        t += step
    return out


def _coefficients(voltage: float, p: dict) -> dict:
    return {
        "c0": p["c0a"] + p["c0b"] * voltage,
        "c1": p["c1a"] + p["c1b"] * voltage,
        "alpha": p["alpha_a"] + p["alpha_b"] * voltage,
    }


def default_substeps(
    amplitude_mm: float, frequency_hz: float, rate_hz: float, voltage: float, params: dict = SPENCER_1997
) -> int:
    """RK4 steps per sample interval so that h·λ ≤ 0.25 for a bound λ (1/s) on the stiffness.

    λ: the pre-yield relaxation of z through the dashpots, (A·α + k0)/(c0 + c1), plus the yield
    term n·(γ + β)·z_s^(n−1)·|ẋ|max at the saturation value z_s = (A/(γ + β))^(1/n) (cm).
    """
    p, c = params, _coefficients(voltage, params)
    z_s = (p["A"] / (p["gamma"] + p["beta"])) ** (1.0 / p["n"])
    v_max = amplitude_mm / MM_PER_CM * 2 * math.pi * frequency_hz
    lam = (p["A"] * c["alpha"] + p["k0"]) / (c["c0"] + c["c1"])
    lam += p["n"] * (p["gamma"] + p["beta"]) * z_s ** (p["n"] - 1) * v_max
    return max(1, math.ceil(lam / (rate_hz * _H_LAMBDA)))


def damper_force(
    amplitude_mm: float = 25.0,
    frequency_hz: float = 1.0,
    voltage: float = 1.0,
    rate_hz: float = 500.0,
    cycles: int = 3,
    substeps: int | None = None,
    params: dict = SPENCER_1997,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Noise-free, unscaled test: times (s, from 0), displacement (mm), Spencer's force (N), substeps.

    ``cycles`` whole cycles after one warm-up cycle; round(cycles·rate_hz/frequency_hz) + 1
    samples (the last closes the loop when a period is a whole number of samples).
    """
    if not (amplitude_mm > 0 and frequency_hz > 0 and rate_hz > 0 and cycles >= 1):
        raise ValueError("amplitude, frequency and rate must be positive and cycles ≥ 1")
    m = substeps or default_substeps(amplitude_mm, frequency_hz, rate_hz, voltage, params)
    p, c = params, _coefficients(voltage, params)
    period = 1.0 / frequency_hz
    n_samples = round(cycles * rate_hz / frequency_hz) + 1
    h = 1.0 / (rate_hz * m)
    n_warm = math.ceil(period / h)  # warm-up on its own step so recording starts exactly at x = 0
    X, w = amplitude_mm / MM_PER_CM, 2 * math.pi * frequency_hz
    force = _integrate(
        period,
        period / n_warm,
        n_warm,
        h,
        m,
        n_samples,
        X,
        w,
        c["c0"],
        c["c1"],
        p["k0"],
        p["k1"],
        p["x0"],
        c["alpha"],
        p["gamma"],
        p["beta"],
        p["A"],
        p["n"],
    )
    t = np.arange(n_samples) / rate_hz
    x = amplitude_mm * np.sin(w * (period + t))  # = X·sin(wt): the recording starts at phase 0
    return t, x, force, m


def sine_test(
    amplitude_mm: float = 25.0,
    frequency_hz: float = 1.0,
    voltage: float = 1.0,
    rate_hz: float = 500.0,
    cycles: int = 3,
    peak_force_N: float | None = 1200.0,
    force_noise_frac: float = 0.005,
    displacement_noise_mm: float = 0.001,
    force_offset_N: float = 8.0,
    rng: np.random.Generator | int | None = 0,
    substeps: int | None = None,
    params: dict = SPENCER_1997,
    velocity_noise_mm_s: float = 0.0,
) -> SineTest:
    """A recorded sine test (s, mm, N). ``peak_force_N=None`` keeps Spencer's damper unscaled.

    ``rng``: a ``numpy.random.Generator`` or a seed for ``numpy.random.default_rng``.
    """
    rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
    t, x_true, force, m = damper_force(amplitude_mm, frequency_hz, voltage, rate_hz, cycles, substeps, params)
    peak = float(np.max(np.abs(force)))
    scale = 1.0 if peak_force_N is None else peak_force_N / peak
    f_true = scale * force
    f = f_true + force_offset_N + rng.normal(0.0, force_noise_frac * scale * peak, t.shape)
    x = x_true + rng.normal(0.0, displacement_noise_mm, t.shape)
    w = 2 * math.pi * frequency_hz
    v = amplitude_mm * w * np.cos(w * t)
    if velocity_noise_mm_s > 0:
        v = v + rng.normal(0.0, velocity_noise_mm_s, t.shape)
    return SineTest(t=t, x=x, f=f, x_true=x_true, f_true=f_true, scale=scale, peak_unscaled_N=peak, substeps=m, v=v)


def render(test: SineTest, velocity: bool = False) -> str:
    """The project's CSV text: fixed formats (µs, 10 nm, 0.1 mN, velocity 1 µm/s) so bytes depend only on
    the values; ``velocity``: with the recorded velocity as a ``velocity_mm_s`` column."""
    if velocity and test.v is not None:
        rows = [f"{ti:.6f},{xi:.5f},{vi:.3f},{fi:.4f}\n" for ti, xi, vi, fi in zip(test.t, test.x, test.v, test.f)]
        return "time_s,displacement_mm,velocity_mm_s,force_N\n" + "".join(rows)
    if velocity:
        raise ValueError("this test has no velocity channel to write")
    rows = [f"{ti:.6f},{xi:.5f},{fi:.4f}\n" for ti, xi, fi in zip(test.t, test.x, test.f)]
    return "time_s,displacement_mm,force_N\n" + "".join(rows)


def write_test(path, velocity: bool = False, **kwargs) -> SineTest:
    """Simulate ``sine_test(**kwargs)`` and write it to ``path`` as a specimen CSV (``velocity``: with a
    velocity column); returns the test."""
    test = sine_test(**kwargs)
    from bwbench.data.output_paths import write_text

    write_text(path, render(test, velocity))
    return test


def loop_energy(x, f) -> float:
    """∮F dx (N·mm = mJ) along the samples by the trapezoid rule; > 0 for a dissipating loop."""
    x, f = np.asarray(x, dtype=float), np.asarray(f, dtype=float)
    return float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))
