"""Excitation signals x, ẋ, ẍ for the displacement-driven model.

- ``measured`` (default): the specimen's own displacement samples, smoothed and differentiated
  with a Savitzky–Golay filter so that encoder noise does not make ẋ (and with it the branch)
  chatter near a reversal.
- ``sine``: the paper's approximation of the triangular excitation, x = x0 + a·sin(2πt/T + φ),
  with amplitude, period, offset and phase fitted to the displacement record.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from bwbench.models.savitzky_golay import savgol

EXCITATIONS = ("measured", "sine")

# 9 samples, quartic. At the specimens' 1 Hz sampling a quartic follows the crosshead's 8 s
# reversal blend; lower orders bias ẋ there, and with 2·ξ·ωn up to ~13,000 N·s/mm in Tables 6–8
# a 0.001 mm/s bias is 13 N. Measured on the 15 truth sets (benchmarks/bench_differentiator.py):
# truth-parameter MSE median 7 N² with SG(9,4), 94 N² with SG(7,2), 1 N² being the force noise.
SAVGOL_WINDOW = 9
SAVGOL_POLYORDER = 4


@dataclass(frozen=True)
class Excitation:
    """Sampled excitation: t (s), x (mm), v = ẋ (mm/s), a = ẍ (mm/s²), all of one length."""

    kind: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray


@dataclass(frozen=True)
class SineFit:
    """x(t) = offset + amplitude·sin(2π·t/period + phase); mm and s."""

    amplitude: float
    period: float
    offset: float
    phase: float

    def evaluate(self, t):
        w = 2.0 * np.pi / self.period
        arg = w * np.asarray(t, dtype=float) + self.phase
        x = self.offset + self.amplitude * np.sin(arg)
        v = self.amplitude * w * np.cos(arg)
        a = -self.amplitude * w * w * np.sin(arg)
        return x, v, a


def _uniform_step(t: np.ndarray) -> float:
    dt = np.diff(t)
    step = float(np.median(dt))
    # The specimen reader refuses worse (``bwbench.data.specimen.SAMPLING_TOLERANCE``, one line with the
    # file and line); this guards arrays that did not come through it.
    if np.max(np.abs(dt - step)) > 0.01 * step:
        raise ValueError("Savitzky-Golay differentiation needs uniformly sampled time")
    return step


def measured(t, x, window: int = SAVGOL_WINDOW, polyorder: int = SAVGOL_POLYORDER) -> Excitation:
    """Smoothed displacement and its first two derivatives from uniformly sampled data."""
    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    step = _uniform_step(t)
    window = min(window, len(x) - (1 - len(x) % 2))
    xs = savgol(x, window, polyorder)
    v = savgol(x, window, polyorder, deriv=1, delta=step)
    a = savgol(x, window, polyorder, deriv=2, delta=step)
    return Excitation("measured", t, xs, v, a)


def fit_sine(t, x) -> SineFit:
    """Least-squares sine through the displacement record, started from its FFT peak."""
    from scipy.optimize import least_squares  # here: scipy.optimize costs ~0.5 s to import

    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    offset0 = float(np.mean(x))
    spectrum = np.fft.rfft(x - offset0)
    freqs = np.fft.rfftfreq(len(x), d=float(np.median(np.diff(t))))
    k = int(np.argmax(np.abs(spectrum[1:]))) + 1
    period0 = 1.0 / freqs[k]
    amplitude0 = 0.5 * (np.max(x) - np.min(x))
    phase0 = float(np.angle(spectrum[k])) + np.pi / 2 - 2 * np.pi * freqs[k] * t[0]

    def residual(q):
        return SineFit(*q).evaluate(t)[0] - x

    fit = least_squares(residual, [amplitude0, period0, offset0, phase0], x_scale="jac")
    amplitude, period, offset, phase = fit.x
    if amplitude < 0:  # the same curve, with a positive amplitude
        amplitude, phase = -amplitude, phase + np.pi
    phase = float(np.mod(phase + np.pi, 2 * np.pi) - np.pi)
    return SineFit(float(amplitude), float(period), float(offset), phase)


def sine(t, x) -> Excitation:
    """The paper's sine approximation of the displacement record, sampled at ``t``."""
    xs, v, a = fit_sine(t, x).evaluate(t)
    return Excitation("sine", np.asarray(t, dtype=float), xs, v, a)


def build(kind: str, t, x) -> Excitation:
    if kind == "measured":
        return measured(t, x)
    if kind == "sine":
        return sine(t, x)
    raise ValueError(f"excitation must be one of {EXCITATIONS}, got {kind!r}")
