"""What the data say about the parameters beyond one fit: an MCMC posterior (marginals, the most
correlated pairs, the chain's convergence verdict) and profile likelihoods.

Both return the PNG's path and write the CSV behind it beside it (same name).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.analysis import mcmc
from bwbench.models.switched import identifiable as fm
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.models.switched.parameters import LOWER, UPPER
from bwbench.problems.hysteresis.report.figure_common import axis_label, synthetic, truth
from bwbench.render.palette import MAX_WIDTH_IN, OKABE_ITO, TRUTH, canvas, legend, save, slug, styles, theme, title

R_HAT_MAX, ESS_MIN = mcmc.R_HAT_MAX, mcmc.ESS_MIN  # Vehtari et al. (2021): converged when R̂ ≤ 1.01 and bulk ESS ≥ 400
NOT_CONVERGED_BOX = {"fc": "#FBE3D6", "ec": OKABE_ITO[3], "boxstyle": "round,pad=0.4"}
CONVERGED_BOX = {"fc": "#DDEFE7", "ec": OKABE_ITO[2], "boxstyle": "round,pad=0.4"}


def verdict(diagnostics: pd.DataFrame | None) -> tuple[bool | None, str]:
    """(converged?, sentence) from a table with ``r_hat`` and ``ess_bulk`` per parameter (as
    ``mcmc.convergence`` gives); (None, "") without one."""
    if diagnostics is None or len(diagnostics) == 0:
        return None, ""
    r_hat = diagnostics["r_hat"].astype(float).to_numpy()
    ess = diagnostics["ess_bulk"].astype(float).to_numpy()
    bad_r = ~(r_hat <= R_HAT_MAX)  # NaN counts as failing
    bad_e = ~(ess >= ESS_MIN)
    if not bad_r.any() and not bad_e.any():
        return True, f"converged: R̂ ≤ {R_HAT_MAX:g} and bulk ESS ≥ {ESS_MIN} for every parameter"
    n = len(r_hat)
    parts = []
    if np.isnan(r_hat).all():
        parts.append("no R̂ (too few draws)")
    elif bad_r.any():
        parts.append(f"R̂ up to {np.nanmax(r_hat):.3g} (> {R_HAT_MAX:g} for {int(bad_r.sum())} of {n} parameters)")
    if bad_e.any() and not np.isnan(ess).all():
        parts.append(f"bulk ESS down to {np.nanmin(ess):.0f} (< {ESS_MIN} for {int(bad_e.sum())} of {n})")
    return False, (
        "NOT converged: " + "; ".join(parts) + ". The histograms show where the chain has been, not the posterior."
    )


def _coordinates(values: dict, names, state: str, problem=None):
    """A parameter vector in the chain's coordinates ``names``: taken as is when ``values`` has
    them all, mapped from the model's direct parameters (the paper's 14 without ``problem``) to the
    identifiable ones otherwise; None if neither."""
    if problem is not None:
        from bwbench.problems.hysteresis.report.posterior_draws import in_coordinates

        return in_coordinates(values, problem)
    if all(np.isfinite(values.get(n, np.nan)) for n in names):
        return np.array([float(values[n]) for n in names])
    if all(np.isfinite(values.get(n, np.nan)) for n in PARAM_NAMES) and tuple(names) == fm.hysteretic_names(state):
        try:
            return np.asarray(fm.from_paper(np.array([values[n] for n in PARAM_NAMES], dtype=float), state)[0])
        except ValueError:  # no saturation: no identifiable image
            return None
    return None


def _ticks(axis, bins: int) -> None:
    """Few ticks with short labels: the panels are narrow."""
    axis.set_major_locator(matplotlib.ticker.MaxNLocator(bins))
    axis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:.3g}"))


def posterior(
    study,
    out_dir,
    chain,
    burn: int | None = None,
    pairs: int = 4,
    max_csv: int = 4000,
    *,
    diagnostics=None,
    from_unit=None,
    names=None,
    order=None,
    problem=None,
    posterior=None,
) -> Path:
    """MCMC posterior of one chain: the marginal of every parameter and the joint density of the
    ``pairs`` most correlated pairs, with the overall best fit on the specimen (any run) and the
    truth marked, and the convergence verdict printed on the figure. ``burn`` steps are dropped
    (default half), and so are stuck walkers (``mcmc.stuck_walkers``).

    ``names`` and ``from_unit``: the chain's coordinates and its map from unit coordinates (default:
    the paper's 14 in the Table 5 box; for the identifiable ones e.g. ``hysteretic_names(state)``
    and ``scaled_bounds(x, f, state).from_unit``). ``diagnostics``: R̂ and bulk ESS per parameter
    (``mcmc.convergence``); computed here from the kept walkers when not given (False: none).
    ``problem`` and ``posterior`` (a ``posterior_draws.PosteriorChain``): any model's chain — names,
    labels, units and box from the problem, the main mode's walkers kept, its ArviZ table shown,
    parameters a reduced model held fixed named in the title instead of drawn."""
    from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs
    from bwbench.problems.hysteresis.report.posterior_draws import axis
    from bwbench.problems.hysteresis.report.posterior_draws import truth as truth_of

    theme()
    state = study.settings.get("state", "shared")
    if burn is None:
        burn = posterior.burn if posterior is not None else chain.steps // 2
    fixed = []
    if posterior is not None:
        problem = posterior.problem
        names, from_unit, fixed = list(posterior.names), problem.from_unit, list(posterior.fixed)
        keep = np.zeros(chain.walkers, dtype=bool)
        keep[posterior.main.walkers] = True
        stuck = ~keep
        if diagnostics is None:
            found = posterior.assessment["diagnostics"]  # none for runs too small for the R̂ badge
            diagnostics = found[posterior.assessment["modes"].index(posterior.main)] if found else False
    else:
        names = list(PARAM_NAMES if names is None else names)
        if from_unit is None:  # the paper's 14 in the Table 5 box
            from_unit = lambda u: LOWER + u * (UPPER - LOWER)  # noqa: E731
        stuck = mcmc.stuck_walkers(chain.samples, chain.log_prob, burn)
    samples = chain.physical(from_unit, burn, ~stuck)
    if diagnostics is None:
        diagnostics = mcmc.convergence(chain.samples[:, ~stuck], names, burn)
    diagnostics = None if diagnostics is False else pd.DataFrame(diagnostics)
    converged, sentence = verdict(diagnostics)
    if posterior is not None and (posterior.nested is not None or not posterior.converged):
        # the posterior's own verdict (nested sampling: the runs' checks and precision; emcee: R̂/ESS and the
        # best ranking fit covered), the same line as the report's and the API's
        converged, sentence = posterior.converged, posterior.verdict_line
    box = (
        np.vstack([LOWER, UPPER])
        if from_unit is None
        else np.vstack([from_unit(np.zeros((1, len(names))))[0], from_unit(np.ones((1, len(names))))[0]])
    )
    specimen = chain.specimen
    if problem is not None:
        known = truth_of(study, problem, specimen)
        true = None if known is None else np.array([known.get(n, np.nan) for n in names])
        label = lambda n: axis(problem, n)  # noqa: E731
    else:
        true = truth(study, specimen)
        true = None if true is None else _coordinates(dict(zip(PARAM_NAMES, true)), names, state)
        label = axis_label
    # the best ranking fit (the posterior run's own best point comes from its start's searches, in the
    # full model even when the chain samples a reduced one); the ranking's when there is one
    runs = study.runs[
        (study.runs["specimen"] == specimen)
        & (study.runs["status"] == "ok")
        & np.isfinite(study.runs["mse"].astype(float))
    ]
    if (runs["kind"] == "ranking").any():
        runs = runs[runs["kind"] == "ranking"]
    if problem is not None and "model" in runs and runs["model"].notna().any():
        runs = runs[runs["model"] == problem.model.name]  # a study comparing models: this model's fits only
    best_run: Any = runs.loc[runs["mse"].idxmin()] if len(runs) else None
    best = None if best_run is None else _coordinates(best_run.to_dict(), names, state, problem)
    if problem is not None and posterior is not None and posterior.fixed:
        # in the reduced model's gauge a full-model value (truth, fit) is not comparable: not marked
        gauge = [j for j, n in enumerate(names) if n in problem.model.reduced_gauge(posterior.fixed, problem.state)]
        for marked in (true, best):
            if marked is not None:
                marked[gauge] = np.nan
    colour = styles(study, order)[best_run["optimizer"]].colour if best_run is not None else "black"

    lo_q, hi_q = np.quantile(samples, [0.005, 0.995], axis=0)
    pad = 0.3 * (hi_q - lo_q) + 1e-12
    lo, hi = np.maximum(lo_q - pad, box.min(axis=0)), np.minimum(hi_q + pad, box.max(axis=0))
    for marked in (true, best):  # keep the marks on the frame
        if marked is not None:
            lo, hi = np.fmin(lo, marked), np.fmax(hi, marked)  # fmin: a mark left out (NaN) moves nothing
    margin = 0.04 * (hi - lo)
    lo, hi = lo - margin, hi + margin

    shown = [j for j, n in enumerate(names) if n not in fixed]
    d = len(shown)
    ncols = 5 if d > 8 else 4
    nrows = -(-d // ncols)
    corr = posterior_correlation(samples[:, shown], [names[j] for j in shown])
    top = strongest_pairs(corr, pairs)
    fig = canvas(MAX_WIDTH_IN, 0.8 + 2.35 * nrows + 3.2 + 1.0)
    grid = fig.add_gridspec(nrows + 2, ncols, height_ratios=[0.45] + [1] * nrows + [1.45])
    note = fig.add_subplot(grid[0, :])
    note.axis("off")
    if sentence:
        note.text(
            0.5,
            0.5,
            sentence,
            ha="center",
            va="center",
            fontsize=11,
            fontweight="bold",
            wrap=True,
            transform=note.transAxes,
            bbox=CONVERGED_BOX if converged else NOT_CONVERGED_BOX,
        )
    diag = {} if diagnostics is None else diagnostics.set_index("parameter").to_dict("index")
    for k, j in enumerate(shown):
        name = names[j]
        ax = fig.add_subplot(grid[1 + k // ncols, k % ncols])
        ax.hist(samples[:, j], bins=40, range=(lo[j], hi[j]), color="0.6", density=True, histtype="stepfilled")
        ax.set_xlim(lo[j], hi[j])
        ax.set_yticks([])
        ax.grid(False)
        ax.set_xlabel(label(name))
        _ticks(ax.xaxis, 2)
        if best is not None and np.isfinite(best[j]):
            ax.axvline(best[j], color=colour, lw=2.0)
        if true is not None and np.isfinite(true[j]):
            ax.axvline(true[j], color="black", lw=1.2, ls="--")
        if name in diag:
            r, e = diag[name]["r_hat"], diag[name]["ess_bulk"]
            ok = r <= R_HAT_MAX and e >= ESS_MIN
            ax.set_title(
                f"R̂ {r:.2f}, ESS {e:.0f}",
                fontsize=9.5,
                color="black" if ok else OKABE_ITO[3],
                fontweight="normal" if ok else "bold",
            )
    pair_grid = grid[nrows + 1, :].subgridspec(1, max(len(top), 1))
    for k, (a, b, r) in enumerate(top):
        ia, ib = names.index(a), names.index(b)
        ax = fig.add_subplot(pair_grid[0, k])
        ax.hist2d(samples[:, ia], samples[:, ib], bins=40, cmap="Greys", range=[[lo[ia], hi[ia]], [lo[ib], hi[ib]]])
        if best is not None:
            ax.plot(best[ia], best[ib], marker="*", ms=15, color=colour, mec="black", mew=0.8, ls="", zorder=5)
        if true is not None:
            ax.plot(true[ia], true[ib], **TRUTH, zorder=6)
        ax.set_xlabel(label(a))
        ax.set_ylabel(label(b))
        ax.set_title(f"correlation r = {r:+.2f}")
        _ticks(ax.xaxis, 2)
        _ticks(ax.yaxis, 4)
    handles: list[Any] = [Patch(color="0.6", label="posterior samples")]
    if best is not None:
        handles.append(
            Line2D(
                [],
                [],
                color=colour,
                lw=2.0,
                marker="*",
                ms=13,
                mec="black",
                mew=0.8,
                label=f"best fit on the specimen: {best_run['optimizer']} ({best_run['kind']}, seed "
                f"{int(best_run['replicate'])}), MSE {best_run['mse']:.4g} {study.loss_unit}",
            )
        )
    if true is not None:
        handles.append(Line2D([], [], ls="--", lw=1.2, marker="x", color="black", ms=8, mew=2, label="truth"))
    legend(fig, handles, ncol=len(handles))
    if posterior is not None:
        modes = len(posterior.assessment["modes"])
        dropped = f", mode 1 of {modes} ({len(posterior.main.walkers)} walkers)" if modes > 1 else ""
    else:
        dropped = f", {int(stuck.sum())} stuck walker(s) left out" if stuck.any() else ""
    held = (
        ("\nheld fixed (reduced model): " + ", ".join(f"{label(n)} = {samples[0, names.index(n)]:.4g}" for n in fixed))
        if fixed
        else ""
    )
    if posterior is not None and posterior.nested is not None:  # nested sampling: runs of equal-weight draws
        masses = ", ".join(f"{m.mass:.2f}" for m in posterior.nested["modes"])
        title(
            fig,
            f"{specimen}: {chain.optimizer} posterior, {chain.walkers} independent runs × {chain.steps:,} "
            f"equal-weight draws, every mode (masses {masses}){held}",
        )
    else:
        title(
            fig,
            f"{specimen}: {chain.optimizer} posterior, {chain.steps:,} steps × {chain.walkers} walkers, first "
            f"{burn:,} steps dropped as burn-in{dropped}{held}",
        )
    thin = max(1, -(-len(samples) // max_csv))  # ceil: at most max_csv rows
    frame = pd.DataFrame(samples[::thin], columns=names).assign(source="posterior", optimizer=chain.optimizer)
    extra = []
    if best is not None:
        extra.append(pd.DataFrame([best], columns=names).assign(source="best fit", optimizer=best_run["optimizer"]))
    if true is not None:
        extra.append(pd.DataFrame([true], columns=names).assign(source="truth", optimizer=""))
    if diagnostics is not None:
        for column in ("r_hat", "ess_bulk"):
            values = diagnostics.set_index("parameter")[column].reindex(names).to_numpy(dtype=float)
            extra.append(pd.DataFrame([values], columns=names).assign(source=column, optimizer=chain.optimizer))
    frame = pd.concat([frame, *extra], ignore_index=True)[["source", "optimizer", *names]]
    return save(
        fig,
        out_dir,
        f"posterior_{slug(specimen)}{_suffix(study, problem, chain.optimizer)}",
        frame,
        synthetic(study, [specimen]),
    )


def _suffix(study, problem, label: str) -> str:
    """ "_spencer" when the study compares models, "_emcee" when its posterior runs several samplers (each
    posterior has its own figure), "" otherwise."""
    from bwbench.problems.hysteresis.report.figure_common import study_variants
    from bwbench.render.labels import split_label

    out = ""
    if problem is not None and len({model for _, model, _ in study_variants(study)}) > 1:
        out += f"_{slug(problem.model.name)}"
    samplers = (study.config.get("posterior") or {}).get("optimizer")
    if isinstance(samplers, list) and len(samplers) > 1:
        out += f"_{slug(split_label(label)[0])}"
    return out
