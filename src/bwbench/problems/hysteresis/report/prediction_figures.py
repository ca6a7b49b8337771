"""Predicted against measured force, one row per test: ``bwbench predict --plot``, ``bwbench fit
--plot`` of a joint fit, and the report's held-out tests.

Each row: the hysteresis loop (measured points, the model's line on top) and the residual (model −
measured, N) against time with its RMSE and NRMSE, where a misfit of a few newtons that a 1,000 N
loop hides is visible.
"""

from __future__ import annotations

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.render.fit_plots import WARMUP, shade_warmup, warmup_label
from bwbench.render.palette import MAX_WIDTH_IN, OKABE_ITO, figure, legend, theme, write_png
from bwbench.render.palette import title as palette_title

MEASURED: dict = {"color": "black", "marker": ".", "ls": "", "ms": 2.0, "alpha": 0.7, "zorder": 3, "rasterized": True}
MAX_ROWS = 8  # more tests than this: the first MAX_ROWS are drawn, the title says how many


def draw_predictions(predictions, title: str, what: str = "predicted"):
    """The figure (matplotlib) of ``predictions`` (``fitted_model.Prediction``), one row each."""
    theme()
    shown = list(predictions)[:MAX_ROWS]
    fig, axes = figure(
        MAX_WIDTH_IN,
        1.2 + 2.5 * len(shown),
        nrows=len(shown),
        ncols=2,
        squeeze=False,
        gridspec_kw={"width_ratios": [1, 1.6]},
    )
    colour = OKABE_ITO[0] if what == "fitted" else OKABE_ITO[3]
    for (loop, resid), p in zip(axes, shown):
        finite = np.all(np.isfinite(p.force_N))
        loop.plot(p.displacement_mm, p.measured_N, **MEASURED)
        if finite:
            loop.plot(p.displacement_mm, p.force_N, color=colour, lw=1.6, zorder=4)
            resid.plot(p.time_s, p.force_N - p.measured_N, color=colour, lw=0.8)
        else:
            resid.text(0.5, 0.5, "the model blows up on this record", transform=resid.transAxes, ha="center")
        resid.axhline(0.0, color="black", lw=0.7)
        shade_warmup([resid], p.time_s, p.warmup)
        loop.set_title(p.specimen, loc="left")
        loop.set_xlabel("displacement x (mm)")
        loop.set_ylabel("force F (N)")
        resid.set_title(f"{what} − measured: RMSE {p.rmse_N:.3g} N, NRMSE {p.nrmse:.3g} (RMSE / max|F|)", loc="left")
        resid.set_xlabel("point (no time: quasi-static)" if getattr(p, "quasi_static", False) else "time t (s)")
        resid.set_ylabel("residual (N)")
    predictions = list(predictions)
    more = len(predictions) - len(shown)
    which = (
        f"\nshown: the first {len(shown)} of {len(predictions)} tests, one per row ({shown[0].specimen} … "
        f"{shown[-1].specimen}); every test's RMSE is in the result"
        if more > 0
        else ""
    )
    palette_title(fig, title + which)
    handles: list = [
        Line2D([], [], label="measured", **{k: v for k, v in MEASURED.items() if k != "rasterized"}),
        Line2D([], [], color=colour, lw=1.6, label=f"{what} by the model"),
    ]
    warm = max(shown, key=lambda p: p.warmup)
    if warm.warmup:
        handles.append(Patch(**WARMUP, label=warmup_label(warm.warmup_s)))
    legend(fig, handles, ncol=len(handles))
    return fig


def plot_predictions(predictions, path, title: str, what: str = "predicted", synthetic: bool = False) -> None:
    """``draw_predictions`` written as a PNG at ``path``."""
    write_png(draw_predictions(predictions, title, what), path, synthetic)
