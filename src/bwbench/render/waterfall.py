"""The waterfall: every ranking run's final loss, one row per run, sorted per specimen and backend."""

from __future__ import annotations

from pathlib import Path

import matplotlib.ticker
import numpy as np
from matplotlib.lines import Line2D

from bwbench.analysis import statistics
from bwbench.render.palette import (
    MAX_WIDTH_IN,
    figure,
    legend,
    save,
    split_label,
    styles,
    theme,
)
from bwbench.render.run_figures import specimen_order, specimen_title


def waterfall(study, out_dir, order=None, specimens=None) -> Path:
    """Final MSE of every ranking run above its specimen's best known, one panel per specimen (in
    natural order), one slot per backend (best first) with its runs sorted: a flat stretch is a
    plateau where several seeds end at the same (local) optimum. Log axis of (MSE − best)/best, as
    COCO plots Δf: the 1 % and 10 % success levels are lines; the best known run itself sits on the
    bottom edge; runs above the plotted range are a ▲ at the top edge with their count."""
    theme()
    ranking = study.ranking
    best = statistics.best_known(study.runs)
    final = statistics.final_mse(ranking)
    frame = ranking[["optimizer", "specimen", "replicate", "status"]].assign(
        final_mse=final.to_numpy(), best_known=ranking["specimen"].map(best).to_numpy()
    )
    frame["ratio"] = frame["final_mse"] / frame["best_known"]
    frame = frame.sort_values(["specimen", "optimizer", "ratio"], kind="stable")
    frame["rank"] = frame.groupby(["specimen", "optimizer"]).cumcount() + 1
    look = styles(study, order)
    optimizers = [o for o in look if o in set(frame["optimizer"])]
    specimens = specimen_order(study, specimens or list(dict.fromkeys(frame["specimen"])))
    excess = 100 * (frame["ratio"] - 1)  # % above the best known
    finite = excess[np.isfinite(excess)]
    # Bottom: one decade below the 1 % line (or the smallest positive excess); top: the upper
    # quartile of the backends other than random, to the next decade: random search's runs
    # hundreds of times above the best would otherwise squash the range where the ranking is.
    bottom = min(0.1, 10 ** np.floor(np.log10(finite[finite > 0].min()))) if (finite > 0).any() else 0.1
    bottom = max(bottom, 1e-3)
    others = finite[[split_label(o)[0] != "random" for o in frame.loc[finite.index, "optimizer"]]]
    q = float(np.percentile(others, 75)) if len(others) else float(finite.max()) if len(finite) else 100.0
    top = max(100.0, 10 ** np.ceil(np.log10(max(q, 1e-9)) + 0.3))
    fig, axes = figure(
        MAX_WIDTH_IN, 2.5 * len(specimens) + 1.9, nrows=len(specimens), ncols=1, squeeze=False, sharex=True, sharey=True
    )
    for ax, specimen in zip(axes[:, 0], specimens):
        for b, optimizer in enumerate(optimizers):
            g = frame[(frame["specimen"] == specimen) & (frame["optimizer"] == optimizer)]
            e = 100 * (g["ratio"].to_numpy() - 1)
            x = b + (np.linspace(-0.3, 0.3, len(e)) if len(e) > 1 else np.zeros(len(e)))
            inside = np.isfinite(e) & (e <= top)
            shown = np.clip(e, bottom, top)
            style = look[optimizer]
            ax.plot(x[inside], shown[inside], **style.line(lw=1.0, markers=True, ms=5), zorder=3)
            above, failed = int((np.isfinite(e) & (e > top)).sum()), int((~np.isfinite(e)).sum())
            if above:
                ax.plot(
                    b, top, marker="^", ms=9, color=style.colour, mec="black", mew=0.6, ls="", clip_on=False, zorder=5
                )
                ax.annotate(
                    f"{above}",
                    (b, top),
                    xytext=(7, -3),
                    textcoords="offset points",
                    fontsize=9.5,
                    va="top",
                    annotation_clip=False,
                )
            if failed:
                ax.annotate(
                    f"{failed} failed",
                    (b, bottom),
                    xytext=(0, 3),
                    textcoords="offset points",
                    fontsize=9,
                    ha="center",
                    va="bottom",
                    color="0.2",
                )
        for tau, ls in zip(statistics.TOLERANCES, (":", "--")):
            ax.axhline(100 * tau, color="black", lw=1.0, ls=ls, zorder=2)
        ax.set_yscale("log")
        ax.set_ylim(bottom / 1.5, top)  # the best run, drawn at the bottom tick, stays whole
        ax.yaxis.set_major_formatter(
            matplotlib.ticker.FuncFormatter(
                lambda v, _, low=bottom: (
                    f"{'≤ ' if v <= low * 1.0001 else ''}{v:,.0f} %"
                    if v >= 1
                    else f"{'≤ ' if v <= low * 1.0001 else ''}{v:g} %"
                )
            )
        )
        ax.set_ylabel("final MSE above best known")
        ax.set_title(
            f"{specimen_title(study, specimen)}: best known {best[specimen]:.4g} {study.loss_unit}", loc="left"
        )
        for b in range(len(optimizers) - 1):
            ax.axvline(b + 0.5, color="0.85", lw=0.8)
        ax.grid(axis="x", visible=False)
    axes[-1, 0].set_xticks(range(len(optimizers)), optimizers, rotation=30, ha="right")
    axes[-1, 0].set_xlim(-0.6, len(optimizers) - 0.4)
    handles = [
        Line2D([], [], color="black", lw=1.0, ls=ls, label=f"{tau:.0%} above the best known (success at {tau:.0%})")
        for tau, ls in zip(statistics.TOLERANCES, (":", "--"))
    ]
    if (np.isfinite(excess) & (excess > top)).any():
        handles.append(
            Line2D(
                [],
                [],
                color="0.4",
                marker="^",
                ms=8,
                mec="black",
                mew=0.6,
                ls="",
                label=f"n runs above {top:,.0f} % (off the scale)",
            )
        )
    legend(fig, handles, ncol=3)
    fig.suptitle(
        "Waterfall: final MSE of every ranking run above its specimen's best known, runs sorted per "
        "backend (backends best first)"
    )
    return save(fig, out_dir, "waterfall", frame, study.problem_type.is_synthetic(study))
