"""Independent nested-sampling runs read together: the model evidence pooled, the modes with their
masses, and where a given fit lies against the draws (the verdict itself is
``bwbench.analysis.posterior_verdict.judge``).

Modes: single-linkage clustering of the pooled draws in coordinates scaled by each parameter's width of
one mode (``scale``),
cut at ``GAP`` times the median nearest-neighbour distance (modes are separated by a gap many times the
spacing of draws inside one); groups with less than ``MIN_MASS`` of the draws are joined to the nearest
mode (tail points, not modes). A point lies in a mode when its nearest draw is within that cut.

The prior is uniform on the search box in the searched coordinates, so ln Z is the log of the mean
likelihood over the box: widening the box by a factor c in a parameter the data pin down lowers ln Z by
ln c (``box_sensitivity``); the likelihood's constant (σ integrated out under Jeffreys' prior) is the
same for every model of the same data, so differences of ln Z (Bayes factors) are meaningful.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

AGREE_P = 0.01  # runs disagree (ln Z, mode masses) when a χ² test gives p below this
GAP = 6.0  # modes: single-linkage cut at GAP × the median nearest-neighbour distance of the draws
MIN_MASS = 0.02  # a group of fewer draws than this share is a tail, not a mode
MAX_CLUSTERED = 3000  # draws clustered (evenly thinned); the rest are assigned to the nearest clustered draw


@dataclass(frozen=True)
class Mode:
    """One mode: the pooled draw indices it holds (``members`` into the (n·runs) flattening, run-major
    by draw: index i·runs + k), its mass (share of all draws) and the mass in each run, and its best
    log-likelihood."""

    members: np.ndarray
    mass: float
    run_mass: np.ndarray
    best_log_like: float

    @property
    def spread(self) -> float:
        """Run-to-run standard deviation of the mode's mass."""
        return float(np.std(self.run_mass, ddof=1)) if len(self.run_mass) > 1 else float("nan")


def scale(draws: np.ndarray) -> np.ndarray:
    """Per-parameter unit of the distance: the width of one mode, not of the whole posterior — the median
    gap between neighbouring distinct values times their number (≈ 2.5 σ for a Gaussian; a gap between
    two modes is one gap and does not count), so modes apart in one parameter stay apart however many
    others there are. Floor 1e-12."""
    flat = draws.reshape(-1, draws.shape[-1])
    out = np.empty(flat.shape[1])
    for j in range(flat.shape[1]):
        values = np.unique(flat[:, j])
        out[j] = float(np.median(np.diff(values))) * len(values) if len(values) > 2 else 0.0
    return np.maximum(out, 1e-12)


