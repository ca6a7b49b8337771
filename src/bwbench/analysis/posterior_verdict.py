"""The verdict on a posterior from independent runs: the one function (``judge``) whose words the sampler's
message, the terminal, the report and the API all show.

Input: each run's equal-weight draws side by side, ``draws`` (n, runs, d) in unit coordinates, their
log-likelihoods (n, runs), and what each run said of itself (its ln Z and error, whether it ended by its own
rule, its Kish effective sample size, UltraNest's insertion-order test). The verdict has three parts:

**Hard checks**, any one failed means "not converged":

1. every run ended by its own stopping rule (none cut by the budget);
2. the runs' ln Z agree within their stated errors (χ² p ≥ ``AGREE_P``);
3. every run puts mass into every region holding ≥ ``REGION_MIN`` of the pooled mass (a run holding less
   than ``MISSING`` of a region's pooled share has missed it): what a run that never found the thin part
   of a posterior looks like;
4. every run passes UltraNest's insertion-order test (a new live point's rank among the live points is
   uniform when the sampler draws from the constrained prior; Buchner 2023, §4.5.2): the check that sees
   a bias all runs share, which agreement between runs cannot;
5. the best fit found otherwise (the ranking's best, and its other good fits) lies inside the posterior:
   with a flat prior the highest-likelihood region holds it, so draws that never come near it while it is
   as probable missed a mode (``nested.locate``), whatever the runs' agreement.

**Precision from the scatter between runs** (never from each run's own error, which on the default
specimen understated the runs' scatter of a region's mass ~13×): the standard error of the pooled mean
and of the pooled 5 % and 95 % quantiles of every parameter, from the runs' own estimates (sd over runs
/ √runs), within ``TARGET_SD`` posterior standard deviations — in the searched coordinates, where the
prior is uniform (log for a log-scaled box: a long physical tail would swamp the sd), and of every region's mass within
``TARGET_MASS``. Needs ``MIN_RUNS`` runs. When it fails, the runs it would take follow from the SE's
1/√runs (``needed``).

**The badge** "runs reproduce each other": ArviZ's rank-normalised split-R̂ ≤ 1.01 and bulk ESS ≥ 400
for every parameter, each run's draws one chain, computed only when every run holds ≥ ``BADGE_DRAWS``
effective draws (below that a perfect sampler fails R̂ ≤ 1.01 in 7 parameters about a quarter of the
time). It is shown, it does not decide: the precision does.

Regions: the posterior's separate modes when it has several (``nested.find_modes``), else its pooled
draws partitioned by k-means (``REGIONS`` clusters, coordinates scaled by their pooled sd, fixed seed):
a part of the posterior that a run missed shows as a region it holds no mass in, and runs that split
the mass differently show as the scatter of the region masses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import pandas as pd

from bwbench.analysis import mcmc, nested

AGREE_P = nested.AGREE_P  # runs' ln Z disagree when a χ² test gives p below this
REGION_MIN = 0.05  # regions holding at least this share of the pooled mass must be in every run
MISSING = 0.1  # a run has missed a region when its share there is below this fraction of the pooled share
TARGET_SD = 0.1  # pooled mean and 5/95 % quantiles: standard error within this many posterior sd
TARGET_MASS = 0.05  # each region's pooled mass: standard error within this
MIN_RUNS = 3  # the scatter between fewer runs says too little of the precision
BADGE_DRAWS = 300  # R̂/ESS only on at least this many effective draws per run
REGIONS = 4  # k-means clusters of the pooled draws
QUANTILES = (0.05, 0.95)


@dataclass
class Check:
    """One hard check: ``passed`` is None when it could not be made (e.g. no insertion-order test)."""

    name: str
    passed: bool | None
    detail: str


@dataclass
class Region:
    """A part of the posterior: its ``label`` (the parameter that sets it apart, with its range), pooled
    ``mass``, each run's mass ``run_mass``, and ``members`` (bool over the (n·runs) flattening, draw-major:
    index i·runs + k)."""

    label: str
    mass: float
    run_mass: np.ndarray
    members: np.ndarray

    @property
    def se(self) -> float:
        """Standard error of the pooled mass from the runs' scatter."""
        r = len(self.run_mass)
        return float(np.std(self.run_mass, ddof=1) / math.sqrt(r)) if r > 1 else float("nan")

    @property
    def spread(self) -> str:
        """'0.20–0.52 across runs'."""
        return f"{self.run_mass.min():.2f}–{self.run_mass.max():.2f} across runs"


