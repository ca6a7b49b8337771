"""What a nested-sampling posterior's runs say, as the report shows it: the verdict in one line, the hard
checks, the pooled intervals with their precision from the runs' scatter, the region masses with their
spread between runs, the R̂/ESS badge, what budget would suffice; then what the data leave to the box
(profile likelihood beside each marginal, the parameters undetermined over part of their box, how the
region masses move when such a box is cut) and the figure of each run's marginals overlaid."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.analysis import posterior_profile, posterior_verdict
from bwbench.problems.hysteresis.report.posterior_draws import axis, parameters
from bwbench.render.format import number
from bwbench.render.palette import OKABE_ITO, canvas, legend, save, slug, theme, title


def verdict_block(doc, pc) -> None:
    """The verdict first (one line), then the checks, the precision and region tables, the badge."""
    v = pc.nested
    (doc.p if v.converged else doc.banner)(f"**{v.line}.**" if v.converged else v.line + ".")
    doc.table(checks_table(v), "The hard checks: any one failed means not converged")
    if len(v.precision):
        doc.table(
            precision_table(v),
            "Pooled posterior means and 5/95 % quantiles, each ± its standard error from the scatter between "
            f"the {v.runs} runs, in posterior sd (target ≤ {posterior_verdict.TARGET_SD:g}), and the range of the "
            "runs' own means; computed in the searched coordinates, where the prior is uniform (a log-scaled "
            "parameter's mean is then its geometric mean)",
        )
    doc.table(
        regions_table(v),
        "Where the posterior's mass lies: regions (its separate modes, or k-means parts of one), each run's mass "
        f"and the pooled mass ± its standard error from the runs' scatter (target ≤ {posterior_verdict.TARGET_MASS:g})",
    )
    doc.p(v.badge["text"] + " — a badge: the precision above decides.")
    if v.needed and v.needed.get("evaluations"):
        doc.p(
            f"What would suffice: about {v.needed['runs']} runs of this size (~{v.needed['per_run']:,.0f} evaluations "
            f"each), {v.needed['evaluations']:,} evaluations in all (the standard errors fall as 1/√runs): set "
            f"`[posterior] budget = {_round_up(v.needed['evaluations'] * 1.1):,}`."
        )
    elif any(c.name == "runs complete" and c.passed is False for c in v.checks):
        share = max(pc.chain.evidence.get("run_nfev") or [0])
        doc.p(
            f"What would suffice: each run needed more than its share (~{share:,} evaluations) to end by its own "
            f"rule; a run of {pc.chain.evidence.get('live_points', '?')} live points on this posterior takes "
            "several hundred thousand evaluations (docs/posterior.md), so a budget of at least "
            f"{_round_up(max(share * 4 * len(pc.chain.evidence.get('log_z', [1])), 1)):,} is the next step."
        )


def _round_up(x: float) -> int:
    """x rounded up to two significant figures."""
    if x <= 0:
        return 0
    step = 10 ** max(0, int(np.floor(np.log10(x))) - 1)
    return int(np.ceil(x / step) * step)


def checks_table(v) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {
                "check": c.name,
                "result": {True: "pass", False: "**FAIL**", None: "not made"}[c.passed],
                "detail": c.detail,
            }
            for c in v.checks
        ]
    )


def precision_table(v) -> pd.DataFrame:
    rows = []
    for r in v.precision.itertuples():
        rows.append(
            {
                "parameter": r.parameter,
                "pooled mean": f"{number(r.mean_physical, 4)} ± {r.se_mean:.2f} sd",
                "5 %": f"{number(r.q05_physical, 4)} ± {r.se_q05:.2f} sd",
                "95 %": f"{number(r.q95_physical, 4)} ± {r.se_q95:.2f} sd",
                "runs' means": f"{number(r.run_mean_min_physical, 4)} … {number(r.run_mean_max_physical, 4)}",
                "within target": "yes" if r.met else "**no**",
            }
        )
    return pd.DataFrame(rows)


def regions_table(v) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {
                "region": r.label,
                "pooled mass": f"{r.mass:.2f} ± {r.se:.3f}" if np.isfinite(r.se) else f"{r.mass:.2f}",
                "runs' masses": ", ".join(f"{m:.2f}" for m in r.run_mass),
                "spread": r.spread,
            }
            for r in v.regions
        ]
    )


def box_block(doc, pc, study, order=None) -> None:
    """The profile likelihood beside each marginal (figure), the parameters the data leave undetermined
    over part of their box, and how the region masses move when such a box is cut."""
    profile = (pc.chain.evidence or {}).get("profile")
    png = runs_figure(study, doc.out_dir, pc, profile)
    doc.figure(
        png,
        f"{pc.chain.specimen}: each run's marginal overlaid (disagreement between runs is visible), the pooled "
        "marginal, and the profile log-likelihood (the others re-maximised) beside it",
    )
    if not profile:
        doc.p(
            "No profile likelihood: the posterior's budget was too small to keep its evaluations aside "
            f"(they are run when the budget is at least {20:,}× their cost)."
        )
        return
    for text in box_statements(pc, profile):
        doc.p(text)
    table = sensitivity_table(pc, profile)
    if len(table):
        doc.table(
            table,
            "Prior sensitivity: the posterior under a box cut by a third on one side, read from the same draws "
            "(a uniform prior truncated): the share of the mass kept, each region's mass, and the parameter "
            "whose mean moves most (in posterior sd)",
        )


def box_statements(pc, profile) -> list[str]:
    """One sentence per searched parameter the data leave undetermined over part of its box, and one
    naming the determined ones with their 95 % profile range."""
    labels = parameters(pc.problem)
    out, pinned = [], []
    for j, name in enumerate(pc.names):
        span = posterior_profile.undetermined(profile["unit"][j], profile["log_like"][j])
        allowed = posterior_profile.allowed(profile["unit"][j], profile["log_like"][j])
        if allowed is None:
            continue
        lo, hi = _physical(pc, j, allowed)
        if span is not None:
            mass = _mass_share(pc, j, span)
            out.append(
                f"**{axis(pc.problem, name, labels)}: undetermined over {number(lo, 3)}–{number(hi, 3)}** — the "
                f"profile likelihood stays within {posterior_profile.ALLOW} of its maximum there (the data allow all "
                f"of it), so how the posterior's mass spreads along it ({mass}) follows the box: the volume the "
                "other parameters have at each value, not the data."
            )
        else:
            pinned.append(f"{axis(pc.problem, name, labels)} {number(lo, 3)}–{number(hi, 3)}")
    if pinned:
        out.append(
            "Determined by the data (95 % profile-likelihood range, the others re-maximised): "
            + "; ".join(pinned)
            + "."
        )
    return out


def _physical(pc, j: int, unit_span) -> tuple[float, float]:
    U = np.full((2, len(pc.names)), 0.5)
    U[:, j] = np.clip(unit_span, 0.0, 1.0)
    P = pc.problem.from_unit(U)
    return float(P[0, j]), float(P[1, j])


def _mass_share(pc, j: int, span) -> str:
    """'0.40 of the mass in its lower half' for the undetermined stretch ``span`` (unit)."""
    u = pc.chain.samples[:, :, j].ravel()
    middle = (span[0] + span[1]) / 2
    lo, _ = _physical(pc, j, (middle, middle))
    return f"{np.mean(u < middle):.2f} of the posterior's mass below {number(lo, 3)}"


def sensitivity_table(pc, profile) -> pd.DataFrame:
    """Rows per (undetermined parameter, cut box) of ``posterior_profile.sensitivity``."""
    v, labels = pc.nested, parameters(pc.problem)
    flat = pc.chain.samples.reshape(-1, len(pc.names))
    physical = pc.problem.from_unit(flat)
    rows = []
    for j, name in enumerate(pc.names):
        if posterior_profile.undetermined(profile["unit"][j], profile["log_like"][j]) is None:
            continue
        for cut in posterior_profile.sensitivity(flat, j, v.regions, physical):
            lo, hi = _physical(pc, j, cut["box"])
            row = {
                "box of " + axis(pc.problem, name, labels): f"{number(lo, 3)}–{number(hi, 3)}",
                "mass kept": f"{cut['kept']:.2f}",
            }
            for r, mass in zip(v.regions, cut["regions"] or [np.nan] * len(v.regions)):
                row[f"{r.label} (now {r.mass:.2f})"] = f"{mass:.2f}" if np.isfinite(mass) else "–"
            if cut["shift"] is not None:
                k, shift = cut["shift"]
                row["largest shift of a mean"] = f"{axis(pc.problem, pc.names[k], labels)} {shift:+.2f} sd"
            rows.append(row)
    return pd.DataFrame(rows)


def _edges(u: np.ndarray, span) -> np.ndarray:
    """30 bins (unit coordinates) over the posterior's range of one parameter, padded, and over the stretch
    the data leave undetermined (``span``) when there is one."""
    lo, hi = np.quantile(u, [0.005, 0.995])
    pad = 0.15 * max(hi - lo, 1e-6)
    lo, hi = max(0.0, lo - pad), min(1.0, hi + pad)
    if span is not None:
        lo, hi = min(lo, span[0]), max(hi, span[1])
    return np.linspace(lo, hi, 31)


def runs_figure(study, out_dir, pc, profile):
    """One panel per searched parameter: each run's marginal (a thin step line per run), the pooled
    marginal (grey), and on a second axis the profile log-likelihood relative to its maximum, with the
    95 % threshold; the undetermined stretch shaded."""
    from bwbench.problems.hysteresis.report.figure_common import synthetic

    theme()
    samples = pc.chain.samples  # (n, runs, d)
    n, runs, d = samples.shape
    labels = parameters(pc.problem)
    ncols = 4 if d > 6 else min(d, 3)
    nrows = -(-d // ncols)
    fig = canvas(12, 2.7 * nrows + 1.6)
    grid = fig.add_gridspec(nrows, ncols)
    colours = [OKABE_ITO[k % len(OKABE_ITO)] for k in range(runs)]
    rows = []
    for j, name in enumerate(pc.names):
        ax = fig.add_subplot(grid[j // ncols, j % ncols])
        span = posterior_profile.undetermined(profile["unit"][j], profile["log_like"][j]) if profile else None
        edges = _edges(samples[:, :, j], span)
        U = np.full((len(edges), d), 0.5)
        U[:, j] = edges
        x = pc.problem.from_unit(U)[:, j]  # bin edges in physical units (even in the searched coordinate)
        pooled = np.histogram(samples[:, :, j].ravel(), bins=edges)[0] / (n * runs)
        ax.stairs(pooled, x, fill=True, color="0.8", zorder=1)
        for k in range(runs):
            share = np.histogram(samples[:, k, j], bins=edges)[0] / n
            ax.stairs(share, x, color=colours[k], lw=1.0, alpha=0.85, zorder=2)
        ax.set_xlabel(axis(pc.problem, name, labels))
        ax.set_ylabel("share of draws per bin")
        if np.ptp(x) > 0 and x.min() > 0 and x.max() / x.min() > 100:
            ax.set_xscale("log")
        values = np.asarray(profile["log_like"][j], float) if profile else np.full(1, np.nan)
        if np.isfinite(values).any():
            g = np.asarray(profile["unit"][j], float)
            U = np.full((len(g), d), 0.5)
            U[:, j] = g
            gx = pc.problem.from_unit(U)[:, j]
            delta = values - np.nanmax(values)
            keep = (g >= edges[0]) & (g <= edges[-1])  # the profile where the marginal is drawn
            twin = ax.twinx()
            twin.plot(gx[keep], delta[keep], "-o", color="black", ms=3.5, lw=1.2, zorder=3)
            twin.axhline(-posterior_profile.ALLOW, color="black", ls=":", lw=1.0)
            twin.set_ylim(-10.0, 1.0)  # the flat stretch and the threshold; a steep fall leaves the frame
            twin.set_ylabel("Δ profile log-likelihood (–)")
            twin.grid(False)
            if span is not None:
                lo, hi = _physical(pc, j, span)
                ax.axvspan(lo, hi, color=OKABE_ITO[1], alpha=0.10, lw=0, zorder=0)
            rows += [{"parameter": name, "kind": "profile", "x": a, "value": b} for a, b in zip(gx, delta)]
        rows += [{"parameter": name, "kind": "pooled share", "x": a, "value": b} for a, b in zip(x[:-1], pooled)]
    handles = [Patch(color="0.8", label="pooled marginal")]
    handles += [Line2D([], [], color=colours[k], lw=1.2, label=f"run {k + 1}") for k in range(min(runs, 8))]
    if profile:
        handles += [
            Line2D([], [], color="black", marker="o", ms=3.5, label="profile log-likelihood (right axis)"),
            Line2D([], [], color="black", ls=":", label=f"95 % threshold (−{posterior_profile.ALLOW})"),
            Patch(color=OKABE_ITO[1], alpha=0.25, label="undetermined: the data allow all of it"),
        ]
    legend(fig, handles, ncol=min(len(handles), 5))
    shown = ", with the profile likelihood" if profile else " (no profile: the budget left none for it)"
    title(fig, f"{pc.chain.specimen}: {runs} runs' marginals overlaid{shown}\n{pc.nested.line}")
    return save(
        fig,
        out_dir,
        f"posterior_runs_{slug(pc.chain.specimen)}",
        pd.DataFrame(rows),
        synthetic(study, [pc.chain.specimen]),
    )
