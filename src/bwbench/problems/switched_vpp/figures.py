"""Figures of the switched-model problem: one fit (``bwbench fit --plot``), and a study's loops,
parameter spread, posterior, parameters against underpressure and profiles.

Each study figure returns the PNG's path and writes the CSV behind it beside it (same name).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import seaborn as sns

from bwbench.analysis import mcmc, statistics
from bwbench.data import manifest
from bwbench.data.parameters import LABELS, LOWER, UNITS, UPPER
from bwbench.models.switched_bouc_wen import PARAM_NAMES
from bwbench.report.figures import DPI, finished, mark_synthetic, palette, save, slug, theme
from bwbench.problems.switched_vpp.fit_figures import hysteresis_loops, plot_fit  # noqa: F401

SPREAD_TOLERANCE = 0.10  # parameter spread: runs with MSE ≤ (1 + 0.10) × best known


def axis_label(name: str) -> str:
    unit = UNITS[name]
    return f"{LABELS[name]} ({'–' if unit == '-' else unit})"


def _synthetic(study, specimens) -> bool:
    return any(manifest.is_synthetic(study.specimen_path(s)) for s in specimens)


def _truth(study, specimen):
    return manifest.truth_params(study.specimen_path(specimen))


def _problem(study, specimen):
    from bwbench.problems import SpecimenEntry

    return study.problem_type.make_problem(study.settings, SpecimenEntry(specimen, str(study.specimen_path(specimen))))


def parameter_spread(study, out_dir, specimens=None, tolerance: float = SPREAD_TOLERANCE) -> Path:
    """The 14 parameters, scaled to their Table 5 range, of every ranking run whose MSE is within
    ``tolerance`` of the best known for its specimen (one panel per specimen); truth as black ×."""
    theme()
    specimens = list(specimens or study.specimens)[:3]
    best = statistics.best_known(study.runs)
    runs = finished(study.ranking)
    colours = palette(study)
    optimizers = study.optimizers
    fig, axes = plt.subplots(len(specimens), 1, figsize=(13, 3.6 * len(specimens) + 0.6), squeeze=False)
    rows = []
    width = 0.8 / max(len(optimizers), 1)
    rng = np.random.default_rng(0)  # jitter only: the figure is the same every time
    for ax, specimen in zip(axes[:, 0], specimens):
        good = runs[(runs["specimen"] == specimen) & (runs["mse"] <= best[specimen] * (1 + tolerance))]
        total = runs[runs["specimen"] == specimen].groupby("optimizer").size()
        for b, optimizer in enumerate(optimizers):
            g = good[good["optimizer"] == optimizer]
            unit = (g[list(PARAM_NAMES)].to_numpy() - LOWER) / (UPPER - LOWER)
            offset = (b - (len(optimizers) - 1) / 2) * width
            for j in range(len(PARAM_NAMES)):
                x = j + offset + rng.uniform(-0.25, 0.25, len(g)) * width
                ax.plot(x, unit[:, j], "o", ms=4.5, alpha=0.8, color=colours[optimizer], zorder=3,
                        label=f"{optimizer} ({len(g)}/{int(total.get(optimizer, 0))} runs)" if j == 0 else None)
            values = g[list(PARAM_NAMES)].to_numpy(dtype=float)
            for (replicate, mse), v, u in zip(g[["replicate", "mse"]].itertuples(index=False), values, unit):
                rows += [{"specimen": specimen, "optimizer": optimizer, "replicate": replicate, "mse": mse,
                          "parameter": n, "value": v[j], "unit_value": u[j]} for j, n in enumerate(PARAM_NAMES)]
        truth = _truth(study, specimen)
        if truth is not None:
            unit_truth = (truth - LOWER) / (UPPER - LOWER)
            ax.hlines(unit_truth, np.arange(len(PARAM_NAMES)) - 0.42, np.arange(len(PARAM_NAMES)) + 0.42,
                      color="black", lw=1.2, zorder=1)
            ax.plot(np.arange(len(PARAM_NAMES)), unit_truth, "x", color="black", ms=8, mew=2, label="truth")
            rows += [{"specimen": specimen, "optimizer": "truth", "replicate": -1, "mse": np.nan, "parameter": n,
                      "value": float(v), "unit_value": float(w)} for n, v, w in zip(PARAM_NAMES, truth, unit_truth)]
        ax.set_xticks(np.arange(len(PARAM_NAMES)), [LABELS[n] for n in PARAM_NAMES])
        ax.set_xlim(-0.6, len(PARAM_NAMES) - 0.4)
        ax.set_ylim(-0.04, 1.04)
        ax.set_ylabel("(value − lower) / (upper − lower) (–)")
        ax.set_title(f"{specimen}: best known MSE {best[specimen]:.4g} {study.loss_unit}", fontsize=10)
        ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))
        for j in range(len(PARAM_NAMES) - 1):
            ax.axvline(j + 0.5, color="0.85", lw=0.8)
        ax.grid(axis="x", visible=False)
    axes[-1, 0].set_xlabel("parameter (scaled to its Table 5 search range)")
    fig.suptitle(f"Parameter spread across seeds: every run with MSE ≤ {1 + tolerance:g} × best known "
                 f"for its specimen", fontsize=11)
    frame = pd.DataFrame(rows, columns=["specimen", "optimizer", "replicate", "mse", "parameter", "value",
                                        "unit_value"])
    return save(fig, out_dir, "spread", frame, _synthetic(study, specimens))


def posterior(study, out_dir, chain, burn: int | None = None, pairs: int = 4, max_csv: int = 4000) -> Path:
    """emcee posterior of one chain: the 14 marginals (row '+', row '−') and the pairwise
    densities of the ``pairs`` most correlated pairs; each backend's best fit on the specimen
    (coloured ▼ / ◆) and the truth (black ×) overlaid. ``burn`` steps are dropped (default half),
    and so are stuck walkers (``mcmc.stuck_walkers``)."""
    from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs

    theme()
    burn = chain.steps // 2 if burn is None else burn
    stuck = mcmc.stuck_walkers(chain.samples, chain.log_prob, burn)
    samples = chain.physical(burn, ~stuck)
    corr = posterior_correlation(samples, list(PARAM_NAMES))
    top = strongest_pairs(corr, pairs)
    specimen = chain.specimen
    truth = _truth(study, specimen)
    colours = palette(study)
    runs = finished(study.ranking[study.ranking["specimen"] == specimen])
    best_fits = runs.loc[runs.groupby("optimizer")["mse"].idxmin()] if len(runs) else runs
    lo_q, hi_q = np.quantile(samples, [0.005, 0.995], axis=0)
    pad = 0.3 * (hi_q - lo_q) + 1e-12
    lo_lim, hi_lim = np.maximum(lo_q - pad, LOWER), np.minimum(hi_q + pad, UPPER)
    if truth is not None:
        lo_lim, hi_lim = np.minimum(lo_lim, truth), np.maximum(hi_lim, truth)
        margin = 0.04 * (hi_lim - lo_lim)  # keep the truth off the frame
        lo_lim, hi_lim = np.maximum(lo_lim - margin, LOWER), np.minimum(hi_lim + margin, UPPER)

    fig = plt.figure(figsize=(19, 10.5))
    outer = fig.add_gridspec(2, 1, height_ratios=[2, 1.35], hspace=0.35)
    top_grid = outer[0].subgridspec(2, 7, hspace=0.7, wspace=0.35)
    pair_grid = outer[1].subgridspec(1, max(len(top), 1), wspace=0.3)
    for j, name in enumerate(PARAM_NAMES):
        ax = fig.add_subplot(top_grid[j // 7, j % 7])
        ax.hist(samples[:, j], bins=40, range=(lo_lim[j], hi_lim[j]), color="0.55", density=True)
        ax.set_xlim(lo_lim[j], hi_lim[j])
        ax.set_yticks([])
        ax.set_xlabel(axis_label(name), fontsize=9)
        ax.tick_params(axis="x", labelsize=7)
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(3))
        top_y = ax.get_ylim()[1]
        for run in best_fits.itertuples():
            v = float(best_fits.loc[run.Index, name])
            inside = lo_lim[j] <= v <= hi_lim[j]
            ax.plot(np.clip(v, lo_lim[j], hi_lim[j]), top_y * 0.93, "v" if inside else "D", ms=6,
                    color=colours[run.optimizer], mec="black", mew=0.5, clip_on=False)
        if truth is not None:
            ax.plot(truth[j], 0, "x", color="black", ms=9, mew=2, clip_on=False)
            ax.axvline(truth[j], color="black", lw=0.8, ls="--")
    for k, (a, b, r) in enumerate(top):
        ia, ib = PARAM_NAMES.index(a), PARAM_NAMES.index(b)
        ax = fig.add_subplot(pair_grid[0, k])
        ax.hist2d(samples[:, ia], samples[:, ib], bins=40, cmap="Blues",
                  range=[[lo_lim[ia], hi_lim[ia]], [lo_lim[ib], hi_lim[ib]]])
        for run in best_fits.itertuples():
            va, vb = float(best_fits.loc[run.Index, a]), float(best_fits.loc[run.Index, b])
            inside = lo_lim[ia] <= va <= hi_lim[ia] and lo_lim[ib] <= vb <= hi_lim[ib]
            ax.plot(np.clip(va, lo_lim[ia], hi_lim[ia]), np.clip(vb, lo_lim[ib], hi_lim[ib]), "o" if inside else "D",
                    ms=7, mec="black", mew=0.7, color=colours[run.optimizer], clip_on=False)
        if truth is not None:
            ax.plot(truth[ia], truth[ib], "x", color="black", ms=10, mew=2.2, zorder=5, clip_on=False)
        ax.set_xlabel(axis_label(a))
        ax.set_ylabel(axis_label(b))
        ax.set_title(f"correlation r = {r:+.2f}", fontsize=10)
        ax.tick_params(labelsize=8)
    Line2D = matplotlib.lines.Line2D
    handles = [Line2D([], [], ls="", marker="v", ms=7, mec="black", mew=0.5, color=colours[o], label=f"{o} best fit")
               for o in best_fits["optimizer"]]
    handles += [Line2D([], [], ls="", marker="D", ms=6, color="0.8", mec="black", mew=0.5,
                       label="best fit outside the plotted range (drawn at its edge)"),
                matplotlib.patches.Patch(color="0.55", label="posterior samples")]
    if truth is not None:
        handles.append(Line2D([], [], ls="", marker="x", ms=8, mew=2, color="black", label="truth"))
    fig.legend(handles=handles, loc="upper left", ncol=min(len(handles), 7), fontsize=9,
               bbox_to_anchor=(0.01, 0.965), frameon=False)
    dropped = f", {int(stuck.sum())} stuck walker(s) left out" if stuck.any() else ""
    fig.suptitle(f"{specimen}: emcee posterior marginals and the {len(top)} most correlated pairs "
                 f"({chain.steps} steps × {chain.walkers} walkers, first {burn} steps dropped as burn-in{dropped})",
                 fontsize=12, x=0.01, ha="left", y=0.995)
    thin = max(1, -(-len(samples) // max_csv))  # ceil: at most max_csv rows
    frame = pd.DataFrame(samples[::thin], columns=list(PARAM_NAMES))
    frame = frame.assign(source="posterior", optimizer=chain.optimizer)
    extra = [best_fits[list(PARAM_NAMES)].assign(source="best fit", optimizer=best_fits["optimizer"].to_numpy())]
    if truth is not None:
        extra.append(pd.DataFrame([truth], columns=list(PARAM_NAMES)).assign(source="truth", optimizer=""))
    frame = pd.concat([frame, *extra], ignore_index=True)[["source", "optimizer", *PARAM_NAMES]]
    if _synthetic(study, [specimen]):
        mark_synthetic(fig)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    png = out_dir / f"posterior_{slug(specimen)}.png"
    fig.subplots_adjust(left=0.04, right=0.99, top=0.90, bottom=0.07)
    fig.savefig(png, dpi=DPI)
    plt.close(fig)
    frame.to_csv(png.with_suffix(".csv"), index=False, float_format="%.6g")
    return png


def parameters_vs_underpressure(study, out_dir, optimizer: str, material: str) -> Path:
    """The 14 parameters against underpressure for one material (the paper's Figs 18–19):
    median and min–max range over the seeds (and repeats) of ``optimizer``'s ranking runs,
    each run a faint dot, truth as black ×."""
    theme()
    runs = finished(study.ranking)
    runs = runs[(runs["optimizer"] == optimizer) & (runs["material"] == material)]
    colour = palette(study)[optimizer]
    long = runs.melt(id_vars=["specimen", "underpressure_MPa", "repeat", "replicate"],
                     value_vars=list(PARAM_NAMES), var_name="parameter", value_name="value").assign(source=optimizer)
    truths = []
    for specimen, g in runs.groupby("specimen"):
        truth = _truth(study, specimen)
        if truth is not None:
            first = g.iloc[0]
            truths += [{"specimen": specimen, "underpressure_MPa": first["underpressure_MPa"],
                        "repeat": first["repeat"], "replicate": -1, "parameter": n, "value": float(v),
                        "source": "truth"} for n, v in zip(PARAM_NAMES, truth)]
    frame = pd.concat([long, pd.DataFrame(truths)], ignore_index=True).assign(material=material)
    fig, axes = plt.subplots(2, 7, figsize=(19, 6.6), squeeze=False)
    pressures = sorted(runs["underpressure_MPa"].unique())
    step = np.min(np.diff(pressures)) if len(pressures) > 1 else 0.02
    for ax, name in zip(axes.flat, PARAM_NAMES):
        g = long[long["parameter"] == name]
        stats = g.groupby("underpressure_MPa")["value"].agg(["median", "min", "max"])
        ax.plot(g["underpressure_MPa"], g["value"], ".", color=colour, alpha=0.35, ms=5)
        ax.fill_between(stats.index, stats["min"], stats["max"], color=colour, alpha=0.15, lw=0)
        ax.plot(stats.index, stats["median"], "-o", color=colour, ms=4, lw=1.4)
        t = frame[(frame["source"] == "truth") & (frame["parameter"] == name)]
        ax.plot(t["underpressure_MPa"], t["value"], "x", color="black", ms=7, mew=1.8)
        ax.set_title(axis_label(name), fontsize=10)
        ax.set_xlim(pressures[0] - step / 2, pressures[-1] + step / 2) if pressures else None
        ax.tick_params(labelsize=8)
        ax.xaxis.set_major_locator(matplotlib.ticker.FixedLocator(pressures))
        ax.set_xticklabels([f"{p:g}" for p in pressures])
    for ax in axes[-1]:
        ax.set_xlabel("underpressure (MPa)")
    n_seeds = runs.groupby("specimen").size()
    n_repeats = runs.groupby("underpressure_MPa")["specimen"].nunique()
    legend = [matplotlib.lines.Line2D([], [], color=colour, marker="o", label=f"{optimizer}: median"),
              matplotlib.patches.Patch(color=colour, alpha=0.3, label="min–max"),
              matplotlib.lines.Line2D([], [], color=colour, marker=".", ls="", alpha=0.5, label="each run"),
              matplotlib.lines.Line2D([], [], color="black", marker="x", ls="", label="truth")]
    fig.legend(handles=legend, loc="upper right", ncol=4, fontsize=9)
    seeds = int(n_seeds.max()) if len(n_seeds) else 0
    repeats = int(n_repeats.max()) if len(n_repeats) else 0
    fig.suptitle(f"{material}: identified parameters vs underpressure — {optimizer}, median and range over "
                 f"{seeds} seeds × {repeats} repeat(s) per underpressure", fontsize=11, x=0.01, ha="left")
    return save(fig, out_dir, f"underpressure_{slug(material)}", frame, _synthetic(study, runs["specimen"].unique()),
                 rect=(0, 0.03, 1, 0.95))


def profiles(analysis: dict, out_dir, synthetic_data: bool = False) -> Path:
    """Profile likelihoods from ``identifiability.analyse``: MSE against each profiled parameter,
    the others re-optimised; the analysed fit and the 95 % likelihood-ratio threshold (profile
    points below it are statistically as good as the best) marked. Log y when it spans > 10×."""
    theme()
    names = list(analysis["profiles"])
    fig, axes = plt.subplots(1, len(names), figsize=(4.8 * len(names), 4.0), squeeze=False)
    rows = []
    values = [p["mse"] for points in analysis["profiles"].values() for p in points if p["mse"] is not None]
    floor = min([analysis["mse"], *values])  # the best fit any profile found
    # 95 % likelihood-ratio threshold for one parameter: ΔSSR = 1.96²·s², i.e. ΔMSE = 1.96²·s²/L
    threshold = floor + 1.96**2 * analysis["noise_rmse_N"] ** 2 / analysis["n_data"]
    for ax, name in zip(axes[0], names):
        points = pd.DataFrame(analysis["profiles"][name])
        mse = points["mse"].astype(float)
        ax.plot(points["value"], mse, "-o", ms=4, color="C0", label="profile (others re-optimised)")
        ax.plot(analysis["params"][name], analysis["mse"], "*", ms=13, color="C3", label="analysed fit")
        ax.axhline(threshold, color="0.3", ls="--", lw=0.9, label="95 % threshold (one parameter)")
        if np.nanmax(mse) / floor > 10:
            ax.set_yscale("log")
        else:
            ax.ticklabel_format(axis="y", style="plain", useOffset=False)
        ax.set_xlabel(axis_label(name))
        ax.set_ylabel("MSE (N²)")
        ax.legend(fontsize=8)
        rows.append(points.assign(parameter=name, threshold_mse=threshold))
    fig.suptitle(f"{analysis['specimen']}: profile likelihoods (MSE after re-optimising the other 13 parameters)",
                 fontsize=11)
    frame = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    return save(fig, out_dir, f"profiles_{slug(analysis['specimen'])}", frame, synthetic_data)