@dataclass
class Verdict:
    """``judge``'s answer. ``line`` is the one line every display shows first; ``reasons`` the failed
    checks and targets in plain words (empty when converged)."""

    converged: bool
    runs: int
    draws_per_run: int
    checks: list
    precision: pd.DataFrame
    precision_met: bool | None
    regions: list
    badge: dict
    needed: dict | None
    reasons: list
    line: str
    evidence: dict
    modes: list = field(default_factory=list)
    cut: float = float("nan")
    scale: np.ndarray | None = None
    best_fit_place: dict | None = None
    diagnostics: pd.DataFrame | None = None

    # the names the report's readers of the earlier verdict use
    _ALIASES = {"failed": "reasons", "message": "line"}

    def __getitem__(self, key: str):
        return getattr(self, self._ALIASES.get(key, key))

    def as_dict(self) -> dict:
        """Plain values for JSON and the API: converged, reasons, line, checks, precision, regions, badge."""
        return {
            "converged": self.converged,
            "line": self.line,
            "reasons": list(self.reasons),
            "runs": self.runs,
            "checks": [{"check": c.name, "passed": c.passed, "detail": c.detail} for c in self.checks],
            "precision_met": self.precision_met,
            "regions": [
                {"region": r.label, "mass": r.mass, "se": r.se, "run_mass": [float(m) for m in r.run_mass]}
                for r in self.regions
            ],
            "badge": {k: v for k, v in self.badge.items() if k != "table"},
            "needed": self.needed,
        }


def judge(
    draws: np.ndarray,
    log_prob: np.ndarray,
    log_z,
    log_z_err,
    names,
    *,
    complete=None,
    ess=None,
    insertion=None,
    run_nfev=None,
    steps=None,
    best_fit=None,
    from_unit=None,
    labels=None,
    runs_asked: int | None = None,
) -> Verdict:
    """The verdict on draws (n, runs, d) of independent runs (see the module's docstring).

    ``complete``, ``ess``, ``insertion`` (True/False/None), ``run_nfev``, ``steps`` (slice steps per new
    point): one per run; ``best_fit``: (unit point, log-likelihood, label) of the best fit found otherwise,
    or a list of such, best first (the ranking's good fits); ``from_unit``: unit → physical
    rows (precision and region ranges are computed on physical values; default: the unit coordinates);
    ``labels``: display names with units, one per parameter (default ``names``)."""
    n, runs, d = draws.shape
    names = list(names)
    labels = list(labels) if labels is not None else names
    flat = draws.reshape(-1, d)
    physical = np.asarray(from_unit(flat), float) if from_unit is not None else flat
    P = physical.reshape(n, runs, d)
    ev = nested.evidence(log_z, log_z_err)
    modes, cut, unit = nested.find_modes(draws, log_prob)
    regions = find_regions(draws, P, labels, modes)
    checks = _hard_checks(runs, complete, ev, log_z, regions, insertion, runs_asked)
    doubled = steps_check(P, steps, labels)
    if doubled is not None:
        checks.append(doubled)
    fits = [] if best_fit is None else [best_fit] if isinstance(best_fit, tuple) else list(best_fit)
    places = [
        nested.locate(point, like, draws, log_prob, {"scale": unit, "cut": cut, "modes": modes})
        for point, like, _ in fits
    ]
    place = places[0] if places else None
    if fits:
        checks.append(_fits_check(fits, places, log_prob))
    precision = precision_table(draws, labels, from_unit)
    met = _precision_met(precision, regions, runs)
    ess_runs = np.asarray(ess, float) if ess is not None else np.full(runs, float(n))
    badge = reproduce_badge(draws, names, ess_runs)
    needed = _needed(precision, regions, runs, run_nfev, complete)
    reasons = [c.detail for c in checks if c.passed is False]
    if met is False:
        reasons.append(_precision_text(precision, regions, runs, needed))
    elif met is None:
        reasons.append(f"only {runs} run{'s' if runs != 1 else ''}: the precision needs the scatter of ≥ {MIN_RUNS}")
    converged = not reasons
    line = _line(converged, reasons, runs, n, precision, regions)
    return Verdict(
        converged=converged,
        runs=runs,
        draws_per_run=n,
        checks=checks,
        precision=precision,
        precision_met=met,
        regions=regions,
        badge=badge,
        needed=needed,
        reasons=reasons,
        line=line,
        evidence=ev,
        modes=modes,
        cut=cut,
        scale=unit,
        best_fit_place=place,
        diagnostics=badge.get("table"),
    )


