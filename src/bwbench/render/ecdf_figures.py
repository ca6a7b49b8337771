"""Runtime distributions as the benchmarking field draws them (COCO, IOHprofiler): one figure, the
fixed-target view beside the fixed-budget view.

- Fixed target (left): the ECDF of runtimes — for each label, the fraction of (run, target) pairs
  whose target its run reached within x evaluations, over ``ECDF_TAUS``: 51 targets log-spaced
  from 0.1 % to 100× above the best known loss of the specimen (COCO uses 51 log-spaced Δf
  targets). A curve reaches 1 only if every run hit every target.
- Fixed budget (right): the ECDF of final losses — the fraction of runs whose final loss is within
  x of the best known (x = final / best known − 1, log axis; the 1 % and 10 % success levels are
  lines).

Small multiples by variant (one row per formulation, say) keep a study of 24 labels readable; in
each row the ``HIGHLIGHT`` best labels by the report's order are drawn in their colours, random
search (the baseline) in dark grey, the others thin light grey and named in the panel.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from bwbench.analysis import statistics
from bwbench.render.labels import is_baseline, split_label
from bwbench.render.palette import MAX_WIDTH_IN, figure, legend, save, styles, theme

ECDF_TAUS = tuple(float(t) for t in np.geomspace(1e-3, 1e2, 51))
HIGHLIGHT = 4  # coloured labels per panel when a panel has more than MAX_COLOURED candidates
MAX_COLOURED = 6
GREY = "0.74"
FLOOR = 1e-5  # final losses within 0.001 % of the best known are drawn at this excess


def ecdf(evals, grid) -> np.ndarray:
    """Fraction of ``evals`` (inf = never) that are ≤ each value of ``grid``."""
    evals = np.sort(np.asarray(evals, dtype=float))
    if evals.size == 0:
        return np.zeros(len(grid))
    return np.searchsorted(evals, grid, side="right") / evals.size


def by_variant(labels) -> dict:
    """{variant (None when the labels carry none): labels in the given order}."""
    groups: dict = {}
    for label in labels:
        groups.setdefault(split_label(label)[1], []).append(label)
    return groups


def highlighted(labels, k: int = HIGHLIGHT) -> tuple[list, list, list]:
    """(coloured, baselines, grey) of one panel's ``labels`` given best first: every candidate
    coloured up to ``MAX_COLOURED``, else the best ``k``."""
    candidates = [n for n in labels if not is_baseline(n)]
    coloured = candidates if len(candidates) <= MAX_COLOURED else candidates[:k]
    return coloured, [n for n in labels if is_baseline(n)], [n for n in candidates if n not in coloured]


def runtime_distributions(study, out_dir, order=None, noun: str | None = None, taus=ECDF_TAUS) -> Path:
    """The figure (``ecdf.png``) and its CSV: the curves as drawn, one row per point (``view``
    fixed-target: x = evaluations, fraction of (run, target) pairs; fixed-budget: x = final loss /
    best known − 1, fraction of runs)."""
    theme()
    ranking = study.ranking
    look = styles(study, order)
    labels = [o for o in look if o in set(ranking["optimizer"])]
    groups = by_variant(labels)
    best = statistics.best_known(study.runs)
    rt = statistics.runtimes(ranking, study.traces, taus, best)
    excess = (statistics.final_mse(ranking) / ranking["specimen"].map(best).astype(float) - 1.0).to_numpy()
    budget = float(np.nanmax(ranking["nfev"])) if len(ranking) else 1.0
    grid = np.unique(np.round(np.geomspace(1, max(budget, 2), 300)).astype(int))
    finite = excess[np.isfinite(excess)]
    high = max(float(finite.max()) * 2 if len(finite) else 10.0, 1.0)
    fig, axes = figure(MAX_WIDTH_IN, 4.1 * len(groups) + 1.5, nrows=len(groups), ncols=2, squeeze=False)
    rows, drawn = [], []
    for (variant, names), (left, right) in zip(groups.items(), axes):
        coloured, baselines, grey = highlighted(names)
        for rank, name in enumerate(grey + baselines + coloured[::-1]):
            kw = (
                {"color": GREY, "lw": 1.0, "zorder": 2}
                if name in grey
                else look[name].line(
                    lw=1.9, markers=True, ms=5, zorder=10 - min(rank, 8), markevery=(7 + 29 * rank % 53, 60)
                )
            )
            y = ecdf(rt.loc[rt["optimizer"] == name, "evals"], grid)
            left.step(grid, y, where="post", **kw)
            mine = np.sort(np.maximum(excess[(ranking["optimizer"] == name).to_numpy()], FLOOR))
            share = np.arange(1, mine.size + 1) / max(mine.size, 1)
            shown = np.isfinite(mine)
            right.step(
                np.r_[FLOOR, mine[shown]],
                np.r_[0.0, share[shown]],
                where="post",
                **{**kw, "markevery": (1, max(1, mine.size // 6))} if name not in grey else kw,
            )
            drawn += [] if name in grey else [name]
            rows.append(
                pd.DataFrame(
                    {
                        "view": "fixed target",
                        "variant": variant,
                        "label": name,
                        "x": grid,
                        "fraction": y,
                        "highlighted": name not in grey,
                    }
                )
            )
            rows.append(
                pd.DataFrame(
                    {
                        "view": "fixed budget",
                        "variant": variant,
                        "label": name,
                        "x": mine,
                        "fraction": share,
                        "highlighted": name not in grey,
                    }
                )
            )
        where = f"{variant} {noun or 'variant'}: " if variant is not None else ""
        left.set_title(f"{where}fixed target ({len(taus)} targets)", loc="left")
        right.set_title(f"{where}fixed budget ({budget:,.0f} evaluations)", loc="left")
        _axes(left, right, budget, high)
        if grey:
            left.text(
                0.015,
                0.97,
                "grey: " + ", ".join(split_label(n)[0] for n in grey),
                transform=left.transAxes,
                va="top",
                ha="left",
                fontsize=9,
                color="0.25",
                wrap=True,
                bbox={"fc": "white", "ec": "0.8", "boxstyle": "round"},
            )
    handles = [look[n].handle() for n in look if n in set(drawn)]
    handles += [
        Line2D([], [], color="black", lw=1.0, ls=ls, label=f"final loss {tau:.0%} above the best known")
        for tau, ls in zip(statistics.TOLERANCES, (":", "--"))
    ]
    if any(highlighted(names)[2] for names in groups.values()):
        handles.append(Line2D([], [], color=GREY, lw=1.0, label="other labels (named in the panel)"))
    legend(fig, handles, ncol=3)
    fig.suptitle(
        "Runtime distributions: how often and how fast each label reaches the best known loss "
        "(labels in the report's order)"
    )
    frame = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    return save(fig, out_dir, "ecdf", frame, study.problem_type.is_synthetic(study))


def excess_label(v, _=None) -> str:
    """A tick of the excess axis (a fraction above the best known) in per cent, short enough not to
    collide with its neighbours: '0.1 %', '10 %', '100 %', then powers of ten ('10⁵ %', not '100,000 %')."""
    prefix = "≤ " if v <= FLOOR * 1.0001 else ""
    percent = v * 100
    if percent < 1000:
        return f"{prefix}{percent:g} %"
    exponent = int(round(np.log10(percent)))
    power = "10" + str(exponent).translate(_SUPERSCRIPT)  # Unicode, not mathtext: text is drawn as written
    return f"{prefix}{power} %" if np.isclose(percent, 10.0**exponent) else f"{prefix}{percent:.0e} %"


_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _axes(left, right, budget: float, high: float) -> None:
    left.set_xscale("log")
    left.set_xlim(1, budget * 1.05)
    left.set_ylim(-0.02, 1.02)
    left.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:,.0f}"))
    left.set_xlabel("evaluations")
    left.set_ylabel("fraction of (run, target) pairs reached (–)")
    right.set_xscale("log")
    right.set_xlim(FLOOR / 1.5, high)
    right.set_ylim(-0.02, 1.02)
    for tau, ls in zip(statistics.TOLERANCES, (":", "--")):
        right.axvline(tau, color="black", lw=1.0, ls=ls, zorder=1)
    right.xaxis.set_major_locator(matplotlib.ticker.LogLocator(numticks=7))
    right.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    right.xaxis.set_major_formatter(matplotlib.ticker.FuncFormatter(excess_label))
    right.set_xlabel("final loss above the best known (log)")
    right.set_ylabel("fraction of runs (–)")
