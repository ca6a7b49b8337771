"""The verdict on a posterior from independent nested-sampling runs: convergence across runs, the model
evidence, the modes with their masses, and where a given fit lies against the draws.

Input: equal-weight draws of each run side by side, ``draws`` (n, runs, d) in unit coordinates, their
log-likelihoods ``log_prob`` (n, runs), and each run's ln Z with its error. Converged when all of:

- **R̂ and ESS**: ArviZ's rank-normalised split-R̂ ≤ 1.01 and bulk ESS ≥ 400 for every parameter, each
  run's draws taken as one chain (nothing dropped: nested sampling has no burn-in);
- **ln Z**: the runs agree within their stated errors (χ² of the runs' ln Z about their weighted mean,
  p ≥ ``AGREE_P``);
- **mode masses**: each mode holds the same share of every run's draws (χ² test of the runs × modes
  counts, p ≥ ``AGREE_P``; the draws of a run are nearly independent, so the counts are multinomial);
- **every run complete**: none was cut by the budget before its own stopping rule.

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

from bwbench.analysis import mcmc

AGREE_P = 0.01  # runs disagree (ln Z, mode masses) when a χ² test gives p below this
GAP = 6.0  # modes: single-linkage cut at GAP × the median nearest-neighbour distance of the draws
MIN_MASS = 0.02  # a group of fewer draws than this share is a tail, not a mode
MIN_DRAWS = 4  # ArviZ's R̂ needs at least this many draws per chain
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
    step = max(1, -(-len(X) // MAX_CLUSTERED))
    picked = np.arange(0, len(X), step)
    tree = cKDTree(X[picked])
    near = tree.query(X[picked], k=2)[0][:, 1]
    cut = GAP * float(np.median(near[near > 0])) if np.any(near > 0) else 1e-9
    labels_picked = (
        fcluster(linkage(X[picked], method="single"), t=cut, criterion="distance")
        if len(picked) > 1
        else np.ones(1, dtype=int)
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


def masses_agree(modes: list[Mode], draws_per_run: int) -> tuple[bool, float]:
    """(agree, p) of the χ² test that every run puts the same share of its draws in each mode."""
    from scipy.stats import chi2_contingency

    if len(modes) < 2 or len(modes[0].run_mass) < 2:
        return True, float("nan")
    counts = np.array([m.run_mass * draws_per_run for m in modes]).T  # runs × modes
    counts = counts[:, counts.sum(axis=0) > 0]
    if counts.shape[1] < 2:
        return True, float("nan")
    p = float(chi2_contingency(np.round(counts))[1])
    return p >= AGREE_P, p


def assess(
    draws: np.ndarray,
    log_prob: np.ndarray,
    log_z,
    log_z_err,
    names,
    complete=None,
    runs_asked: int | None = None,
    best_fit=None,
) -> dict:
    """The verdict on draws (n, runs, d) of independent runs (see the module's docstring).

    ``best_fit``: (unit point, log-likelihood, label) of the best fit found otherwise (e.g. the ranking's):
    with a flat prior the highest-likelihood region holds it, so if it lies outside every draw at least as
    probable as their support (``locate``: "missed"), the sampler missed a mode and the posterior is
    not converged, whatever R̂ says. Its place is ``best_fit_place``.

    Returns ``converged``, ``failed`` (the criteria that failed, plain phrases), ``diagnostics`` (the
    ``mcmc.convergence`` table), ``evidence`` (``evidence``), ``modes`` (``find_modes``), ``masses_p``,
    ``cut``, ``scale`` and ``message`` (one paragraph)."""
    import pandas as pd

    n, runs, _ = draws.shape
    names = list(names)
    if n >= MIN_DRAWS:
        with np.errstate(over="ignore", invalid="ignore"):
            table = mcmc.convergence(draws, names, burn=0)
    else:  # ArviZ needs 4 draws per chain: no R̂ at all
        table = pd.DataFrame({"parameter": names, "r_hat": np.nan, "ess_bulk": np.nan, "ess_tail": np.nan})
    ev = evidence(log_z, log_z_err)
    modes, cut, unit = find_modes(draws, log_prob)
    agree, p_mass = masses_agree(modes, n)
    failed = []
    worst = np.asarray(table["r_hat"], float)
    ess = np.asarray(table["ess_bulk"], float)
    if runs < 2:
        failed.append("fewer than 2 runs: R̂ needs independent runs")
    bad = [
        f"{name} (R̂ {r:.3f}, bulk ESS {e:.0f})"
        for name, r, e in zip(names, worst, ess)
        if not (r <= mcmc.R_HAT_MAX and e >= mcmc.ESS_MIN)
    ]
    if n < MIN_DRAWS:
        failed.append(f"only {n} equal-weight draw{'s' if n != 1 else ''} per run: too few for R̂ and ESS")
    elif bad:
        if len(bad) > 4:
            bad = bad[:4] + [f"and {len(bad) - 4} more"]
        failed.append(f"R̂ ≤ {mcmc.R_HAT_MAX:g} and bulk ESS ≥ {mcmc.ESS_MIN}: " + ", ".join(bad))
    if not ev["agree"]:
        failed.append(
            f"the runs' ln Z disagree beyond their errors ({', '.join(f'{z:.2f}' for z in log_z)}; "
            f"χ² p = {ev['p']:.2g})"
        )
    if not agree:
        failed.append(
            "the runs put different masses in the modes ("
            + "; ".join(
                f"mode {i + 1}: " + ", ".join(f"{m:.2f}" for m in mode.run_mass) for i, mode in enumerate(modes)
            )
            + f"; χ² p = {p_mass:.2g})"
        )
    if complete is not None and not all(complete):
        failed.append(
            f"{sum(not c for c in complete)} of {len(complete)} runs cut by the budget before their stopping rule"
        )
    if runs_asked is not None and runs < runs_asked:
        failed.append(f"only {runs} of {runs_asked} runs had budget to start")
    place = None
    if best_fit is not None:
        point, like, label = best_fit
        place = locate(point, like, draws, log_prob, {"scale": unit, "cut": cut, "modes": modes})
        if place["where"] == "missed":
            failed.append(
                f"the sampler missed a mode at least as probable as {label} (log-likelihood {like:.1f}, "
                f"where no draw goes; the draws' best {np.nanmax(log_prob):.1f})"
            )
    converged = not failed
    text = (
        f"{runs} runs, {n:,} equal-weight draws each; ln Z = {ev['log_z']:.2f} ± {ev['err']:.2f}; "
        f"{len(modes)} mode{'s' if len(modes) > 1 else ''} (masses "
        + ", ".join(f"{m.mass:.2f} ± {m.spread:.2f}" for m in modes)
        + "); "
    )
    text += (
        "converged: R̂ ≤ 1.01 and bulk ESS ≥ 400 for every parameter, the runs agree on ln Z and on the mode masses"
        if converged
        else "not converged: " + "; ".join(failed)
    )
    return {
        "converged": converged,
        "failed": failed,
        "diagnostics": table,
        "evidence": ev,
        "modes": modes,
        "masses_p": p_mass,
        "cut": cut,
        "scale": unit,
        "message": text,
        "best_fit_place": place,
    }


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