def _fits_check(fits, places, log_prob) -> Check:
    """Check 5: no good fit found otherwise lies where no draw goes while as probable as the draws."""
    missed = [(label, like) for (_, like, label), place in zip(fits, places) if place["where"] == "missed"]
    if not missed:
        return Check(
            "good fits inside",
            True,
            f"{fits[0][2]} lies "
            + (f"in mode {places[0]['mode'] + 1}" if places[0]["where"] == "mode" else "below the posterior's support")
            + (f", and so do the other {len(fits) - 1} good fits (or below)" if len(fits) > 1 else ""),
        )
    label, like = missed[0]
    return Check(
        "good fits inside",
        False,
        f"the sampler missed a mode at least as probable as {label} (log-likelihood {like:.1f}, where no draw "
        f"goes; the draws' best {np.nanmax(log_prob):.1f})"
        + (f"; {len(missed) - 1} more good fit(s) likewise" if len(missed) > 1 else ""),
    )


def _hard_checks(runs, complete, ev, log_z, regions, insertion, runs_asked) -> list:
    checks = []
    complete = list(complete) if complete is not None else [True] * runs
    cut = [k + 1 for k, c in enumerate(complete) if not c]
    checks.append(
        Check(
            "runs complete",
            not cut and (runs_asked is None or runs >= runs_asked),
            f"{len(cut)} of {runs} runs cut by the budget before their stopping rule (run "
            + ", ".join(map(str, cut))
            + ")"
            if cut
            else f"only {runs} of {runs_asked} runs had budget to start"
            if runs_asked is not None and runs < runs_asked
            else f"all {runs} runs ended by their own rule",
        )
    )
    if runs < 2:
        checks.append(Check("runs agree", False, "only one run: nothing to say it reproduces"))
        return checks
    checks.append(
        Check(
            "ln Z agree",
            bool(ev["agree"]),
            f"the runs' ln Z agree (χ² p = {ev['p']:.2g})"
            if ev["agree"]
            else f"the runs' ln Z disagree beyond their errors ({', '.join(f'{z:.2f}' for z in log_z)}; "
            f"χ² p = {ev['p']:.2g})",
        )
    )
    missing = [
        f"{r.label} (pooled {r.mass:.2f}; run {k + 1}: {m:.3f})"
        for r in regions
        if r.mass >= REGION_MIN
        for k, m in enumerate(r.run_mass)
        if m < MISSING * r.mass
    ]
    checks.append(
        Check(
            "every region in every run",
            not missing,
            "a run missed a region holding ≥ 5 % of the pooled mass: " + "; ".join(missing[:3])
            if missing
            else "every run puts mass in every region holding ≥ 5 % of the pooled mass",
        )
    )
    if insertion is not None and any(t is not None for t in insertion):
        failed = [k + 1 for k, t in enumerate(insertion) if t is False]
        checks.append(
            Check(
                "insertion order",
                not failed,
                f"UltraNest's insertion-order test fails in run {', '.join(map(str, failed))}: the new live points "
                "are not drawn uniformly within the likelihood contour (more slice steps needed)"
                if failed
                else "UltraNest's insertion-order test passes in every run",
            )
        )
    return checks


