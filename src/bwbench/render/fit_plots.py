"""The figure of ``FitResult.plot()`` and ``Prediction.plot()``: per record, the loops F–x and F–v, and
the force and its residual against time, measured against model.

Drawn on a ``matplotlib.figure.Figure`` made directly (not through pyplot) inside a style context:
the global backend, the rcParams and pyplot's list of figures are what they were. In IPython the
figure still shows inline when it is a cell's value: a PNG formatter is registered for ``Figure``
where none is (what matplotlib's inline backend does itself once pyplot is imported).
"""

from __future__ import annotations

from typing import Any

import numpy as np

STYLE: Any = {
    "font.size": 9,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "legend.frameon": False,
}  # Any: matplotlib types the keys as literals
MEASURED = {"color": "0.35", "lw": 0.9, "label": "measured"}
MODEL = {"color": "tab:red", "lw": 1.1, "label": "model"}
PANELS = 4
WARMUP: Any = {"color": "0.6", "alpha": 0.25, "lw": 0, "zorder": 0}  # Any: as STYLE


def warmup_label(seconds: float) -> str:
    return f"warm-up, {seconds:g} s: simulated, not in the loss"


def shade_warmup(axes, t, warmup: int) -> None:
    """Shade the warm-up (the first ``warmup`` samples: simulated but left out of the loss) on Axes whose
    x axis is the time ``t`` (s); nothing when there is none."""
    if not warmup:
        return
    for ax in axes:
        ax.axvspan(t[0], t[warmup], **WARMUP)


def velocity_of(prediction) -> np.ndarray:
    """The velocity (mm/s) that drove the model, or a central difference of the displacement."""
    v = getattr(prediction, "velocity_mm_s", None)
    return np.asarray(v, float) if v is not None else np.gradient(prediction.displacement_mm, prediction.time_s)


# A record with more reversals than this (a few dozen cycles) has its force against time drawn in a
# zoom window of about ZOOM_REVERSALS reversals in its middle: the whole record is a solid band.
LONG_RECORD_REVERSALS = 60
ZOOM_REVERSALS = 12


def zoom(prediction) -> slice:
    """The samples of the force-against-time panel: all of them, or a long record's middle window."""
    n = len(prediction.measured_N)
    turns = getattr(prediction, "reversals", 0)
    if turns <= LONG_RECORD_REVERSALS:
        return slice(0, n)
    width = max(int(n * ZOOM_REVERSALS / turns), 10)
    start = max(n // 2 - width // 2, 0)
    return slice(start, min(start + width, n))


def draw(prediction, axes) -> None:
    """The four panels of one record onto ``axes`` (a sequence of 1 to 4 Axes, in the order F–x, F–v,
    F(t), residual(t)); one Axes gets the F–x loops only. A quasi-static record (no time) has the
    residual against displacement instead of F–v and its points along the path for time; a long record
    its force against time in a zoom window (``zoom``)."""
    p = prediction
    x, v, t = p.displacement_mm, velocity_of(p), p.time_s
    model = np.where(np.isfinite(p.force_N), p.force_N, np.nan)
    rmse = f"RMSE {p.rmse_N:.3g} N, NRMSE {p.nrmse:.3g}"
    quasi = getattr(p, "quasi_static", False)
    time = "point along the path (no time)" if quasi else "time (s)"
    w = zoom(p)
    zoomed = w != slice(0, len(t))
    plane = (
        (
            lambda ax: (
                ax.plot(x, model - p.measured_N, color="tab:blue", lw=0.8),
                ax.axhline(0.0, color="0.5", lw=0.6),
            ),
            "displacement (mm)",
            "residual (N)",
            "residual against displacement",
        )
        if quasi
        else (
            lambda ax: (ax.plot(v, p.measured_N, **MEASURED), ax.plot(v, model, **MODEL)),
            "velocity (mm/s)",
            "force (N)",
            "force–velocity",
        )
    )
    panels = [
        (
            lambda ax: (ax.plot(x, p.measured_N, **MEASURED), ax.plot(x, model, **MODEL)),
            "displacement (mm)",
            "force (N)",
            f"{p.specimen}: {rmse}",
        ),
        plane,
        (
            lambda ax: (ax.plot(t[w], p.measured_N[w], **MEASURED), ax.plot(t[w], model[w], **MODEL)),
            time,
            "force (N)",
            f"force against time (zoom: {t[w.start]:.4g} … {t[w.stop - 1]:.4g})" if zoomed else "force against time",
        ),
        (
            lambda ax: (
                ax.plot(t, model - p.measured_N, color="tab:blue", lw=0.8, label="model − measured"),
                ax.axhline(0.0, color="0.5", lw=0.6),
            ),
            time,
            "residual (N)",
            "residual",
        ),
    ]
    for ax, (plot, xlabel, ylabel, title) in zip(axes, panels):
        plot(ax)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title, fontsize="medium", parse_math=False)  # a specimen's name, as written
    axes[0].legend(loc="best", fontsize="small")
    shade_warmup(axes[2:], t, getattr(p, "warmup", 0))
    if getattr(p, "warmup", 0) and len(axes) > 2:
        axes[2].set_title(f"force against time (shaded: {warmup_label(p.warmup_s)})", fontsize="small")


def figure(predictions, title: str | None = None, ax=None):
    """A Figure of ``predictions`` (one row of four panels each), or drawn into ``ax`` (one Axes: the
    first record's F–x loops; a sequence: its four panels) and that Axes' figure returned."""
    import matplotlib
    from matplotlib.figure import Figure

    predictions = list(predictions)
    with matplotlib.rc_context(STYLE):
        if ax is not None:
            axes = list(np.ravel(ax)) if isinstance(ax, (list, tuple, np.ndarray)) else [ax]
            draw(predictions[0], axes[:PANELS])
            return axes[0].figure
        fig = Figure(figsize=(12, 2.9 * len(predictions) + 0.4), layout="constrained")
        grid = fig.subplots(len(predictions), PANELS, squeeze=False)
        for row, prediction in zip(grid, predictions):
            draw(prediction, row)
        if title:
            fig.suptitle(title, fontsize="medium", parse_math=False)  # names from the data, as written
    show_inline()
    return fig


def show_inline() -> None:
    """In IPython, let a bare ``Figure`` display as PNG (once, only where nothing else does it)."""
    import sys

    if "IPython" not in sys.modules:
        return
    from IPython import get_ipython

    shell = get_ipython()
    if shell is None:
        return
    from matplotlib.figure import Figure

    formatter = shell.display_formatter.formatters["image/png"]
    try:
        formatter.lookup_by_type(Figure)
    except KeyError:
        from IPython.core.pylabtools import print_figure

        formatter.for_type(Figure, lambda fig: print_figure(fig, "png", bbox_inches="tight"))
