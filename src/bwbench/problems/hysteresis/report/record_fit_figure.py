"""The figure of one fit (``bwbench fit --plot``) for any record: ``fit_figures.plot_fit``'s, or for a
record longer than a few dozen cycles (``LONG_RECORD_REVERSALS``: a broadband or earthquake record, a
long test), where a loop drawn with arrows and reversal marks is unreadable, ``plot_long_fit``: the
loops of the whole record and the force–velocity plane on the left; the force of the whole record
with a zoom window shaded, that window with its reversals, and the residual of the whole record on
the right.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.problems.hysteresis.report.fit_figures import (
    BAND_COLOUR,
    MEASURED,
    fit_title,
    mark_reversals,
    nrmse_short,
    residual_limit,
    reversals,
    time_label,
)
from bwbench.problems.hysteresis.report.fit_figures import plot_fit as plot_short_fit
from bwbench.render.palette import MAX_WIDTH_IN, OKABE_ITO, Style, canvas, legend, theme, title, write_png

LONG_RECORD_REVERSALS = 60
ZOOM_REVERSALS = 12  # the zoom window spans about this many reversals (6 cycles)


def plot_fit(problem, result, path, synthetic: bool = False) -> None:
    """The fit figure of ``problem``'s record at ``path``: the long-record one past ``LONG_RECORD_REVERSALS``."""
    turns = reversals(problem.specimen.x)
    if len(turns) <= LONG_RECORD_REVERSALS:
        plot_short_fit(problem, result, path, synthetic)
        return
    theme()
    params = np.array([result.params[name] for name in problem.param_names])
    plot_long_fit(problem, result, problem.simulate(params), turns, path, synthetic)


def zoom_window(t, f, turns) -> slice:
    """About ``ZOOM_REVERSALS`` reversals in the middle of a long record (away from a start-up transient):
    the samples a reader can see the loops and the fit in."""
    n = len(t)
    width = max(int(n * min(1.0, ZOOM_REVERSALS / max(len(turns), 1))), 10)
    centre = n // 2
    start = int(np.clip(centre - width // 2, 0, max(n - width, 0)))
    return slice(start, min(start + width, n))


def plot_long_fit(problem, result, fitted, turns, path, synthetic: bool = False) -> None:
    """A long record's fit (more than ``LONG_RECORD_REVERSALS`` reversals): the loops of the whole record
    and the force–velocity plane on the left; the force of the whole record with a zoom window shaded,
    that window with its reversals, and the residual of the whole record on the right."""
    spec = problem.specimen
    t, x, f = spec.t, spec.x, spec.f
    quasi = getattr(problem.signal, "rate_independent", False)
    style = Style(result.optimizer, OKABE_ITO[0], "-", "o", True)
    fig = canvas(MAX_WIDTH_IN, 8.8)
    grid = fig.add_gridspec(3, 2, width_ratios=[1, 1.5])
    loop, plane = fig.add_subplot(grid[0:2, 0]), fig.add_subplot(grid[2, 0])
    whole, zoom, residual = (fig.add_subplot(grid[r, 1]) for r in range(3))
    residual.sharex(whole)
    thin = {**MEASURED, "ms": 1.2, "alpha": 0.35}
    loop.plot(x, f, **thin)
    loop.plot(problem.signal.x, fitted, **style.line(lw=0.7, ls="-"), alpha=0.8, zorder=4)
    loop.set(xlabel="displacement x (mm)", ylabel="force F (N)")
    loop.set_title(f"loops of the whole record ({len(turns)} reversals)", loc="left")
    error = fitted - f
    if quasi:
        plane.plot(x, error, **{**thin, "color": style.colour})
        plane.set(xlabel="displacement x (mm)", ylabel="model − measured (N)")
        plane.set_title("residual against displacement (quasi-static: no velocity)", loc="left")
    else:
        v = problem.signal.v
        plane.plot(v, f, **thin)
        plane.plot(v, fitted, ls="", marker=".", ms=1.0, color=style.colour, alpha=0.5, zorder=4, rasterized=True)
        plane.set(xlabel="velocity ẋ (mm/s)", ylabel="force F (N)")
        plane.set_title("force–velocity plane", loc="left")
    window = zoom_window(t, f, turns)
    whole.plot(t, f, color="black", lw=0.4, alpha=0.7, rasterized=True)
    whole.plot(t, fitted, **style.line(lw=0.5, ls="-"), alpha=0.8, rasterized=True)
    whole.set_ylabel("force F (N)")
    whole.set_title("force, whole record (shaded: the zoom below)", loc="left")
    whole.tick_params(labelbottom=False)
    zoom.plot(t[window], fitted[window], **style.line(lw=1.6, ls="-"), zorder=3)
    zoom.plot(t[window], f[window], **MEASURED)
    in_window = [i for i in turns if window.start <= i < window.stop]
    mark_reversals([zoom], t, in_window)
    zoom.set(xlabel=time_label(problem), ylabel="force F (N)")
    unit = "" if quasi else " s"
    zoom.set_title(
        f"zoom: {t[window.start]:.4g} … {t[window.stop - 1]:.4g}{unit} ({len(in_window)} reversals)", loc="left"
    )
    rmse = float(np.sqrt(np.mean(error**2)))
    residual.plot(t, error, **style.line(lw=0.5, ls="-"), rasterized=True)
    residual.axhline(0.0, color="black", lw=0.8)
    limit = residual_limit({"fit": error})
    residual.set_ylim(-limit, limit)
    residual.set(xlabel=time_label(problem), ylabel="model − measured (N)")
    residual.set_title(f"residual, whole record: RMSE {rmse:.3g} N, {nrmse_short(rmse, f)}", loc="left")
    for ax in (whole, residual):
        ax.axvspan(t[window.start], t[window.stop - 1], color=BAND_COLOUR, alpha=0.25, lw=0, zorder=0)
    handles = [
        Line2D([], [], label="measured", **{k: v for k, v in MEASURED.items() if k != "rasterized"}),
        style.handle(f"fitted model ({result.optimizer})", marker=False),
        Line2D([], [], ls=":", color="0.45", label="reversal of travel (zoom)"),
        Patch(color=BAND_COLOUR, alpha=0.25, label="zoom window"),
    ]
    legend(fig, handles, ncol=4)
    title(fig, fit_title(problem, result))
    write_png(fig, path, synthetic)