def steps_check(P: np.ndarray, steps, labels) -> Check | None:
    """The slice steps checked by doubling (UltraNest's advice): the runs that took more steps per new
    point against the others, parameter by parameter (Welch-like t on the runs' means, the base runs'
    scatter as the unit; Bonferroni over the parameters at p < ``AGREE_P``). None without at least one
    run of each kind and two base runs."""
    from scipy.stats import t as student

    if steps is None:
        return None
    steps = np.asarray(steps)
    more = steps > steps.min()
    if more.sum() < 1 or (~more).sum() < 2:
        return None
    means = P.mean(axis=0)  # (runs, d)
    a, b = means[~more], means[more]
    sd = a.std(axis=0, ddof=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.abs(b.mean(axis=0) - a.mean(axis=0)) / (sd * math.sqrt(1 / len(a) + 1 / len(b)))
    t = np.where(sd > 0, t, 0.0)
    p = 2 * student.sf(t, df=len(a) - 1)
    j = int(np.argmin(p))
    worst = float(min(1.0, p[j] * P.shape[2]))
    which = ", ".join(str(k + 1) for k in np.flatnonzero(more))
    if worst >= AGREE_P:
        return Check(
            "steps doubled",
            True,
            f"the slice steps checked by doubling: run {which} took {int(steps.max())} steps per new point instead "
            f"of {int(steps.min())} and agrees with the others (largest difference {labels[j]}, p = {worst:.2g})",
        )
    return Check(
        "steps doubled",
        False,
        f"the runs with doubled slice steps (run {which}: {int(steps.max())} per new point instead of "
        f"{int(steps.min())}) differ from the others in {labels[j]} (mean {b[:, j].mean():.4g} against "
        f"{a[:, j].mean():.4g}, p = {worst:.2g}): too few steps",
    )


def find_regions(draws: np.ndarray, physical: np.ndarray, labels, modes=None) -> list:
    """The parts of the posterior whose masses the runs must agree on, biggest first: its separate modes
    (``nested.find_modes``) when it has several holding ≥ ``REGION_MIN`` each, else the pooled draws cut
    by k-means into ``REGIONS`` (coordinates scaled by their pooled sd, fixed seed). Each is labelled by
    the parameter that sets it apart most (its median furthest from the rest's, in pooled sd) with its
    central 90 % range there."""
    n, runs, d = draws.shape
    groups = [m.members for m in (modes or []) if m.mass >= REGION_MIN]
    if len(groups) < 2:
        groups = _kmeans(draws)
    if len(groups) < 2:
        return [Region("the whole posterior", 1.0, np.ones(runs), np.ones(n * runs, bool))]
    run_of = np.tile(np.arange(runs), n)
    phys = physical.reshape(-1, d)
    psd = phys.std(axis=0)
    out = []
    for index in groups:
        members = np.zeros(n * runs, bool)
        members[index] = True
        apart = np.abs(np.median(phys[members], axis=0) - np.median(phys[~members], axis=0))
        j = int(np.argmax(np.where(psd > 0, apart / np.where(psd > 0, psd, 1.0), -1.0)))
        lo, hi = np.quantile(phys[members, j], [0.05, 0.95])
        run_mass = np.array([members[run_of == k].mean() for k in range(runs)])
        out.append(Region(f"{labels[j]}: {_short(lo)}–{_short(hi)}", float(members.mean()), run_mass, members))
    out.sort(key=lambda r: -r.mass)
    return out


def _kmeans(draws: np.ndarray) -> list:
    """Index arrays (into the (n·runs) flattening) of the k-means regions of the pooled draws."""
    from scipy.cluster.vq import kmeans2

    flat = draws.reshape(-1, draws.shape[-1])
    sd = flat.std(axis=0)
    moving = sd > 1e-12
    if len(flat) < 2 * REGIONS or not moving.any():
        return []
    X = flat[:, moving] / sd[moving]
    step = max(1, len(X) // 4000)  # k-means on an even thinning; every draw then goes to its nearest centre
    centres, _ = kmeans2(X[::step], REGIONS, seed=np.random.default_rng(0), minit="++")
    nearest = np.argmin(((X[:, None, :] - centres[None]) ** 2).sum(axis=2), axis=1)
    return [np.flatnonzero(nearest == g) for g in np.unique(nearest)]


def _short(x: float) -> str:
    return f"{x:.3g}"


def precision_table(draws: np.ndarray, labels, from_unit=None) -> pd.DataFrame:
    """Per parameter, in the searched coordinates (``draws`` (n, runs, d), unit: the coordinates the prior
    is uniform in, so a log-scaled parameter's long tail in physical units does not swamp its sd): the
    pooled mean, sd and 5/95 % quantiles, each run's mean, and the standard errors of the pooled mean and
    quantiles from the runs' scatter, in posterior sd (``se_mean``, ``se_q05``, ``se_q95``); with
    ``from_unit``, the same mean, quantiles and runs' means mapped to physical units (``*_physical``). A
    parameter the posterior holds fixed has sd 0 and no row."""
    n, runs, d = draws.shape
    rows = []
    for j in range(d):
        x = draws[:, :, j]
        sd = float(np.std(x))
        if not sd > 0:
            continue
        run_mean = x.mean(axis=0)
        run_q = np.quantile(x, QUANTILES, axis=0)  # (2, runs)
        se = partial(_se, runs=runs, sd=sd)
        rows.append(
            {
                "parameter": labels[j],
                "index": j,
                "mean": float(x.mean()),
                "sd": sd,
                "q05": float(np.quantile(x, QUANTILES[0])),
                "q95": float(np.quantile(x, QUANTILES[1])),
                "run_mean_min": float(run_mean.min()),
                "run_mean_max": float(run_mean.max()),
                "se_mean": se(run_mean),
                "se_q05": se(run_q[0]),
                "se_q95": se(run_q[1]),
            }
        )
    frame = pd.DataFrame(rows)
    if len(frame):
        frame["met"] = frame[["se_mean", "se_q05", "se_q95"]].max(axis=1) <= TARGET_SD
        for column in ("mean", "q05", "q95", "run_mean_min", "run_mean_max"):
            frame[f"{column}_physical"] = _physical(frame, column, d, from_unit)
    return frame


def _physical(frame: pd.DataFrame, column: str, d: int, from_unit) -> list:
    """The unit-coordinate values of ``column`` (one per row, parameter ``index``) in physical units (each
    coordinate of the box maps on its own)."""
    if from_unit is None:
        return list(frame[column])
    U = np.full((len(frame), d), 0.5)
    U[np.arange(len(frame)), frame["index"].to_numpy()] = frame[column].to_numpy()
    P = np.asarray(from_unit(U), float)
    return [float(P[i, j]) for i, j in enumerate(frame["index"])]


def _se(values, runs: int, sd: float) -> float:
    """Standard error of a pooled estimate from the runs' own ``values``, in posterior sd."""
    return float(np.std(values, ddof=1) / math.sqrt(runs) / sd) if runs > 1 else float("nan")


def _precision_met(precision, regions, runs) -> bool | None:
    if runs < MIN_RUNS:
        return None
    params = bool(precision["met"].all()) if len(precision) else True
    return params and all(r.se <= TARGET_MASS for r in regions)


def _worst_ratio(precision, regions) -> float:
    """The largest standard error over its target (1 = just met)."""
    ratios = [0.0]
    if len(precision):
        ratios.append(float(precision[["se_mean", "se_q05", "se_q95"]].max(axis=1).max()) / TARGET_SD)
    ratios += [r.se / TARGET_MASS for r in regions if np.isfinite(r.se)]
    return max(ratios)


def _needed(precision, regions, runs, run_nfev, complete) -> dict | None:
    """{"runs", "evaluations", "per_run"}: what the precision targets need, from the SE's 1/√runs; None
    when they are met or cannot be estimated (fewer than ``MIN_RUNS`` runs, or runs cut)."""
    if runs < 2 or (complete is not None and not all(complete)):
        return None
    ratio = _worst_ratio(precision, regions)
    if not np.isfinite(ratio) or ratio <= 1:
        return None
    want = int(math.ceil(runs * ratio**2))
    per_run = float(np.median(run_nfev)) if run_nfev is not None and len(run_nfev) else float("nan")
    return {
        "runs": want,
        "per_run": per_run,
        "evaluations": int(want * per_run) if np.isfinite(per_run) else None,
    }


def _precision_text(precision, regions, runs, needed) -> str:
    worst = []
    if len(precision):
        p = precision.assign(worst=precision[["se_mean", "se_q05", "se_q95"]].max(axis=1)).sort_values("worst")
        worst += [f"{r.parameter} ± {r.worst:.2f} sd" for r in p.itertuples() if r.worst > TARGET_SD][::-1][:3]
    worst += [f"{r.label} mass {r.mass:.2f} ± {r.se:.2f} ({r.spread})" for r in regions if r.se > TARGET_MASS][:2]
    text = (
        f"the {runs} runs do not yet pin the posterior to the target (pooled means and 5/95 % quantiles within "
        f"{TARGET_SD:g} sd, region masses within {TARGET_MASS:g}): " + ", ".join(worst)
    )
    if needed is not None and needed.get("evaluations"):
        text += f"; about {needed['runs']} runs ({needed['evaluations']:,} evaluations in all) would suffice"
    return text


def reproduce_badge(draws: np.ndarray, names, ess) -> dict:
    """The "runs reproduce each other" badge: R̂ and bulk ESS on each run's first m draws, m the least
    effective sample size of a run (the draws of a run are shuffled, so the first m are m nearly
    independent ones), when m ≥ ``BADGE_DRAWS``; else not computed. ``reproduce``: True, False or None."""
    n, runs, _ = draws.shape
    m = int(min(n, np.floor(np.min(ess)))) if len(ess) else 0
    if runs < 2 or m < BADGE_DRAWS:
        why = "one run" if runs < 2 else f"runs hold {m} effective draws, R̂ needs ≥ {BADGE_DRAWS} per run to mean much"
        return {"reproduce": None, "draws": m, "text": f"R̂/ESS not computed: {why}", "table": None}
    with np.errstate(over="ignore", invalid="ignore"):
        table = mcmc.convergence(draws[:m], list(names), burn=0)
    worst, least = float(table["r_hat"].max()), float(table["ess_bulk"].min())
    ok = bool(worst <= mcmc.R_HAT_MAX and least >= mcmc.ESS_MIN)
    return {
        "reproduce": ok,
        "draws": m,
        "r_hat": worst,
        "ess": least,
        "text": f"runs reproduce each other: {'yes' if ok else 'no'} (worst R̂ {worst:.3f}, least bulk ESS "
        f"{least:,.0f} on {m} draws per run)",
        "table": table,
    }


def sentence(converged: bool, reasons, converged_text: str) -> str:
    """The verdict in one line: "Posterior converged: <converged_text>" or "Posterior not converged: <first
    reason> (and N more)" — every sampler's verdict in the same words."""
    if converged:
        return f"Posterior converged: {converged_text}"
    reasons = list(reasons) or ["see the diagnostics"]
    more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
    return f"Posterior not converged: {reasons[0]}{more}"


def _line(converged, reasons, runs, n, precision, regions) -> str:
    return sentence(
        converged,
        reasons,
        f"{runs} independent runs reproduce each other within the precision target (pooled means and 5/95 % "
        f"quantiles within {TARGET_SD:g} posterior sd, region masses within {TARGET_MASS:g}; "
        f"{len(regions) if len(regions) > 1 else 'one'} region{'s' if len(regions) > 1 else ''}), every hard "
        "check passed",
    )
