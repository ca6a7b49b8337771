"""Why good fits scatter across seeds: the data (the posterior is that wide) or the optimiser (it
stopped before the posterior's bulk, or in another mode).

The posterior is the reference of what the data allow: its draws are, by construction, the parameter
values the data cannot tell apart, and its log-probabilities say how probable such values are. A fit
of an optimiser is

- *in the posterior* when its log-posterior is at least the 1 % quantile of the draws' (``FLOOR``):
  it is as probable as the posterior's own draws; where it lies, the data put it;
- *stopped early* when its log-posterior is below that: the optimiser stopped before the posterior's
  bulk (a fit 10 % above the best MSE is e^(L/2·log 1.1) ≈ e^90 less probable on L ≈ 1,900 samples).

Per parameter, the fits outside the range the posterior's draws cover (their central 99 %: wider than
a 95 % interval so that the peak of a skewed posterior, where optimisers stop, counts as inside) are
the scatter the data do not explain: those stopped early are the optimiser's; those as probable as
the draws but where the draws (almost) never go lie in another mode the chain did not visit.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

FLOOR = 0.01  # quantile of the draws' log-probability a fit must reach to be "in the posterior"
LEVEL = 0.99  # the range of the draws a fit must lie in, per parameter

DATA, EARLY, ELSEWHERE = "in the posterior", "stopped early", "as probable, elsewhere"


def classify(fits_log_prob, draws_log_prob) -> np.ndarray:
    """True for each fit whose log-posterior reaches the ``FLOOR`` quantile of the posterior draws'."""
    floor = float(np.quantile(np.asarray(draws_log_prob, dtype=float), FLOOR))
    return np.asarray(fits_log_prob, dtype=float) >= floor


def decompose(fits, fits_log_prob, draws, draws_log_prob, names) -> tuple[pd.DataFrame, np.ndarray]:
    """Per parameter, the scatter of the good fits against the posterior, and each fit's class.

    ``fits`` (n, d) and ``draws`` (m, d) in the same coordinates (e.g. units of the search box, so
    widths compare across parameters); ``*_log_prob`` their log-posteriors, (n,) and (m,).

    Returns a table with, per parameter: ``fits_spread`` (max − min of the fits), ``posterior_width``
    (the draws' central 99 %), ``inside`` (fits inside it), ``stopped_early`` and
    ``elsewhere`` (fits outside it, by class) and ``scatter`` (whose the scatter is: "the data" when
    every fit is inside, else "the optimiser" when most fits outside stopped early, else "another
    mode"); and per fit its class (``DATA``, ``EARLY``, ``ELSEWHERE``).
    """
    fits, draws = np.atleast_2d(np.asarray(fits, dtype=float)), np.atleast_2d(np.asarray(draws, dtype=float))
    reached = classify(fits_log_prob, draws_log_prob)
    tail = (1 - LEVEL) / 2
    lo, hi = np.quantile(draws, [tail, 1 - tail], axis=0)
    inside = (fits >= lo) & (fits <= hi)
    rows = []
    for j, name in enumerate(names):
        out = ~inside[:, j]
        early, other = int(np.sum(out & ~reached)), int(np.sum(out & reached))
        scatter = "the data" if not out.any() else ("the optimiser" if early >= other else "another mode")
        rows.append(
            {
                "parameter": name,
                "fits_spread": float(np.ptp(fits[:, j])) if len(fits) else np.nan,
                "posterior_width": float(hi[j] - lo[j]),
                "inside": int(np.sum(inside[:, j])),
                "stopped_early": early,
                "elsewhere": other,
                "scatter": scatter,
            }
        )
    kind = np.where(~reached, EARLY, np.where(np.all(inside, axis=1), DATA, ELSEWHERE))
    return pd.DataFrame(rows), kind


def symmetry_share(paper_unit: np.ndarray, gauged_unit: np.ndarray) -> float:
    """Fraction of the total variance of the direct coordinates (box units) that fixing the
    gauge removes: the part of the scatter that is the exact symmetry. NaN with fewer than 2 runs; 0
    when fixing the gauge does not shrink the scatter (it can move fits apart: then none of it is the
    symmetry, never a negative share)."""
    keep = np.all(np.isfinite(paper_unit), axis=1) & np.all(np.isfinite(gauged_unit), axis=1)
    if keep.sum() < 2:
        return float("nan")
    before = float(np.sum(np.var(paper_unit[keep], axis=0)))
    after = float(np.sum(np.var(gauged_unit[keep], axis=0)))
    return max(0.0, 1.0 - after / before) if before > 0 else float("nan")
