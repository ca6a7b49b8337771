"""Study figures every problem gets: convergence, and the helpers the others share (the waterfall is
``bwbench.render.waterfall``, the runtime distributions ``bwbench.render.ecdf_figures``).

Every function takes a loaded ``bwbench.database.reader.Study`` and an output folder and returns the
PNG's path, with the tidy CSV behind it beside it (same name, ``.csv``). ``order``: the report's
ranking (best first); it sets the legend order and each backend's style, the same in every figure
(default: lowest median final loss first; see ``bwbench.render.palette``). Figures of synthetic
data carry the SYNTHETIC mark.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib.ticker
import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.analysis import statistics
from bwbench.render.palette import (
    MAX_WIDTH_IN,
    backend_handles,
    figure,
    legend,
    save,
    split_label,
    styles,
    theme,
)

BANDS = 3  # interquartile bands for the best few labels of a panel only: more bands hide each other


def finished(runs: pd.DataFrame) -> pd.DataFrame:
    return runs[(runs["status"] == "ok") & np.isfinite(runs["mse"].astype(float))]


def specimen_order(study, specimens=None) -> list[str]:
    """``specimens`` (default all) in natural order: by underpressure, then repeat, when the
    runs carry them, else by name."""
    specimens = list(dict.fromkeys(specimens or study.specimens))
    runs = study.runs
    first = runs.drop_duplicates("specimen").set_index("specimen")

    def key(name):
        row = first.loc[name] if name in first.index else {}
        pressure = pd.to_numeric(row.get("underpressure_MPa", np.nan), errors="coerce") if len(row) else np.nan
        repeat = pd.to_numeric(row.get("repeat", np.nan), errors="coerce") if len(row) else np.nan
        return (np.inf if pd.isna(pressure) else float(pressure), np.inf if pd.isna(repeat) else float(repeat), name)

    return sorted(specimens, key=key)


def specimen_title(study, specimen: str) -> str:
    """``"0.05 MPa, repeat 1"`` when the runs give underpressure and repeat (``"POM C9021, 0.05 MPa,
    repeat 1"`` when the study has several materials), else the specimen's name."""
    row = study.runs[study.runs["specimen"] == specimen].head(1)
    if (
        len(row)
        and "underpressure_MPa" in row
        and np.isfinite(pd.to_numeric(row["underpressure_MPa"].iloc[0], errors="coerce"))
    ):
        text = f"{float(row['underpressure_MPa'].iloc[0]):g} MPa"
        if "material" in row and study.runs["material"].nunique() > 1:
            text = f"{row['material'].iloc[0]}, {text}"
        repeat = pd.to_numeric(row["repeat"].iloc[0], errors="coerce") if "repeat" in row else np.nan
        return text + (f", repeat {int(repeat)}" if np.isfinite(repeat) else "")
    return specimen


# --------------------------------------------------------------------------------- convergence


def best_so_far(trace_nfev, trace_mse, grid) -> np.ndarray:
    """The step function of a best-so-far trace at evaluation counts ``grid``: +inf before the
    run's first finite loss (it has found nothing yet; leaving it out would let a median rise)."""
    idx = np.searchsorted(np.asarray(trace_nfev), grid, side="right") - 1
    values = np.asarray(trace_mse, dtype=float)[np.maximum(idx, 0)]
    return np.where(idx >= 0, values, np.inf)


def quartiles(curves) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower quartile, median and upper quartile across runs (rows) of best-so-far curves.

    Order statistics, not interpolation: a quartile between a finite value and +inf is +inf (not
    drawn), where interpolating would give inf − inf = NaN; and an order statistic of curves that
    never rise never rises either."""
    q25, median, q75 = np.percentile(np.asarray(curves, dtype=float), [25, 50, 75], axis=0, method="inverted_cdf")
    return q25, median, q75


def plain_log_axis(axis, span: float) -> None:
    """Tick labels of a log axis as plain numbers (2, 3, 10, 100), the minor ones only when the axis
    spans less than a decade (else they crowd)."""
    plain = matplotlib.ticker.FuncFormatter(lambda v, _: f"{v:g}")
    axis.set_major_formatter(plain)
    axis.set_minor_formatter(plain if span < 10 else matplotlib.ticker.NullFormatter())


def _evaluation_grid(max_nfev: float, points: int = 400) -> np.ndarray:
    return np.unique(np.round(np.linspace(1, max(max_nfev, 2), points)).astype(int))


def _convergence_panel(ax, curves: dict, look: dict, names: list, grid, budget: float, bands: int) -> dict:
    """One panel of ``convergence``: each label's median best-so-far curve (``curves``: label -> list of
    curves relative to the panel's reference), the interquartile band of the ``bands`` best coloured
    labels, the grey ones named in a box; the log y axis fitted to the coloured medians after the first
    tenth of the budget. Returns what the figure's legend and CSV need."""
    from bwbench.render.ecdf_figures import GREY, highlighted

    coloured, baselines, grey = highlighted(names)
    shown, counts, drawn, banded, rows = [], set(), [], set(), []
    for rank, optimizer in enumerate(coloured + baselines + grey):
        if not curves.get(optimizer):
            continue
        q25, median, q75 = quartiles(curves[optimizer])
        counts.add(len(curves[optimizer]))
        style = look[optimizer]
        if optimizer in grey:
            ax.plot(grid, median, color=GREY, lw=1.0, zorder=2)
        else:
            ax.plot(
                grid,
                median,
                **style.line(markers=True, ms=5, markevery=(8 + 11 * rank % 37, 60)),
                zorder=3 + len(names) - rank,
            )
            shown.append(median[grid >= budget / 10])
            drawn.append(optimizer)
        if optimizer in coloured[:bands]:
            ax.fill_between(grid, q25, q75, color=style.colour, alpha=0.13, lw=0, zorder=1)
            shown.append(q25[grid >= budget / 10])
            banded.add(optimizer)
        rows.append(
            pd.DataFrame(
                {
                    "optimizer": optimizer,
                    "nfev": grid,
                    "median": median,
                    "q25": q25,
                    "q75": q75,
                    "runs": len(curves[optimizer]),
                    "highlighted": optimizer not in grey,
                    "band": optimizer in coloured[:bands],
                }
            )
        )
    values = np.concatenate(shown + [np.array([1.0])])
    values = values[np.isfinite(values) & (values > 0)]
    ax.set_yscale("log")
    low, high = min(values.min(), 1.0) / 1.25, values.max() * 1.6
    ax.set_ylim(low, high)  # earlier, worse points run off the top
    plain_log_axis(ax.yaxis, high / low)
    ax.set_xlim(0, budget * 1.01)
    if grey:
        ax.text(
            0.99,
            0.97,
            "grey: " + ", ".join(split_label(n)[0] for n in grey),
            transform=ax.transAxes,
            va="top",
            ha="right",
            fontsize=9,
            color="0.25",
            bbox={"fc": "white", "ec": "0.8", "boxstyle": "round"},
            zorder=20,
        )
    return {"rows": rows, "drawn": drawn, "banded": banded, "grey": grey, "counts": counts}


def convergence(
    study, out_dir, specimens=None, max_specimens: int = 4, floors=None, order=None, bands: int = BANDS
) -> Path:
    """Best-so-far loss against evaluations (every label): the median across seeds as a line, the
    interquartile range as a band for the ``bands`` best labels only. First panel (when there are
    several specimens): all specimens pooled; then one panel per specimen of ``specimens`` (at most
    ``max_specimens``, in natural order). When the labels carry variants (formulations), one column
    per variant (and at most two specimens besides the pooled panel). A panel with many labels
    shows its best ``ecdf_figures.HIGHLIGHT`` in colour, random search in dark grey and the rest in
    light grey (``ecdf_figures.highlighted``). ``floors``: {specimen: (loss, name)}, e.g. the truth's
    MSE named "noise floor" where it is one: that specimen's loss is shown relative to it (the line
    at 1); without one, relative to the best known. Linear evaluation axis: the last stretch of the
    budget, where the ranking is decided, gets most of the width."""
    from bwbench.render.ecdf_figures import GREY, by_variant

    theme()
    floors = floors or {}
    best = statistics.best_known(study.runs)
    ranking = study.ranking
    look = styles(study, order)
    groups = by_variant([o for o in look if o in set(ranking["optimizer"])])
    columns = len(groups) if len(groups) > 1 else 1
    specimens = specimen_order(study, list(specimens or study.specimens)[: max_specimens if columns == 1 else 2])
    budget = float(np.nanmax(ranking["nfev"])) if len(ranking) else 1.0
    grid = _evaluation_grid(budget)
    traces = {
        k: g for k, g in study.traces[study.traces["kind"] == "ranking"].groupby(["specimen", "optimizer", "replicate"])
    }
    # The pooled panel divides by each specimen's floor only if every specimen has one: a mix of
    # floors and best knowns would put different things at 1.
    pooled_floor = all(s in floors for s in study.specimens)
    reference = {
        (s, pooled): floors[s][0] if s in floors and (pooled_floor or not pooled) else best[s]
        for s in study.specimens
        for pooled in (True, False)
    }
    panels = [("all specimens (pooled)", None)] if len(specimens) > 1 else []
    panels += [(specimen_title(study, s), s) for s in specimens]
    cells = [(p, v) for p in panels for v in groups] if columns > 1 else [(p, None) for p in panels]
    ncols = columns if columns > 1 else (1 if len(panels) == 1 else 2)
    nrows = -(-len(cells) // ncols)
    fig, axes = figure(MAX_WIDTH_IN, 3.3 * nrows + 1.4, nrows=nrows, ncols=ncols, squeeze=False, sharex=True)
    rows, drawn, banded, greyed = [], [], set(), False
    for ax, ((title, specimen), variant) in zip(axes.flat, cells):
        names = groups[variant] if columns > 1 else [o for g in groups.values() for o in g]
        on_floor = pooled_floor if specimen is None else specimen in floors
        curves = {
            optimizer: [
                best_so_far(g["nfev"].to_numpy(), g["mse"].to_numpy(), grid) / reference[s, specimen is None]
                for (s, o, _), g in traces.items()
                if o == optimizer and specimen in (None, s)
            ]
            for optimizer in names
        }
        panel = _convergence_panel(ax, curves, look, [o for o in look if o in set(names)], grid, budget, bands)
        greyed |= bool(panel["grey"])
        drawn += panel["drawn"]
        banded |= panel["banded"]
        rows += [
            frame.assign(panel=title, variant=variant, y="mse_over_floor" if on_floor else "mse_over_best_known")
            for frame in panel["rows"]
        ]
        floor_name = (
            floors[specimen][1]
            if specimen is not None and on_floor
            else (next(iter(floors.values()))[1] if on_floor else "best known")
        )
        ax.axhline(1.0, color="black", lw=1.1, ls=(0, (5, 3)) if on_floor else ":", zorder=2)
        ax.set_ylabel(f"MSE / {floor_name} (–)")
        floor_text = (
            f"; {floor_name} {floors[specimen][0]:.3g} {study.loss_unit}" if specimen is not None and on_floor else ""
        )
        counts = panel["counts"]
        count_text = f" ({counts.pop()} runs per label)" if len(counts) == 1 else ""
        where = f"{variant}: " if variant is not None else ""
        # wrapped to the panel's width: side-by-side panels' titles would otherwise run into each other
        ax.set_title(
            textwrap.fill(where + title + floor_text + count_text, width=int((MAX_WIDTH_IN / ncols - 0.8) * 12.5)),
            loc="left",
            fontsize=10,
        )
    for k, ax in enumerate(axes.flat[: len(cells)]):
        if k + ncols >= len(cells):  # the lowest panel of its column carries the axis
            ax.xaxis.set_tick_params(labelbottom=True)
            ax.set_xlabel("evaluations")
    for ax in axes.flat[len(cells) :]:
        ax.set_visible(False)
    columns_csv = ["panel", "variant", "optimizer", "nfev", "median", "q25", "q75", "runs", "highlighted", "band", "y"]
    frame = pd.concat(rows, ignore_index=True)[columns_csv] if rows else pd.DataFrame()
    handles = backend_handles(look, drawn)
    if banded:
        per_panel = max(len([o for o in g if o in banded]) for g in groups.values())
        handles.append(
            Patch(
                color="0.6",
                alpha=0.5,
                label=f"interquartile range over seeds (best {per_panel}" + (" per column)" if columns > 1 else ")"),
            )
        )
    if greyed:
        handles.append(Line2D([], [], color=GREY, lw=1.0, label="other labels (named in the panel)"))
    kinds = {pooled_floor if s is None else s in floors for (_, s), _ in cells}
    if True in kinds:
        handles.append(
            Line2D([], [], color="black", lw=1.1, ls=(0, (5, 3)), label=f"{next(iter(floors.values()))[1]} = 1")
        )
    if False in kinds:
        handles.append(Line2D([], [], color="black", lw=1.1, ls=":", label="best known = 1"))
    legend(fig, handles, ncol=4)
    fig.suptitle("Convergence: median over seeds of the best-so-far MSE (labels in the report's order)")
    return save(fig, out_dir, "convergence", frame, study.problem_type.is_synthetic(study))
