"""Profile likelihoods of the least determined parameters: each point a local fit of the others, the
95 % threshold, whether the region is bounded on each side (only a converged re-optimisation shows
it), and the figure with the CSV behind it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.problems.hysteresis.report.figure_common import axis_label
from bwbench.render.palette import MAX_WIDTH_IN, OKABE_ITO, figure, legend, save, slug, theme


def threshold_of(analysis: dict) -> tuple[float, float]:
    """(best MSE any profile or the analysed fit reached, the 95 % likelihood-ratio threshold)."""
    values = [p["mse"] for points in analysis["profiles"].values() for p in points if p["mse"] is not None]
    floor = min([analysis["mse"], *values])
    # 95 % likelihood-ratio threshold for one parameter: ΔSSR = 1.96²·s², i.e. ΔMSE = 1.96²·s²/L
    return floor, floor + 1.96**2 * analysis["noise_rmse_N"] ** 2 / analysis["n_data"]


def bounded(values, mse, threshold: float, converged=None) -> str:
    """Whether the profile shows its 95 % region bounded on both sides of its minimum, one, or
    neither: ``"both sides"``, ``"below only"`` (the lower side), ``"above only"`` or ``"neither"``.

    A profile point is an upper bound of the true profile, so only a ``converged`` point above the
    threshold shows a bound (default: every point converged); ``"not shown"`` when the profile rises
    above the threshold only at points whose re-optimisation did not converge."""
    values, mse = np.asarray(values, dtype=float), np.asarray(mse, dtype=float)
    converged = np.ones(mse.shape, bool) if converged is None else np.asarray(converged, dtype=bool)
    ok = np.isfinite(mse)
    values, mse, converged = values[ok], mse[ok], converged[ok]
    if not values.size:
        return "neither"
    i = int(np.argmin(mse))
    above = (mse > threshold) & converged
    low, high = bool(np.any(above[:i])), bool(np.any(above[i + 1 :]))
    if not (low or high) and np.any(mse > threshold):
        return "not shown"
    return {(True, True): "both sides", (True, False): "below only", (False, True): "above only"}.get(
        (low, high), "neither"
    )


BOUNDED_TEXT = {
    "both sides": "bounded on both sides",
    "below only": "bounded below only (open above)",
    "above only": "bounded above only (open below)",
    "neither": "not bounded: all of the range is in it",
    "not shown": "no bound shown (not converged)",
}


def better_fit_text(found: float, analysed: float, unit: str = "N²", least: float = 1e-4) -> str | None:
    """'9.7041 N², 0.45 % below the analysed fit's 9.7483 N²', with digits enough to tell them
    apart; None when the profile's fit is not lower by at least ``least`` (relative)."""
    if not (np.isfinite(found) and np.isfinite(analysed)) or analysed <= 0 or (analysed - found) / analysed < least:
        return None
    gap = (analysed - found) / analysed
    digits = max(5, int(np.ceil(-np.log10(gap))) + 2)
    return f"{found:.{digits}g} {unit}, {gap:.2%} below the analysed fit's {analysed:.{digits}g} {unit}"


def _region(values, mse, threshold: float) -> list[tuple[float, float]]:
    """Intervals of the parameter where the profile (linearly interpolated) is below ``threshold``."""
    out, start = [], None
    for k, (v, m) in enumerate(zip(values, mse)):
        below = np.isfinite(m) and m <= threshold
        if below and start is None:
            start = v if k == 0 or not np.isfinite(mse[k - 1]) else _cross(values[k - 1], mse[k - 1], v, m, threshold)
        if not below and start is not None:
            end = values[k - 1] if not np.isfinite(m) else _cross(values[k - 1], mse[k - 1], v, m, threshold)
            out.append((start, end))
            start = None
    if start is not None:
        out.append((start, values[-1]))
    return out


def _cross(v0, m0, v1, m1, level):
    return v0 + (level - m0) * (v1 - v0) / (m1 - m0) if m1 != m0 else v0


