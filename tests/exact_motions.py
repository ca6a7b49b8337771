"""Exact test-machine motions x(t), ẋ(t), ẍ(t) for the velocity tests and the differentiator benchmark.

Written independently of ``bwbench.datasets.synthetic`` (the generator the held-out checks must not
share a code path with): the ramp motion is a superposition of smooth velocity steps, each a
half-cosine blend integrated in closed form, where the generator walks piecewise through the
segments. Units: s, mm, mm/s, mm/s².

- ``ramp``: triangular ramps at a constant crosshead speed; every reversal and the start from rest
  is a half-cosine velocity blend of ``reversal_s`` seconds (continuous acceleration);
- ``sine``: amplitude·sin(2πt/period);
- ``random_motion``: a band-limited random motion, a sum of sines with random frequencies up to
  ``f_max_hz``, random phases and amplitudes falling as 1/f, scaled to a given peak.
"""

from __future__ import annotations

import io

import numpy as np


def _step(u):
    """Half-cosine step from 0 (u ≤ 0) to 1 (u ≥ 1), its integral and its derivative in u."""
    u = np.asarray(u, dtype=float)
    c = np.clip(u, 0.0, 1.0)
    value = 0.5 * (1.0 - np.cos(np.pi * c))
    integral = np.where(u <= 0.0, 0.0, np.where(u >= 1.0, u - 0.5, 0.5 * c - np.sin(np.pi * c) / (2 * np.pi)))
    slope = np.where((u > 0.0) & (u < 1.0), 0.5 * np.pi * np.sin(np.pi * c), 0.0)
    return value, integral, slope


def _ramp_steps(amplitude, speed, reversal_s, cycles, start_s):
    """(time where each velocity blend starts, velocity change): start, 2·cycles reversals, stop."""
    quarter = amplitude / speed
    steps = [(start_s, speed)]
    sign = 1.0
    for k in range(2 * cycles):
        steps.append((start_s + quarter * (1 + 2 * k), -2.0 * sign * speed))
        sign = -sign
    steps.append((start_s + 4 * quarter * cycles, -sign * speed))
    return steps


def ramp_reversals(amplitude=10.0, speed=5.0 / 60.0, reversal_s=8.0, cycles=4, start_s=0.3):
    """Times (s) where the ramp motion's velocity changes sign: the centres of the reversal blends."""
    return [t0 + reversal_s / 2 for t0, _ in _ramp_steps(amplitude, speed, reversal_s, cycles, start_s)[1:-1]]


def ramp(t, amplitude=10.0, speed=5.0 / 60.0, reversal_s=8.0, cycles=4, start_s=0.3):
    """Triangular ramps 0 → +A → −A → ... → 0 at ``speed`` mm/s, smooth reversals; (x, v, a) at t (s).

    The crosshead starts at ``start_s`` (blend from rest) and turns every 2A/speed seconds after the
    first quarter cycle; the last ramp ends back at rest at 0 mm after ``cycles`` full cycles. The
    blends round the turning points off, so they lie slightly inside ±A (±9.88 mm for the defaults).
    """
    t = np.asarray(t, dtype=float)
    tau = float(reversal_s)
    steps = _ramp_steps(amplitude, speed, reversal_s, cycles, start_s)
    x = np.zeros_like(t)
    v = np.zeros_like(t)
    a = np.zeros_like(t)
    for t0, dv in steps:
        value, integral, slope = _step((t - t0) / tau)
        x += dv * tau * integral
        v += dv * value
        a += dv * slope / tau
    return x, v, a


def ramp_duration(amplitude=10.0, speed=5.0 / 60.0, reversal_s=8.0, cycles=4, start_s=0.3) -> float:
    """Seconds from t = 0 until the ramp motion is back at rest."""
    return start_s + 4 * amplitude / speed * cycles + reversal_s


def sine(t, amplitude=10.0, period=480.0):
    w = 2 * np.pi / period
    t = np.asarray(t, dtype=float)
    return amplitude * np.sin(w * t), amplitude * w * np.cos(w * t), -amplitude * w * w * np.sin(w * t)


def random_motion(t, rng: np.random.Generator, peak=10.0, f_max_hz=1.0 / 120.0, n_sines=12):
    """Band-limited random motion with peak |x| = ``peak`` mm over t; frequencies in [f_max/20, f_max]."""
    t = np.asarray(t, dtype=float)
    f = rng.uniform(f_max_hz / 20, f_max_hz, n_sines)
    phase = rng.uniform(0, 2 * np.pi, n_sines)
    amp = 1.0 / f
    w = 2 * np.pi * f
    arg = np.outer(t, w) + phase
    x, v, a = np.sin(arg) @ amp, np.cos(arg) @ (amp * w), -np.sin(arg) @ (amp * w * w)
    scale = peak / np.max(np.abs(x))
    return x * scale, v * scale, a * scale


def render_csv(t, x, f, v=None, a=None, sep=",", decimal="."):
    """Specimen CSV text with fixed formats (µs, 10 nm, 0.1 mN; velocity 1e-7 mm/s, acceleration
    1e-9 mm/s²); ``sep=';'``, ``decimal=','`` for a European export."""
    columns = {"time_s": (t, "%.6f"), "displacement_mm": (x, "%.5f"), "force_N": (f, "%.4f")}
    if v is not None:
        columns["velocity_mm_s"] = (v, "%.7f")
    if a is not None:
        columns["acceleration_mm_s2"] = (a, "%.9f")
    out = io.StringIO()
    out.write(sep.join(columns) + "\n")
    for row in zip(*(values for values, _ in columns.values())):
        cells = [fmt % value for value, (_, fmt) in zip(row, columns.values())]
        out.write(sep.join(c.replace(".", decimal) for c in cells) + "\n")
    return out.getvalue()