def find_modes(draws: np.ndarray, log_prob: np.ndarray) -> tuple[list[Mode], float, np.ndarray]:
    """The modes of draws (n, runs, d), biggest first; also the cut distance (scaled units) and the scale."""
    from scipy.cluster.hierarchy import fcluster, linkage
    from scipy.spatial import cKDTree

    n, runs, d = draws.shape
    flat, lp = draws.reshape(-1, d), log_prob.reshape(-1)
    unit = scale(draws)
    X = flat / unit
    # the geometry of the distinct draws (a run's weighted points resampled repeat its heavy ones): a
    # repeated draw would stand at distance 0 from itself
    distinct = np.unique(X, axis=0)
    step = max(1, -(-len(distinct) // MAX_CLUSTERED))
    Xp = distinct[np.arange(0, len(distinct), step)]
    tree = cKDTree(Xp)
    near = tree.query(Xp, k=2)[0][:, 1] if len(Xp) > 1 else np.zeros(1)
    cut = GAP * float(np.median(near[near > 0])) if np.any(near > 0) else 1e-9
    labels_picked = (
        fcluster(linkage(Xp, method="single"), t=cut, criterion="distance") if len(Xp) > 1 else np.ones(1, dtype=int)
    )
    labels = labels_picked[tree.query(X, k=1)[1]]
    # tails: groups below MIN_MASS join the group of their nearest draw in a big group
    counts = {g: int(np.sum(labels == g)) for g in np.unique(labels)}
    big = [g for g, c in counts.items() if c >= MIN_MASS * len(X)] or [max(counts, key=counts.__getitem__)]
    small = ~np.isin(labels, big)
    if small.any():
        keep = ~small
        labels[small] = labels[keep][cKDTree(X[keep]).query(X[small], k=1)[1]]
    run_of = np.tile(np.arange(runs), n)
    modes = []
    for g in big:
        members = np.flatnonzero(labels == g)
        run_mass = np.array([np.mean(labels[run_of == k] == g) for k in range(runs)])
        finite = lp[members][np.isfinite(lp[members])]
        modes.append(Mode(members, len(members) / len(X), run_mass, float(finite.max()) if finite.size else -np.inf))
    modes.sort(key=lambda m: -m.mass)
    return modes, cut, unit


def evidence(log_z, log_z_err) -> dict:
    """The runs' ln Z pooled: ``log_z`` (inverse-variance weighted mean), ``err`` (its error, at least the
    runs' scatter over √runs), ``p`` (χ² test that the runs agree within their errors), ``agree``."""
    from scipy.stats import chi2

    z, e = np.asarray(log_z, float), np.maximum(np.asarray(log_z_err, float), 1e-6)
    w = 1 / e**2
    mean = float(np.sum(w * z) / np.sum(w))
    err = float(np.sqrt(1 / np.sum(w)))
    if len(z) > 1:
        err = max(err, float(np.std(z, ddof=1) / np.sqrt(len(z))))
        p = float(chi2.sf(np.sum(w * (z - mean) ** 2), len(z) - 1))
    else:
        p = float("nan")
    return {"log_z": mean, "err": err, "p": p, "agree": bool(len(z) < 2 or p >= AGREE_P)}


def locate(point, log_like: float, draws: np.ndarray, log_prob: np.ndarray, assessment: dict) -> dict:
    """Where a point (unit coordinates, log-likelihood ``log_like``) lies against the posterior's draws.

    ``where``: "mode" (its nearest draw within the mode cut: ``mode`` is its 0-based index), "below"
    (outside every draw and less likely than the draws' support: ``delta`` = the draws' 0.5 % quantile
    of log-likelihood minus the point's, > 0), or "missed" (outside every draw yet at least as likely as
    the draws' support: the sampler missed a mode at least as probable as this point). Also "missed",
    wherever it lies, a point more likely than every draw by more than d nats: with a flat prior a
    posterior's draws come within ~d/2 of its best likelihood (χ²_d/2), so draws that never reach the
    point's likelihood have not found its region."""
    d = draws.shape[-1]
    flat, lp = draws.reshape(-1, d), log_prob.reshape(-1)
    X = flat / assessment["scale"]
    x = np.asarray(point, float) / assessment["scale"]
    distance = np.sqrt(np.sum((X - x) ** 2, axis=1))
    nearest = int(np.argmin(distance))
    floor = float(np.quantile(lp[np.isfinite(lp)], 0.005)) if np.isfinite(lp).any() else -np.inf
    top = float(np.max(lp[np.isfinite(lp)])) if np.isfinite(lp).any() else -np.inf
    if log_like > top + d:
        return {"where": "missed", "mode": None, "delta": floor - log_like, "distance": float(distance[nearest])}
    if distance[nearest] <= assessment["cut"]:
        mode = next((i for i, m in enumerate(assessment["modes"]) if nearest in set(m.members.tolist())), 0)
        return {"where": "mode", "mode": mode, "delta": floor - log_like, "distance": float(distance[nearest])}
    if log_like < floor:
        return {"where": "below", "mode": None, "delta": floor - log_like, "distance": float(distance[nearest])}
    return {"where": "missed", "mode": None, "delta": floor - log_like, "distance": float(distance[nearest])}


def box_sensitivity(widths_ratio) -> float:
    """Change of ln Z when the box of pinned-down parameters widens by ``widths_ratio`` (one factor per
    parameter, or their product): −Σ ln c (the prior's density falls, the likelihood's mass does not)."""
    return -float(np.sum(np.log(np.asarray(widths_ratio, dtype=float))))


def bayes_factors(log_z: dict) -> dict:
    """{model: ln B against the best model} (0 for the best, negative for the others)."""
    best = max(log_z.values())
    return {m: float(z - best) for m, z in log_z.items()}
