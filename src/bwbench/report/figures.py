"""Study figures every problem gets: convergence, runtime ECDF, waterfall; and the shared look.

Every function takes a loaded ``bwbench.study.results.Study`` and an output folder and returns the
PNG's path, with the tidy CSV behind it beside it (same name, ``.csv``). Colours follow the
backends' order in the study, so a backend has one colour in every figure. Figures of synthetic
data carry the SYNTHETIC mark.
"""

from __future__ import annotations

import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display on test machines and CI
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import seaborn as sns  # noqa: E402

from bwbench.analysis import statistics  # noqa: E402

DPI = 110
ECDF_TAUS = (1.0, 0.1, 0.01)
SYNTHETIC_LABEL = "SYNTHETIC DATA (generated from the paper's Tables 6–8)"


def theme() -> None:
    sns.set_theme(style="whitegrid", context="notebook", font_scale=0.9)


def mark_synthetic(fig) -> None:
    fig.text(0.995, 0.005, SYNTHETIC_LABEL, ha="right", va="bottom", fontsize=8, color="0.35", style="italic")


def palette(study) -> dict:
    """Backend -> colour, stable across figures (ranking backends first, then posterior ones)."""
    names = study.optimizers + [o for o in dict.fromkeys(study.runs["optimizer"]) if o not in study.optimizers]
    # The baseline is always dark grey so it reads as the reference; the others get tab10's ten
    # distinct colours (a larger registry falls back to evenly spaced hues).
    others = [name for name in names if name != "random"]
    colours = dict(zip(others, sns.color_palette("tab10" if len(others) <= 10 else "husl", max(len(others), 1))))
    if "random" in names:
        colours["random"] = (0.25, 0.25, 0.25)
    return {name: colours[name] for name in names}


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9.]+", "-", str(text)).strip("-").lower()


def save(fig, out_dir, stem: str, frame: pd.DataFrame, synthetic_data: bool, rect=(0, 0.03, 1, 0.97)) -> Path:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if synthetic_data:
        mark_synthetic(fig)
    fig.tight_layout(rect=rect)
    png = out_dir / f"{stem}.png"
    fig.savefig(png, dpi=DPI)
    plt.close(fig)
    frame.to_csv(png.with_suffix(".csv"), index=False, float_format="%.6g")
    return png


def finished(runs: pd.DataFrame) -> pd.DataFrame:
    return runs[(runs["status"] == "ok") & np.isfinite(runs["mse"].astype(float))]


# --------------------------------------------------------------------------------- convergence

def best_so_far(trace_nfev, trace_mse, grid) -> np.ndarray:
    """The step function of a best-so-far trace at evaluation counts ``grid``: +inf before the
    run's first finite loss (it has found nothing yet; leaving it out would let a median rise)."""
    idx = np.searchsorted(np.asarray(trace_nfev), grid, side="right") - 1
    values = np.asarray(trace_mse, dtype=float)[np.maximum(idx, 0)]
    return np.where(idx >= 0, values, np.inf)


def _evaluation_grid(max_nfev: float, points: int = 120) -> np.ndarray:
    return np.unique(np.round(np.geomspace(1, max(max_nfev, 2), points)).astype(int))


