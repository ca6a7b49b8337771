"""Excitation signals x, ẋ, ẍ for the displacement-driven model.

- ``measured`` (default): the specimen's own signals. A velocity (and acceleration) the file records
  drives the model as recorded, with the displacement as recorded; what the file does not record
  is estimated (``derivatives``: the displacement smoothed by a noise-scaled quintic spline and
  differentiated; the acceleration from a recorded velocity the same way).
- ``sine``: the paper's approximation of the triangular excitation, x = x0 + a·sin(2πt/T + φ),
  with amplitude, period, offset and phase fitted to the displacement record (recorded velocity
  and acceleration are not used: the paper's method).

The branch (ẋ ≥ 0: '+', ẋ < 0: '−') follows the ẋ of the excitation, whatever its source.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

EXCITATIONS = ("measured", "sine")
MEASURED, ESTIMATED, SINE = "measured", "estimated", "sine fit"  # where a signal comes from


@dataclass(frozen=True, eq=False)  # eq=False: comparing ndarray fields would raise
class Excitation:
    """Sampled excitation: t (s), x (mm), v = ẋ (mm/s), a = ẍ (mm/s²), all of one length.

    ``sources`` says where velocity and acceleration come from (``MEASURED``, ``ESTIMATED`` or
    ``SINE``); ``displacement_noise`` is σ̂ (mm) of the displacement when the velocity was estimated
    from it (else NaN); ``x_recorded`` the displacement as the file has it.
    """

    kind: str
    t: np.ndarray
    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    sources: dict = field(default_factory=dict)
    displacement_noise: float = float("nan")
    x_recorded: np.ndarray | None = None
    # A quasi-static record: v is the direction of motion (±1, 0 at a reversal), a is 0, t the point's index.
    rate_independent: bool = False

    @property
    def velocity_estimated(self) -> bool:
        return self.sources.get("velocity") == ESTIMATED

    def velocity_error(self) -> float:
        """Estimated RMS error (mm/s) of an estimated velocity (``derivatives.velocity_error``); 0 when
        the velocity is recorded (its own error is unknown to bwbench) or a sine fit."""
        if not self.velocity_estimated:
            return 0.0
        from bwbench.models import derivatives

        return derivatives.velocity_error(self.t, self.x_recorded)


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


def measured(t, x, v=None, a=None) -> Excitation:
    """The excitation of recorded signals: t (s), x (mm) and, when recorded, v (mm/s) and a (mm/s²).

    With v recorded, x and v drive the model as recorded and a missing a is the derivative of v;
    without it, x̂, v and (unless recorded) a come from ``derivatives.estimate`` on x.
    """
    from bwbench.models import derivatives

    t = np.asarray(t, dtype=float)
    x = np.asarray(x, dtype=float)
    if v is not None:
        v = np.asarray(v, dtype=float)
        acc = derivatives.estimate(t, v).v if a is None else np.asarray(a, dtype=float)
        sources = {"velocity": MEASURED, "acceleration": ESTIMATED if a is None else MEASURED}
        return Excitation("measured", t, x, v, acc, sources, x_recorded=x)
    e = derivatives.estimate(t, x)
    acc = e.a if a is None else np.asarray(a, dtype=float)
    sources = {"velocity": ESTIMATED, "acceleration": ESTIMATED if a is None else MEASURED}
    return Excitation("measured", t, e.x, e.v, acc, sources, e.noise, x_recorded=x)


def fit_sine(t, x) -> SineFit:
    """Least-squares sine through the displacement record, started from its FFT peak."""
    from scipy.optimize import least_squares  # here: scipy.optimize is slow to import

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
    return Excitation(
        "sine",
        np.asarray(t, dtype=float),
        xs,
        v,
        a,
        {"velocity": SINE, "acceleration": SINE},
        x_recorded=np.asarray(x, dtype=float),
    )


def build(kind: str, t, x, v=None, a=None) -> Excitation:
    """The excitation ``kind`` of recorded t (s), x (mm) and optionally v (mm/s), a (mm/s²)."""
    if kind == "measured":
        return measured(t, x, v, a)
    if kind == "sine":
        return sine(t, x)
    raise ValueError(f"excitation must be one of {EXCITATIONS}, got {kind!r}")


DIRECTION = "direction of motion"  # the source of a quasi-static record's "velocity"


def quasi_static(x) -> Excitation:
    """The excitation of a quasi-static record (no time): the displacement path as recorded, its
    direction of motion (``protocol.directions``: ±1, 0 at a reversal, a dead band against jitter) as
    the velocity — it picks a switched model's branch, never a rate — and no acceleration; t is the
    point's index."""
    from bwbench.models.protocol import directions

    x = np.asarray(x, dtype=float)
    t = np.arange(len(x), dtype=float)
    sources = {"velocity": DIRECTION, "acceleration": "none (quasi-static)"}
    return Excitation("measured", t, x, directions(x), np.zeros_like(x), sources, x_recorded=x, rate_independent=True)


def of_specimen(kind: str, specimen) -> Excitation:
    """The excitation ``kind`` of a ``Specimen`` (its recorded velocity and acceleration used if any; a
    quasi-static one's path and direction, ``quasi_static``)."""
    if getattr(specimen, "quasi_static", False):
        return quasi_static(specimen.x)
    return build(kind, specimen.t, specimen.x, specimen.v, specimen.a)
