"""Samplers compared like optimisers: another sampler's draws against a reference posterior (nested
sampling's, which holds every mode with its mass).

Each draw of the other sampler is put in the reference mode of its nearest reference draw when that
draw lies within the reference's mode cut (``bwbench.analysis.nested``: the same scaled distance that
separates its modes), else "outside every reference mode". A reference mode is **found** when the other
sampler puts at least ``FOUND_SHARE`` of the mode's reference mass in it (a mode of mass 0.3 needs 0.075
of the draws): a sampler stuck in one mode puts nothing in the others, and a sampler that visits a
mode only in passing gives it a few per cent at most. Masses are shown against the reference's, with the
reference's run-to-run spread, so a reader sees whether the other sampler weighs the modes rightly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FOUND_SHARE = 0.25  # a reference mode is found when the other sampler gives it ≥ this share of its mass


@dataclass(frozen=True)
class ModeShares:
    """``shares[k]``: the other sampler's share of draws in reference mode k; ``outside``: its share in
    no reference mode; ``reference``: the reference masses, ``spread``: their run-to-run spread."""

    shares: np.ndarray
    outside: float
    reference: np.ndarray
    spread: np.ndarray

    @property
    def found(self) -> np.ndarray:
        """Whether each reference mode is found (``FOUND_SHARE`` of its mass)."""
        return self.shares >= FOUND_SHARE * self.reference

    @property
    def all_found(self) -> bool:
        return bool(np.all(self.found))


def mode_shares(reference_draws: np.ndarray, verdict: dict, draws: np.ndarray) -> ModeShares:
    """The shares of ``draws`` (m, d) (unit coordinates) in the modes of a reference posterior:
    ``reference_draws`` (n, runs, d) or (n·runs, d) and its ``nested.assess`` verdict (``modes``,
    ``scale``, ``cut``)."""
    from scipy.spatial import cKDTree

    d = np.shape(draws)[-1]
    ref = np.asarray(reference_draws, dtype=float).reshape(-1, d)
    modes = verdict["modes"]
    label = np.full(len(ref), -1)
    for k, mode in enumerate(modes):
        label[mode.members] = k
    X = np.asarray(draws, dtype=float).reshape(-1, d)
    X = X[np.all(np.isfinite(X), axis=1)]
    if not len(X):
        return ModeShares(
            np.zeros(len(modes)), 1.0, np.array([m.mass for m in modes]), np.array([m.spread for m in modes])
        )
    distance, nearest = cKDTree(ref / verdict["scale"]).query(X / verdict["scale"], k=1)
    inside = distance <= verdict["cut"]
    which = np.where(inside, label[nearest], -1)
    shares = np.array([np.mean(which == k) for k in range(len(modes))])
    return ModeShares(
        shares, float(np.mean(which == -1)), np.array([m.mass for m in modes]), np.array([m.spread for m in modes])
    )


def mass_text(shares: ModeShares) -> str:
    """ "mode 1: 1.00 (reference 0.70 ± 0.02); mode 2: 0.00 (reference 0.30 ± 0.02)" (and the share
    outside every mode when there is one)."""
    parts = []
    for k, (s, r, e) in enumerate(zip(shares.shares, shares.reference, shares.spread)):
        ref = f"{r:.2f} ± {e:.2f}" if np.isfinite(e) else f"{r:.2f}"
        parts.append(f"mode {k + 1}: {s:.2f} (reference {ref})")
    if shares.outside >= 0.005:
        parts.append(f"outside every mode: {shares.outside:.2f}")
    return "; ".join(parts)


def found_text(shares: ModeShares) -> str:
    """ "yes (2 of 2)" or "no: misses mode 2 (1 of 2)"."""
    found = shares.found
    count = f"{int(found.sum())} of {len(found)}"
    if found.all():
        return f"yes ({count})"
    missed = [str(k + 1) for k in np.flatnonzero(~found)]
    return f"no: misses mode{'s' if len(missed) > 1 else ''} {', '.join(missed)} ({count})"