def convergence(study, out_dir, specimens=None, max_specimens: int = 4, floors=None) -> Path:
    """Best-so-far MSE against evaluations (the paper's Fig 16, every backend): median line and
    interquartile band across seeds. First panel (when there are several specimens): all
    specimens pooled, MSE relative to each specimen's best known; then one panel per specimen
    (absolute MSE, in ``study.loss_unit``). ``floors``: {specimen: (MSE, label)} drawn as a dashed
    line on that specimen's panel (e.g. the truth's MSE, the noise floor)."""
    theme()
    ranking = study.ranking
    best = statistics.best_known(study.runs)
    specimens = list(specimens or study.specimens)[:max_specimens]
    colours = palette(study)
    budget = float(np.nanmax(ranking["nfev"])) if len(ranking) else 1.0
    grid = _evaluation_grid(budget)
    traces = {k: g for k, g in study.traces[study.traces["kind"] == "ranking"].groupby(
        ["specimen", "optimizer", "replicate"])}
    panels = [("all specimens (pooled)", None)] if len(specimens) > 1 else []
    panels += [(s, s) for s in specimens]
    ncols = 2 if len(panels) in (2, 4) else min(3, len(panels))
    nrows = -(-len(panels) // ncols)
    # one panel: wide enough for the title and a legend of many backends
    fig, axes = plt.subplots(nrows, ncols, figsize=(max(6.0 * ncols, 12.0), 4.0 * nrows + 0.9), squeeze=False)
    rows = []
    for ax, (title, specimen) in zip(axes.flat, panels):
        counts = set()
        shown = []  # medians and lower quartiles: they set the y range, the bands do not
        for optimizer in study.optimizers:
            curves = []
            for (s, o, r), g in traces.items():
                if o != optimizer or (specimen is not None and s != specimen):
                    continue
                curve = best_so_far(g["nfev"].to_numpy(), g["mse"].to_numpy(), grid)
                curves.append(curve / best[s] if specimen is None else curve)
            if not curves:
                continue
            curves = np.array(curves)
            counts.add(len(curves))
            # Order statistics, not interpolation: a quartile between a finite value and +inf is
            # +inf (not drawn), where interpolating would give inf − inf = NaN.
            q25, median, q75 = np.percentile(curves, [25, 50, 75], axis=0, method="inverted_cdf")
            ax.plot(grid, median, color=colours[optimizer], lw=1.6, label=optimizer)
            shown += [median, q25]
            ax.fill_between(grid, q25, q75, color=colours[optimizer], alpha=0.18, lw=0)
            rows.append(pd.DataFrame({"panel": title, "optimizer": optimizer, "nfev": grid, "median": median,
                                      "q25": q25, "q75": q75, "runs": len(curves),
                                      "y": "mse_over_best_known" if specimen is None else "mse_N2"}))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("evaluations")
        if specimen is not None and specimen in (floors or {}):
            value, label = floors[specimen]
            ax.axhline(value, color="black", lw=1.0, ls="--", label=label)
            shown.append(np.array([value]))
        values = np.concatenate(shown) if shown else np.array([])
        values = values[np.isfinite(values) & (values > 0)]
        if values.size:
            # A run's first points can be astronomically bad (a near-runaway parameter set): let the
            # upper quartile band run off the top rather than squash every median line flat.
            ax.set_ylim(values.min() / 2, values.max() * 5)
        ax.set_ylabel("best-so-far MSE / best known (–)" if specimen is None else
                      f"best-so-far MSE ({study.loss_unit})")
        ax.set_title(title + (f" ({counts.pop()} runs per backend)" if len(counts) == 1 else ""), fontsize=10)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    handles, labels = {}, {}
    for ax in axes.flat[:len(panels)]:  # union over panels: a floor line is on one panel only
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    labels = list(handles)
    handles = list(handles.values())
    fig.legend(handles, labels, loc="upper center", ncol=min(len(labels), 6), bbox_to_anchor=(0.5, 0.96),
               frameon=False)
    fig.suptitle("Convergence: median (line) and interquartile range (band) across seeds of the best-so-far MSE",
                 fontsize=11)
    frame = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame()
    return save(fig, out_dir, "convergence", frame, study.problem_type.is_synthetic(study), rect=(0, 0.03, 1, 0.90))


# ------------------------------------------------------------------------------------ runtime ECDF

def ecdf(evals, grid) -> np.ndarray:
    """Fraction of ``evals`` (inf = never) that are ≤ each value of ``grid``."""
    evals = np.sort(np.asarray(evals, dtype=float))
    if evals.size == 0:
        return np.zeros(len(grid))
    return np.searchsorted(evals, grid, side="right") / evals.size


def runtime_ecdf(study, out_dir, taus=ECDF_TAUS) -> Path:
    """ECDF of evaluations to target (COCO/IOHprofiler style): for each backend, the fraction of
    (specimen, seed, target) triples reached within x evaluations; targets = best known MSE of
    the specimen × (1 + τ). A curve reaches 1 only if every run hit every target."""
    theme()
    best = statistics.best_known(study.runs)
    rt = statistics.runtimes(study.ranking, study.traces, taus, best)
    colours = palette(study)
    budget = float(np.nanmax(study.ranking["nfev"])) if len(study.ranking) else 1.0
    grid = _evaluation_grid(budget, 300)
    fig, ax = plt.subplots(figsize=(8.0, 5.0))
    n = len(study.optimizers)
    for i, optimizer in enumerate(study.optimizers):
        evals = rt.loc[rt["optimizer"] == optimizer, "evals"]
        y = ecdf(evals, grid)
        # earlier curves drawn wider, so a curve lying on another (e.g. two at 0) still shows
        ax.step(grid, y, where="post", color=colours[optimizer], lw=1.6 + 2.4 * (n - 1 - i) / max(n - 1, 1),
                label=f"{optimizer}: {y[-1]:.0%} of {len(evals)} reached")
    ax.set_xscale("log")
    ax.set_ylim(-0.02, 1.04)
    ax.set_xlim(1, grid[-1] * 1.05)
    ax.set_xlabel("evaluations")
    ax.set_ylabel("fraction of (specimen, seed, target) reached (–)")
    taus_text = ", ".join(f"{t:g}" for t in taus)
    ax.set_title(f"Runtime ECDF: targets = best known MSE × (1 + τ), τ ∈ {{{taus_text}}}", fontsize=11)
    ax.legend(loc="upper left", fontsize=9)
    frame = rt.drop(columns=["kind"])
    return save(fig, out_dir, "ecdf", frame, study.problem_type.is_synthetic(study))


# ---------------------------------------------------------------------------------- waterfall

def waterfall(study, out_dir) -> Path:
    """Final MSE of every ranking run, relative to its specimen's best known, sorted per backend:
    flat stretches are plateaus where many runs end at the same (local) optimum."""
    theme()
    ranking = study.ranking
    best = statistics.best_known(study.runs)
    final = statistics.final_mse(ranking)
    frame = ranking[["optimizer", "specimen", "replicate", "status"]].assign(
        final_mse=final.to_numpy(), best_known=ranking["specimen"].map(best).to_numpy())
    frame["ratio"] = frame["final_mse"] / frame["best_known"]
    frame = frame.sort_values(["optimizer", "ratio"], kind="stable")
    frame["rank"] = frame.groupby("optimizer").cumcount() + 1
    colours = palette(study)
    fig, ax = plt.subplots(figsize=(10.5, 5.0))
    for optimizer in study.optimizers:
        g = frame[frame["optimizer"] == optimizer]
        shown = g[np.isfinite(g["ratio"])]
        failed = len(g) - len(shown)
        label = f"{optimizer} ({len(g)} runs{f', {failed} failed, not shown' if failed else ''})"
        ax.plot(shown["rank"], shown["ratio"], "-o", ms=4, lw=0.8, color=colours[optimizer], label=label)
    ax.set_yscale("log")
    ax.set_xlabel("run, sorted by final MSE (within each backend)")
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_ylabel("final MSE / best known for its specimen (–)")
    ax.axhline(1.0 + statistics.TOLERANCES[-1], color="0.3", lw=0.8, ls="--",
               label=f"{1.0 + statistics.TOLERANCES[-1]:g} × best known (success at 10 %)")
    ax.set_title("Waterfall: final MSE of every ranking run", fontsize=11)
    ax.legend(fontsize=8, loc="center left", bbox_to_anchor=(1.0, 0.5))  # outside: never over the data
    return save(fig, out_dir, "waterfall", frame, study.problem_type.is_synthetic(study))
