"""The loading protocol of a record: its reversals of motion (with a dead band against jitter), and
what kind of test they make — constant amplitude, cyclic with growing amplitude, a monotonic push,
or irregular (random, broadband, an earthquake record: not periodic).

Reversals are found on the displacement alone, as a rate-independent model sees the path: the
direction of motion changes only once the displacement has gone back by more than the dead band
``dead_band(x)`` from its last extreme, and the reversal is put at that extreme. The band is
``BAND_NOISE`` × the displacement noise (``derivatives.robust_noise``) and at least ``BAND_FRACTION`` ×
the amplitude: a digitised curve's points jitter back and forth by a fraction of a per cent of full
scale, which must not flip a switched model's branch, while a real cycle is far larger.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BAND_NOISE = 3.0
BAND_FRACTION = 0.01
# Half-cycle amplitudes within this fraction of their median: a constant-amplitude test.
CONSTANT_TOLERANCE = 0.1
# A record whose half-cycle amplitudes grow (rank correlation with their order at least GROWING_RANK)
# from the first to the largest by at least GROWING_RATIO is cyclic with growing amplitude.
GROWING_RANK = 0.7
GROWING_RATIO = 2.0


def dead_band(x) -> float:
    """The displacement (mm) the motion must go back by before a reversal counts (module docstring)."""
    from bwbench.models.derivatives import robust_noise

    x = np.asarray(x, dtype=float)
    return max(BAND_NOISE * robust_noise(x), BAND_FRACTION * 0.5 * float(np.ptp(x)))


def reversals(x, band: float | None = None) -> np.ndarray:
    """Indices of the extremes where the motion reverses (``dead_band``), in order."""
    x = np.asarray(x, dtype=float)
    band = dead_band(x) if band is None else band
    out = []
    direction = 0
    extreme = 0
    for k in range(1, len(x)):
        if direction == 0:
            if abs(x[k] - x[0]) > band:
                direction = 1 if x[k] > x[0] else -1
                extreme = k
            elif (x[k] - x[extreme]) * (x[k] - x[0]) > 0 and abs(x[k] - x[0]) > abs(x[extreme] - x[0]):
                extreme = k
            continue
        if (x[k] - x[extreme]) * direction > 0:
            extreme = k
        elif (x[extreme] - x[k]) * direction > band:
            out.append(extreme)
            direction = -direction
            extreme = k
    return np.array(out, dtype=np.int64)


def directions(x, band: float | None = None) -> np.ndarray:
    """The direction of motion at each sample: +1 or −1 between reversals, 0 at a reversal (the
    extreme itself), the first run's direction from the start. What a quasi-static record gives a
    model as its velocity: the branch, never a rate."""
    x = np.asarray(x, dtype=float)
    rev = reversals(x, band)
    out = np.empty(len(x))
    edges = [0, *rev.tolist(), len(x) - 1]
    for a, b in zip(edges[:-1], edges[1:]):
        out[a : b + 1] = 1.0 if x[b] >= x[a] else -1.0
    out[rev] = 0.0
    return out


@dataclass(frozen=True)
class Protocol:
    """``kind``: "constant amplitude", "growing amplitude", "monotonic", "short" (under 3 reversals) or
    "irregular"; ``cycles``:
    half-cycles / 2; ``amplitudes``: each half-cycle's half range (mm)."""

    kind: str
    cycles: float
    amplitudes: np.ndarray

    @property
    def periodic(self) -> bool:
        """Cyclic motion whose per-cycle quantities (energy per cycle, reversal statistics) mean something."""
        return self.kind in ("constant amplitude", "growing amplitude")

    def describe(self) -> str:
        a = self.amplitudes
        if self.kind == "monotonic":
            return "monotonic (no reversal of motion)"
        if self.kind == "short":
            return f"{len(a) - 1} reversal{'s' if len(a) > 2 else ''} of motion: too few cycles to name a protocol"
        if self.kind == "constant amplitude":
            return f"constant amplitude ±{np.median(a):.3g} mm, {self.cycles:g} cycles"
        if self.kind == "growing amplitude":
            first = a[1] if len(a) > 4 else a[0]  # the first whole half-cycle
            return f"cyclic with growing amplitude: {self.cycles:g} cycles, ±{first:.3g} → ±{a.max():.3g} mm"
        return (
            f"irregular (random, broadband or a recorded motion; not periodic): {len(a) - 1} reversals, "
            f"half-cycles of ±{a.min():.3g} … ±{a.max():.3g} mm"
        )


def protocol(x) -> Protocol:
    """The ``Protocol`` of a displacement record (mm)."""
    x = np.asarray(x, dtype=float)
    rev = reversals(x)
    edges = np.concatenate([[0], rev, [len(x) - 1]])
    amplitudes = 0.5 * np.abs(np.diff(x[edges]))
    cycles = len(rev) / 2.0
    if len(rev) == 0:
        return Protocol("monotonic", 0.0, amplitudes)
    if len(rev) < 3:
        return Protocol("short", cycles, amplitudes)
    # the first and last half-cycles start or stop anywhere: judged on the whole ones where there are enough
    whole = amplitudes[1:-1] if len(amplitudes) > 4 else amplitudes
    median = float(np.median(whole))
    if np.all(np.abs(whole - median) <= CONSTANT_TOLERANCE * median) or _ramped(x):
        return Protocol("constant amplitude", cycles, amplitudes)
    if len(whole) >= 4 and whole.max() >= GROWING_RATIO * whole[0] and _rank(whole) >= GROWING_RANK:
        return Protocol("growing amplitude", cycles, amplitudes)
    return Protocol("irregular", cycles, amplitudes)


def _ramped(x) -> bool:
    """A constant-amplitude test ramped in or out (``steady_part``) is still a constant-amplitude test."""
    from bwbench.data.steady_part import steady_part

    return steady_part(np.arange(len(x), dtype=float), x).ramped


def _rank(values) -> float:
    """Spearman's rank correlation of ``values`` with their order."""
    ranks = np.argsort(np.argsort(values, kind="stable"), kind="stable")
    order = np.arange(len(values))
    if np.ptp(ranks) == 0:
        return 0.0
    return float(np.corrcoef(ranks, order)[0, 1])
