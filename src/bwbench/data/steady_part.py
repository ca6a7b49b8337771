"""The steady part of a constant-amplitude test: where its ramp-in and ramp-out cycles end.

A damper rig starts a sine test from rest and stops it at rest: the amplitude ramps in over the
first cycle or so and out over the last. Those cycles are not the test's steady motion: a check
that asks "is this record a sine?" (the inertia rule) or a figure that shows the steady loop should
judge the steady part and say that the ramps were left out.

Half-cycles are the excursions of x on either side of its mid-range (x_max + x_min)/2, each one
counted once it leaves a band of ``BAND`` × the amplitude around it (so encoder noise at a crossing
does not split one). The steady amplitude is the largest peak excursion of the half-cycles (the ramps may be half
the record, so not the median); the ramp
is the run of leading (ramp-in) or trailing (ramp-out) half-cycles whose peak stays below
(1 − ``RAMP_TOLERANCE``) × that, for at most ``MAX_RAMP_CYCLES``. The notion holds only for a constant-amplitude test: a record is
called ramped only when its steady half-cycles agree within ``RAMP_TOLERANCE`` and there are at
least ``MIN_STEADY`` of them (a random or swept record has no steady part, and no ramps are named).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BAND = 0.05  # × amplitude: a half-cycle starts where x leaves this band around its mid-range
RAMP_TOLERANCE = 0.05  # a half-cycle whose peak is below 95 % of the steady amplitude is a ramp cycle
MIN_STEADY = 3  # half-cycles of constant amplitude needed to call a record a constant-amplitude test
# A rig ramps in over a cycle or two; a longer run of smaller cycles is the protocol itself (a column
# test of growing amplitude), not a ramp (``bwbench.models.protocol``).
MAX_RAMP_CYCLES = 2.0


@dataclass(frozen=True)
class SteadyPart:
    """``start``/``stop``: the slice of samples of the steady motion (the whole record when it has no
    ramps); ``ramp_in_cycles``/``ramp_out_cycles``: how many cycles (half-cycles / 2) each ramp
    spans; ``ramp_in_s``/``ramp_out_s``: how long (s)."""

    start: int
    stop: int
    ramp_in_cycles: float = 0.0
    ramp_out_cycles: float = 0.0
    ramp_in_s: float = 0.0
    ramp_out_s: float = 0.0

    @property
    def ramped(self) -> bool:
        return self.ramp_in_cycles > 0 or self.ramp_out_cycles > 0

    @property
    def part(self) -> slice:
        return slice(self.start, self.stop)

    def describe(self) -> str:
        """E.g. "ramp-in 1 cycle (0.5 s), ramp-out 1 cycle (0.5 s)"; "" when there are none."""
        parts = []
        for name, cycles, seconds in (
            ("ramp-in", self.ramp_in_cycles, self.ramp_in_s),
            ("ramp-out", self.ramp_out_cycles, self.ramp_out_s),
        ):
            if cycles > 0:
                parts.append(f"{name} {cycles:g} cycle{'s' if cycles != 1 else ''} ({seconds:.3g} s)")
        return ", ".join(parts)


def half_cycle_starts(x) -> np.ndarray:
    """Indices where x enters a new half-cycle (leaves the band on the other side of its mid-range)."""
    x = np.asarray(x, dtype=float)
    mid, amplitude = 0.5 * (x.max() + x.min()), 0.5 * float(np.ptp(x))
    side = np.where(x - mid > BAND * amplitude, 1, np.where(x - mid < -BAND * amplitude, -1, 0))
    outside = np.flatnonzero(side)
    if not len(outside):
        return outside
    changes = np.flatnonzero(np.diff(side[outside]) != 0) + 1
    return np.concatenate([[outside[0]], outside[changes]])


def steady_part(t, x) -> SteadyPart:
    """The ``SteadyPart`` of a record (times t in s, displacement x in mm); see the module docstring."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    whole = SteadyPart(0, len(x))
    if len(x) < 8 or not np.ptp(x) > 0:
        return whole
    starts = half_cycle_starts(x)
    if len(starts) < MIN_STEADY + 1:
        return whole
    mid = 0.5 * (x.max() + x.min())
    edges = np.concatenate([starts, [len(x)]])
    peaks = np.array([np.max(np.abs(x[a:b] - mid)) for a, b in zip(edges[:-1], edges[1:])])
    steady = float(np.max(peaks))
    low = peaks < (1.0 - RAMP_TOLERANCE) * steady
    first = int(np.argmax(~low))
    last = len(peaks) - 1 - int(np.argmax(~low[::-1]))
    middle = peaks[first : last + 1]
    if len(middle) < MIN_STEADY or np.any(np.abs(middle - steady) > RAMP_TOLERANCE * steady):
        return whole  # not a constant-amplitude test: no steady part to speak of
    if first == 0 and last == len(peaks) - 1:
        return whole
    if max(first, len(peaks) - 1 - last) / 2.0 > MAX_RAMP_CYCLES:
        return whole  # smaller cycles for longer than a ramp: the test's protocol, not its ramps
    # The steady part runs from the crossing before its first half-cycle to the one after its last.
    start = _crossing_before(x, mid, int(edges[first])) if first > 0 else 0
    stop = _crossing_before(x, mid, int(edges[last + 1])) + 1 if last < len(peaks) - 1 else len(x)
    return SteadyPart(
        start,
        stop,
        first / 2.0,
        (len(peaks) - 1 - last) / 2.0,
        float(t[start] - t[0]) if first > 0 else 0.0,
        float(t[-1] - t[stop - 1]) if last < len(peaks) - 1 else 0.0,
    )


def _crossing_before(x, mid, index: int) -> int:
    """The last sample at or before ``index`` where x − mid changes sign (the half-cycle's true start)."""
    d = np.sign(x[: index + 1] - mid)
    changes = np.flatnonzero(d[1:] * d[:-1] <= 0)
    return int(changes[-1]) + 1 if len(changes) else 0
