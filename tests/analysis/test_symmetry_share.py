"""The share of the paper-coordinate scatter that is the exact symmetry."""

import numpy as np

from bwbench.analysis.spread import symmetry_share


def test_share_is_the_variance_that_fixing_the_gauge_removes():
    rng = np.random.default_rng(3)
    gauged = rng.normal(0.5, 0.01, (20, 14))
    paper = gauged.copy()
    paper[:, 0] += rng.normal(0, 0.03, 20)  # the symmetry moves one coordinate a lot
    expected = 1 - np.var(gauged, axis=0).sum() / np.var(paper, axis=0).sum()
    assert symmetry_share(paper, gauged) == expected and 0.3 < expected < 0.6
    # fixing the gauge spreads these fits out: none of the scatter is the symmetry, not a negative share
    assert symmetry_share(gauged, paper) == 0.0
    assert np.isnan(symmetry_share(paper[:1], gauged[:1]))
