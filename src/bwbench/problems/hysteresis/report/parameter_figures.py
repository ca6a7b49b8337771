"""Figures of the switched-model problem: one fit (``bwbench fit --plot``), and a study's loops,
parameter spread, posterior, parameters against underpressure and profiles.

Each study figure returns the PNG's path and writes the CSV behind it beside it (same name).
``order``: the report's ranking (best first), for the backends' styles and legend order (see
``bwbench.render.palette``). The fits are in ``fit_figures``, the posterior and profiles in
``posterior_figures``; the parameter figures are here.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from bwbench.analysis import statistics
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.models.switched.parameters import LABELS, LOWER, UPPER
from bwbench.problems.hysteresis.report.figure_common import EDGE, axis_label, edge_bands, synthetic, truth
from bwbench.render.palette import (
    MAX_WIDTH_IN,
    TRUTH,
    backend_handles,
    figure,
    legend,
    runs_text,
    save,
    slug,
    styles,
    theme,
    truth_handle,
)
from bwbench.render.run_figures import finished, specimen_order, specimen_title

SPREAD_TOLERANCE = 0.10  # parameter spread: runs with MSE ≤ (1 + 0.10) × best known


def _unit(values) -> np.ndarray:
    """Paper parameters as positions in their Table 5 range (0 = lower, 1 = upper)."""
    return (np.asarray(values, dtype=float) - LOWER) / (UPPER - LOWER)


def parameter_spread(study, out_dir, specimens=None, tolerance: float = SPREAD_TOLERANCE, order=None) -> Path:
    """The 14 parameters, scaled to their Table 5 range, of every ranking run whose MSE is within
    ``tolerance`` of the best known for its specimen: one panel per specimen (at most 3, in natural
    order), one column of points per backend that has such runs; the truth as black ×."""
    theme()
    specimens = specimen_order(study, list(specimens or study.specimens)[:3])
    best = statistics.best_known(study.runs)
    runs = finished(study.ranking)
    runs = runs[runs["specimen"].isin(specimens)]
    good = runs[runs["mse"] <= runs["specimen"].map(best) * (1 + tolerance)]
    look = styles(study, order)
    present = [o for o in look if o in set(good["optimizer"])]  # "(0/5 runs)" entries say nothing
    fig, axes = figure(
        MAX_WIDTH_IN, 2.9 * len(specimens) + 1.6, nrows=len(specimens), ncols=1, squeeze=False, sharex=True
    )
    rows, off_scale = [], 0
    width = 0.8 / max(len(present), 1)
    rng = np.random.default_rng(0)  # jitter only: the figure is the same every time
    x0 = np.arange(len(PARAM_NAMES))
    for ax, specimen in zip(axes[:, 0], specimens):
        here = good[good["specimen"] == specimen]
        for b, optimizer in enumerate(present):
            g = here[here["optimizer"] == optimizer]
            values = g[list(PARAM_NAMES)].to_numpy(dtype=float)
            unit = _unit(values)
            offset = (b - (len(present) - 1) / 2) * width
            off_scale += int(np.sum((unit < 0) | (unit > 1)))
            for j in range(len(PARAM_NAMES)):
                x = j + offset + rng.uniform(-0.25, 0.25, len(g)) * width
                # beyond the Table 5 range (an identifiable fit mapped back): on the grey edge bands
                ax.plot(x, np.clip(unit[:, j], -EDGE, 1 + EDGE), **look[optimizer].point(ms=5.5), alpha=0.85, zorder=3)
            for (replicate, mse), v, u in zip(g[["replicate", "mse"]].itertuples(index=False), values, unit):
                rows += [
                    {
                        "specimen": specimen,
                        "optimizer": optimizer,
                        "replicate": replicate,
                        "mse": mse,
                        "parameter": n,
                        "value": v[j],
                        "unit_value": u[j],
                    }
                    for j, n in enumerate(PARAM_NAMES)
                ]
        true = truth(study, specimen)
        if true is not None:
            unit_truth = _unit(true)
            ax.hlines(unit_truth, x0 - 0.42, x0 + 0.42, color="black", lw=1.0, zorder=1)
            ax.plot(x0, unit_truth, **TRUTH, zorder=4)
            rows += [
                {
                    "specimen": specimen,
                    "optimizer": "truth",
                    "replicate": -1,
                    "mse": np.nan,
                    "parameter": n,
                    "value": float(v),
                    "unit_value": float(w),
                }
                for n, v, w in zip(PARAM_NAMES, true, unit_truth)
            ]
        ax.set_xlim(-0.6, len(PARAM_NAMES) - 0.4)
        edge_bands(ax)
        ax.set_ylabel("position in range (–)")
        ax.set_title(
            f"{specimen_title(study, specimen)}: best known {best[specimen]:.4g} {study.loss_unit}, "
            f"{len(here)} of {int((runs['specimen'] == specimen).sum())} runs within {tolerance:.0%}",
            loc="left",
        )
        for j in range(len(PARAM_NAMES) - 1):
            ax.axvline(j + 0.5, color="0.85", lw=0.8)
        ax.axvline(6.5, color="0.4", lw=1.2)  # tension set | compression set
        ax.grid(axis="x", visible=False)
    axes[-1, 0].set_xticks(x0, [LABELS[n] for n in PARAM_NAMES])
    axes[-1, 0].set_xlabel("parameter, scaled to its Table 5 search range (0 = lower, 1 = upper bound)")
    totals = good.groupby("optimizer").size()
    handles = backend_handles(look, present, {o: f"{o} ({runs_text(int(totals[o]))})" for o in present}, line=False)
    if any(r["optimizer"] == "truth" for r in rows):
        handles.append(truth_handle())
    legend(fig, handles, ncol=min(len(handles), 5))
    fig.suptitle(
        f"Parameter spread across seeds: every ranking run with MSE ≤ {1 + tolerance:g} × the best known "
        "for its specimen"
        + (f"\n{off_scale} values beyond the Table 5 range are drawn on the grey band at its edge" if off_scale else "")
    )
    frame = pd.DataFrame(
        rows, columns=["specimen", "optimizer", "replicate", "mse", "parameter", "value", "unit_value"]
    )
    return save(fig, out_dir, "spread", frame, synthetic(study, specimens))


def parameters_vs_underpressure(study, out_dir, optimizer: str, material: str, order=None) -> Path:
    """The 14 parameters against underpressure for one material (the paper's Figs 18–19): every
    ranking run of ``optimizer`` as a point, the median as a bar with the min–max range over its
    seeds (and repeats), the truth as black ×. Each panel's y axis is the parameter's whole Table 5
    range (0 = lower, 1 = upper bound, the bounds in the title), so a change is seen at its true size;
    no lines join the pressures, which would suggest a trend the data may not identify."""
    theme()
    runs = finished(study.ranking)
    runs = runs[(runs["optimizer"] == optimizer) & (runs["material"] == material)]
    style = styles(study, order)[optimizer]
    long = runs.melt(
        id_vars=["specimen", "underpressure_MPa", "repeat", "replicate"],
        value_vars=list(PARAM_NAMES),
        var_name="parameter",
        value_name="value",
    ).assign(source=optimizer)
    truths = []
    for specimen, g in runs.groupby("specimen"):
        true = truth(study, specimen)
        if true is not None:
            first = g.iloc[0]
            truths += [
                {
                    "specimen": specimen,
                    "underpressure_MPa": first["underpressure_MPa"],
                    "repeat": first["repeat"],
                    "replicate": -1,
                    "parameter": n,
                    "value": float(v),
                    "source": "truth",
                }
                for n, v in zip(PARAM_NAMES, true)
            ]
    frame = pd.concat([long, pd.DataFrame(truths)], ignore_index=True).assign(material=material)
    frame["unit_value"] = [
        (v - LOWER[PARAM_NAMES.index(n)]) / (UPPER - LOWER)[PARAM_NAMES.index(n)]
        for n, v in zip(frame["parameter"], frame["value"])
    ]
    frame["drawn_at_edge"] = (frame["unit_value"] < 0) | (frame["unit_value"] > 1)
    pressures = sorted(runs["underpressure_MPa"].unique())
    step = float(np.min(np.diff(pressures))) if len(pressures) > 1 else 0.02
    fig, axes = figure(MAX_WIDTH_IN, 7.2, nrows=2, ncols=7, squeeze=False, sharex=True, sharey=True)
    rng = np.random.default_rng(0)  # jitter only: the figure is the same every time
    off_scale = 0
    for ax, name in zip(axes.flat, PARAM_NAMES):
        g = frame[(frame["source"] == optimizer) & (frame["parameter"] == name)]
        jitter = rng.uniform(-0.12, 0.12, len(g)) * step
        # Values beyond the Table 5 range (the identifiable formulation's box is another) are drawn on
        # the panel's edge as triangles pointing the way they went, never silently cut off.
        y = g["unit_value"].to_numpy()
        for mask, marker, edge in ((y < 0, "v", -EDGE), ((y >= 0) & (y <= 1), "o", None), (y > 1, "^", 1 + EDGE)):
            ax.plot(
                g["underpressure_MPa"][mask] + jitter[mask],
                y[mask] if edge is None else np.full(mask.sum(), edge),
                **{**style.point(ms=4.5), "marker": marker},
                alpha=0.55,
                zorder=3,
            )
        off_scale += int(np.sum((y < 0) | (y > 1)))
        stats = (
            g.assign(unit_value=g["unit_value"].clip(-EDGE, 1 + EDGE))
            .groupby("underpressure_MPa")["unit_value"]
            .agg(["median", "min", "max"])
        )
        ax.errorbar(
            stats.index + 0.3 * step,
            stats["median"],
            yerr=[stats["median"] - stats["min"], stats["max"] - stats["median"]],
            fmt="_",
            ms=14,
            mew=2.4,
            color=style.colour,
            ecolor=style.colour,
            elinewidth=1.4,
            capsize=3,
            ls="none",
            zorder=4,
        )
        t = frame[(frame["source"] == "truth") & (frame["parameter"] == name)]
        t = t.assign(unit_value=t["unit_value"].clip(-EDGE, 1 + EDGE))
        ax.plot(t["underpressure_MPa"], t["unit_value"], **{**TRUTH, "ms": 7}, zorder=5)
        j = PARAM_NAMES.index(name)
        ax.set_title(f"{axis_label(name)}\n{LOWER[j]:.3g} … {UPPER[j]:.3g}", fontsize=10)
        ax.set_xlim(pressures[0] - 0.7 * step, pressures[-1] + 0.8 * step) if pressures else None
        ax.set_xticks(pressures, [f"{p:g}" for p in pressures])
        ax.tick_params(axis="x", labelrotation=90 if len(pressures) > 3 else 0)
        edge_bands(ax)
        ax.set_yticks([0, 0.5, 1])
    for ax in axes[:, 0]:
        ax.set_ylabel("position in range (–)")
    for ax in axes[-1]:
        ax.set_xlabel("underpressure (MPa)")
    seeds = int(runs.groupby("specimen").size().max()) if len(runs) else 0
    repeats = int(runs.groupby("underpressure_MPa")["specimen"].nunique().max()) if len(runs) else 0
    handles = [
        style.handle(f"{optimizer}: each run", line=False),
        Line2D([], [], color=style.colour, marker="_", ms=14, mew=2.4, ls="-", lw=1.4, label="median, bar = min–max"),
    ]
    if off_scale:
        handles.append(
            Line2D(
                [],
                [],
                color=style.colour,
                marker="^",
                ls="none",
                ms=6,
                label=f"beyond the range, at its edge ({off_scale} of {len(runs) * 14} values)",
            )
        )
    if truths:
        handles.append(truth_handle())
    legend(fig, handles, ncol=2 if off_scale else 3)
    gauge = (
        "\nA, β, γ (and with them α, ξ, ωn) of an identifiable fit are one point on the exact symmetry's "
        "orbit: the gauge nearest Table 5's centre"
        if "[identifiable]" in optimizer
        else ""
    )
    fig.suptitle(
        f"{material}: identified parameters against underpressure — {optimizer}, {seeds} seeds × "
        f"{repeats} repeat(s) per underpressure\ny axis: each parameter's whole Table 5 range (its bounds "
        f"under its name){gauge}",
        fontsize=11,
    )
    name = f"underpressure_{slug(material)}" + ("_identifiable" if "[identifiable]" in optimizer else "")
    return save(fig, out_dir, name, frame, synthetic(study, runs["specimen"].unique()))