def profiles(analysis: dict, out_dir, synthetic_data: bool | str = False) -> Path:
    """Profile likelihoods from ``identifiability.analyse``: MSE against each profiled parameter,
    the others re-optimised. Marked: the analysed fit (★), the 95 % likelihood-ratio threshold
    (profile points below it are statistically as good as the best) with the region below it
    shaded, whether that region is bounded on both sides, one or none, and, when the profile
    found a better fit than the analysed one, by how much. Log y when the profile spans > 10×."""
    theme()
    names = list(analysis["profiles"])
    floor, threshold = threshold_of(analysis)
    ncols = min(len(names), 3)
    nrows = -(-len(names) // ncols)
    fig, axes = figure(MAX_WIDTH_IN if ncols > 1 else 6.5, 3.9 * nrows + 1.6, nrows=nrows, ncols=ncols, squeeze=False)
    rows = []
    blue, star, better = OKABE_ITO[0], OKABE_ITO[3], OKABE_ITO[1]
    found_better = []
    for ax, name in zip(axes.flat, names):
        points = pd.DataFrame(analysis["profiles"][name]).sort_values("value")
        values = points["value"].astype(float).to_numpy()
        mse = pd.to_numeric(points["mse"], errors="coerce").to_numpy(dtype=float)
        for a, b in _region(values, mse, threshold):
            ax.axvspan(a, b, color=blue, alpha=0.12, lw=0, zorder=0)
        ax.axhline(threshold, color="0.25", ls="--", lw=1.0)
        ax.plot(values, mse, "-o", ms=5, color=blue, zorder=3)
        ax.plot(analysis["params"][name], analysis["mse"], "*", ms=15, color=star, mec="black", mew=0.6, zorder=5)
        converged = points["converged"].astype(bool).to_numpy() if "converged" in points else np.ones(len(mse), bool)
        if (~converged).any():
            ax.plot(values[~converged], mse[~converged], "o", ms=8, mfc="white", mec=blue, mew=1.4, zorder=4)
        i = int(np.nanargmin(mse)) if np.isfinite(mse).any() else None
        text = better_fit_text(mse[i], analysis["mse"]) if i is not None else None
        if text:
            ax.plot(values[i], mse[i], "D", ms=8, color=better, mec="black", mew=0.8, zorder=6)
            found_better.append((float(mse[i]), text))
            ax.annotate(
                "the profile found a better fit:\n" + text.replace(", ", ",\n", 1),
                (values[i], mse[i]),
                xytext=(0.5, 0.97),
                textcoords="axes fraction",
                ha="center",
                va="top",
                fontsize=9.5,
                bbox={"fc": "white", "ec": better, "boxstyle": "round"},
                arrowprops={"arrowstyle": "->", "color": better, "lw": 1.2},
            )
        side = bounded(values, mse, threshold, converged)
        ax.set_title(f"95 % region {BOUNDED_TEXT[side]}", loc="left")
        if values.size and values.min() > 0 and values.max() / values.min() > 100:
            ax.set_xscale("log")  # a log-scaled search coordinate: its grid is even in log
        finite = mse[np.isfinite(mse)]
        if finite.size and finite.max() / max(floor, 1e-300) > 10:
            ax.set_yscale("log")
        else:
            ax.ticklabel_format(axis="y", style="plain", useOffset=False)
            low = min([threshold, analysis["mse"], *finite]) if finite.size else threshold
            high = max([threshold, analysis["mse"], *finite]) if finite.size else threshold
            ax.set_ylim(low - 0.08 * (high - low), high + 0.35 * (high - low))  # room for the note on top
        if name in analysis.get("labels", {}) and name in analysis.get("units", {}):
            from bwbench.problems.hysteresis.report.posterior_draws import pretty

            ax.set_xlabel(f"{analysis['labels'][name]} ({pretty(analysis['units'][name])})")
        else:
            ax.set_xlabel(axis_label(name))
        ax.set_ylabel("MSE (N²)")
        rows.append(points.assign(parameter=name, threshold_mse=threshold, bounded=side))
    for ax in axes.flat[len(names) :]:
        ax.set_visible(False)
    handles = [
        Line2D(
            [],
            [],
            color=blue,
            marker="o",
            ms=5,
            label="profile (others re-optimised, converged: a bound is read from these only)",
        ),
        Line2D(
            [], [], ls="", marker="o", ms=8, mfc="white", mec=blue, mew=1.4, label="not converged: an upper bound only"
        ),
        Line2D([], [], ls="", marker="*", ms=13, color=star, mec="black", mew=0.6, label="analysed fit"),
        Line2D([], [], color="0.25", ls="--", label="95 % threshold (one parameter)"),
        Patch(color=blue, alpha=0.25, label="95 % region: profile below the threshold"),
    ]
    if found_better:
        handles.append(
            Line2D(
                [],
                [],
                ls="",
                marker="D",
                ms=8,
                color=better,
                mec="black",
                mew=0.8,
                label="a better fit than the analysed one",
            )
        )
    legend(fig, handles, ncol=3)
    d = len(analysis.get("params", {})) or None
    title = (
        f"{analysis['specimen']}: profile likelihoods (MSE after re-optimising the other "
        f"{d - 1 if d else ''} parameters)".replace("other  ", "other ")
    )
    if found_better:
        title += f"\nthe profile found a better fit: {min(found_better)[1]} — the analysed fit is not the optimum"
    fig.suptitle(title)
    frame = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    return save(fig, out_dir, f"profiles_{slug(analysis['specimen'])}", frame, synthetic_data)
