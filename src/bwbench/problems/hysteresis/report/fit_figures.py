"""Fits of the switched model against the measured force: one fit (``bwbench fit --plot``) and the
best fits of a study on one specimen.

Both have the same three panels: the hysteresis loop (measured points on top of the model line,
arrows in the direction of travel, reversals marked), the force against time, and the residual
(model − measured, N) against time on the same time axis, where misfits of a few newtons that a
1,000 N loop hides are visible.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from bwbench.problems.hysteresis.report.figure_common import (
    conditions,
    problem_for,
    reversals,
    synthetic,
    travel_arrows,
    truth,
)
from bwbench.render.fit_plots import WARMUP, shade_warmup, warmup_label
from bwbench.render.palette import (
    MAX_WIDTH_IN,
    OKABE_ITO,
    Style,
    backend_handles,
    figure,
    legend,
    save,
    slug,
    split_label,
    styles,
    theme,
    title,
    write_png,
)

BAND_COLOUR = OKABE_ITO[5]
BACKENDS = 3  # residuals of the best few backends (and random search): more lines hide each other
MEASURED: dict[str, Any] = {
    "color": "black",
    "marker": ".",
    "ls": "",
    "ms": 2.2,
    "alpha": 0.75,
    "zorder": 5,
    "rasterized": True,
}


def _panels(height: float = 6.6):
    """The figure: the loop on the left, force and residual against time (shared axis) on the right."""
    fig, axes = figure(MAX_WIDTH_IN, height, nrows=2, ncols=2, gridspec_kw={"width_ratios": [1, 1.35]})
    gs = axes[0, 0].get_gridspec()
    for ax in axes[:, 0]:
        ax.remove()
    loop = fig.add_subplot(gs[:, 0])
    force, residual = axes[0, 1], axes[1, 1]
    residual.sharex(force)
    force.tick_params(labelbottom=False)
    return fig, loop, force, residual


RAMP_ALPHA = 0.22  # ramp-in/out cycles drawn this light on the loop: the steady loop stays readable


def _draw_measured(loop, force, t, x, f, fitted, style: Style, turns, x_model=None, steady=None) -> None:
    """Measured points (at displacement ``x``) on top of the model line (at ``x_model``, default
    ``x``), travel arrows and reversals on the loop; the same against time. ``steady``: a slice of the
    steady part (``bwbench.data.steady_part``): the ramp cycles outside it are drawn lighter on the loop."""
    x_model = np.asarray(x if x_model is None else x_model)
    x, f, fitted = np.asarray(x), np.asarray(f), np.asarray(fitted)
    keep = np.zeros(len(x), dtype=bool)
    keep[steady if steady is not None else slice(None)] = True
    for part in (
        (slice(None, keep.argmax() + 1), slice(len(keep) - keep[::-1].argmax() - 1, None)) if not keep.all() else ()
    ):
        loop.plot(x_model[part], fitted[part], **{**style.line(lw=1.0, ls="-"), "alpha": RAMP_ALPHA}, zorder=2)
        loop.plot(x[part], f[part], **{**MEASURED, "alpha": RAMP_ALPHA, "zorder": 2})
    steady_turns = [i for i in turns if keep[i]]
    loop.plot(np.where(keep, x_model, np.nan), np.where(keep, fitted, np.nan), **style.line(lw=2.2, ls="-"), zorder=3)
    loop.plot(x[keep], f[keep], **MEASURED)
    travel_arrows(loop, x_model[keep], fitted[keep], [i - int(keep.argmax()) for i in steady_turns], "black")
    turns = steady_turns
    loop.plot(
        np.asarray(x)[turns], np.asarray(f)[turns], ls="", marker="D", ms=7, mfc="white", mec="black", mew=1.3, zorder=6
    )
    loop.set_xlabel("displacement x (mm)")
    loop.set_ylabel("force F (N)")
    loop.set_title("hysteresis loop (arrows: direction of travel)", loc="left")
    force.plot(t, fitted, **style.line(lw=2.0, ls="-"), zorder=3)
    force.plot(t, f, **MEASURED)
    force.set_ylabel("force F (N)")
    force.set_title("force against time", loc="left")


def mark_reversals(axes, t, turns) -> None:
    for ax in axes:
        for i in turns:
            ax.axvline(t[i], color="0.45", lw=0.8, ls=":", zorder=1)


REVERSAL = Line2D(
    [],
    [],
    ls=":",
    color="0.45",
    marker="D",
    ms=7,
    mfc="white",
    mec="black",
    mew=1.3,
    label="reversal of travel (◇ on the loop, dotted against time)",
)


def residual_limit(residuals: dict, skip=()) -> float:
    """Symmetric y range of the residual panel: the lines of ``residuals`` not in ``skip`` fit; a
    far worse one (random search) runs off the edge instead of flattening the others."""
    kept = [np.abs(r[np.isfinite(r)]) for name, r in residuals.items() if name not in skip]
    kept = [r for r in kept if r.size] or [np.abs(r[np.isfinite(r)]) for r in residuals.values()]
    return 1.15 * max(float(np.percentile(r, 99.8)) for r in kept) if kept else 1.0


def plot_fit(problem, result, path, synthetic: bool = False) -> None:
    """One fit: the loop with its direction of travel, force against time, and the residual against
    time with its RMSE; PNG at ``path``. The title names the formulation when the problem has one (a
    long record: ``record_fit_figure``)."""
    theme()
    from bwbench.data.steady_part import steady_part

    spec = problem.specimen
    params = np.array([result.params[name] for name in problem.param_names])
    fitted = problem.simulate(params)
    turns = reversals(spec.x)
    style = Style(result.optimizer, OKABE_ITO[0], "-", "o", True)
    fig, loop, force, residual = _panels()
    steady = steady_part(spec.t, spec.x)
    _draw_measured(
        loop,
        force,
        spec.t,
        spec.x,
        spec.f,
        fitted,
        style,
        turns,
        x_model=problem.signal.x,
        steady=steady.part if steady.ramped else None,
    )
    error = fitted - spec.f
    scored = problem.start.loss  # a warm-up is simulated and drawn, but not in the loss: shaded
    rmse = float(np.sqrt(np.mean(error[scored] ** 2)))
    residual.plot(spec.t, error, **style.line(lw=0.9, ls="-"))
    shade_warmup([force, residual], spec.t, problem.start.warmup)
    residual.axhline(0.0, color="black", lw=0.8)
    limit = residual_limit({"fit": error})
    residual.set_ylim(-limit, limit)
    residual.set_ylabel("model − measured (N)")
    residual.set_xlabel(time_label(problem))
    residual.set_title(f"residual: RMSE {rmse:.3g} N, {nrmse_short(rmse, problem.f_loss)}", loc="left")
    mark_reversals([force, residual], spec.t, turns)
    handles: list = [
        Line2D([], [], label="measured", **{k: v for k, v in MEASURED.items() if k != "rasterized"}),
        style.handle(f"fitted model ({result.optimizer})", marker=False),
        REVERSAL,
    ]
    if steady.ramped:
        handles.append(
            Line2D(
                [],
                [],
                color="black",
                marker=".",
                ls="",
                alpha=RAMP_ALPHA,
                label=f"ramp cycles, lighter ({steady.describe()})",
            )
        )
    if problem.start.warmup:
        handles.append(Patch(**WARMUP, label=warmup_label(problem.start.warmup_s)))
    legend(fig, handles, ncol=2 if len(handles) > 3 else 3)
    title(fig, fit_title(problem, result))
    write_png(fig, path, synthetic)


def fit_title(problem, result) -> str:
    spec = problem.specimen
    formulation = getattr(problem, "formulation", "paper")
    return (
        f"{spec.name} — {problem.model.name} ({formulation} formulation), {result.optimizer}, seed "
        f"{result.seed}, {result.nfev} evaluations\nRMSE {result.rmse_N:.3g} N, "
        f"{_nrmse_words(result.rmse_N, problem.f_loss, 3)}; {conditions(problem)}, {_velocity_source(problem)}"
    )


def _nrmse_words(rmse: float, f, digits: int) -> str:
    from bwbench.problems.hysteresis.fit_result import nrmse_text

    nrmse_abs, nrmse_max = nrmse_pair(rmse, f)
    return nrmse_text(nrmse_abs, nrmse_max, digits)


def nrmse_short(rmse: float, f) -> str:
    """A panel's NRMSE: RMSE/max F where the force has a positive peak, else RMSE/max|F|."""
    nrmse_abs, nrmse_max = nrmse_pair(rmse, f)
    return f"NRMSE {nrmse_max:.3g} (RMSE/max F)" if np.isfinite(nrmse_max) else f"NRMSE {nrmse_abs:.3g} (RMSE/max|F|)"


def time_label(problem) -> str:
    quasi = getattr(problem.signal, "rate_independent", False)
    return "point along the path (quasi-static: no time)" if quasi else "time t (s)"


def nrmse_pair(rmse: float, f) -> tuple[float, float]:
    """(RMSE / max|F|, RMSE / max F) of a record's measured force ``f`` (see ``fit_result.NRMSE_DEFINITIONS``)."""
    f = np.asarray(f, dtype=float)
    peak_abs, peak = float(np.max(np.abs(f))), float(np.max(f))
    return (rmse / peak_abs if peak_abs > 0 else np.inf), (rmse / peak if peak > 0 else np.inf)


def _velocity_source(problem) -> str:
    """ "velocity recorded", "velocity estimated from the displacement" or "velocity of the sine fit"."""
    if getattr(problem.signal, "rate_independent", False):
        return "quasi-static: the displacement path and its direction of motion, no time"
    source = problem.signal.sources.get("velocity", "")
    return {"measured": "velocity recorded", "estimated": "velocity estimated from the displacement"}.get(
        source, f"velocity of the {source}" if source else "velocity"
    )


def hysteresis_loops(study, out_dir, specimen: str, order=None, backends: int = BACKENDS, band="auto") -> Path:
    """The best fits of a study on ``specimen`` (the paper's Figs 20–21 made comparable): the
    measured loop once with the best ranking run's fit, and the residual against time of the best
    run of each of the ``backends`` best backends (ranking ``order``; plus the backend of the best
    run if it is not among them) and of random search. Ranking runs only: a posterior run has a
    far larger budget and would not be a fair "best run of its backend". When the study has a
    posterior on ``specimen``, its 95 % predictive band (``posterior_predictive``; ``band``: "auto" finds
    it, None draws none, or a ``Band``) is shaded on the force and, measured force subtracted, on the
    residual panel."""
    from bwbench.problems.hysteresis.report.posterior_predictive import band_of

    theme()
    band = band_of(study, specimen) if isinstance(band, str) else band
    ranking = study.ranking
    runs = ranking[
        (ranking["specimen"] == specimen) & (ranking["status"] == "ok") & np.isfinite(ranking["mse"].astype(float))
    ]
    look = styles(study, order)
    present = [o for o in look if o in set(runs["optimizer"])]
    best_run = runs.loc[runs["mse"].idxmin()]
    shown = [o for o in present if split_label(o)[0] != "random"][:backends]
    if best_run["optimizer"] not in shown and split_label(best_run["optimizer"])[0] != "random":
        shown.append(best_run["optimizer"])
    randoms = [o for o in present if split_label(o)[0] == "random"]
    shown += randoms
    cache: dict = {}
    frames: list[pd.DataFrame] = []
    residuals: dict[str, np.ndarray] = {}
    fits: dict[str, tuple] = {}
    spec: Any = None
    for optimizer in shown:
        run = runs[runs["optimizer"] == optimizer].sort_values("mse").iloc[0]
        problem = problem_for(study, specimen, optimizer, cache)
        spec = problem.specimen
        force = problem.simulate(run[list(problem.param_names)].to_numpy(dtype=float))
        fits[optimizer] = (run, force, problem)
        residuals[optimizer] = force - spec.f
        frames.append(
            pd.DataFrame(
                {
                    "specimen": specimen,
                    "optimizer": optimizer,
                    "kind": run["kind"],
                    "replicate": int(run["replicate"]),
                    "time_s": spec.t,
                    "displacement_mm": spec.x,
                    "force_measured_N": spec.f,
                    "force_model_N": force,
                    "residual_N": force - spec.f,
                }
            )
        )
    turns = reversals(spec.x)
    fig, loop, force_ax, residual = _panels(7.4)
    best_label = best_run["optimizer"]
    _, best_force, best_problem = fits[best_label]
    _draw_measured(loop, force_ax, spec.t, spec.x, spec.f, best_force, look[best_label], turns)
    noise = _noise_band(study, specimen, cache)
    if noise is not None:
        residual.axhspan(-2 * noise, 2 * noise, color="0.85", zorder=0, lw=0)
    if band is not None:  # on the residual panel as residuals of the best fit: best force − predicted measurement
        force_ax.fill_between(spec.t, band.lower, band.upper, color=BAND_COLOUR, alpha=0.45, lw=0, zorder=2)
        residual.fill_between(
            spec.t, best_force - band.upper, best_force - band.lower, color=BAND_COLOUR, alpha=0.35, lw=0, zorder=1
        )
        # on top of the residual lines: it is narrow (the posterior's spread of the fitted force, no noise)
        residual.fill_between(
            spec.t,
            best_force - band.model_upper,
            best_force - band.model_lower,
            color=OKABE_ITO[4],
            alpha=0.55,
            lw=0,
            zorder=20,
        )
        frames.append(
            pd.DataFrame(
                {
                    "specimen": specimen,
                    "optimizer": "posterior predictive 95 %",
                    "kind": "posterior",
                    "replicate": 0,
                    "time_s": spec.t,
                    "displacement_mm": spec.x,
                    "force_measured_N": spec.f,
                    "band_lower_N": band.lower,
                    "band_upper_N": band.upper,
                    "model_band_lower_N": band.model_lower,
                    "model_band_upper_N": band.model_upper,
                }
            )
        )
    for rank, optimizer in reversed(list(enumerate(shown))):  # the best drawn last, on top
        residual.plot(spec.t, residuals[optimizer], **look[optimizer].line(lw=0.9), zorder=3 + len(shown) - rank)
    residual.axhline(0.0, color="black", lw=0.8, zorder=2)
    limit = residual_limit(residuals, skip=randoms)
    residual.set_ylim(-limit, limit)
    off = [o for o in randoms if np.nanmax(np.abs(residuals[o])) > limit]
    if off:
        residual.text(
            0.99,
            0.03,
            "off-scale: " + ", ".join(f"{o} (up to {np.nanmax(np.abs(residuals[o])):.0f} N)" for o in off),
            transform=residual.transAxes,
            ha="right",
            va="bottom",
            fontsize=9,
            bbox={"fc": "white", "ec": "0.7", "boxstyle": "round"},
            zorder=10,
        )
    residual.set_ylabel("model − measured (N)")
    residual.set_xlabel("time t (s)")
    residual.set_title("residual of the best run of each backend", loc="left")
    mark_reversals([force_ax, residual], spec.t, turns)
    shade_warmup([force_ax, residual], spec.t, best_problem.start.warmup)
    text = {o: f"{o}: RMSE {np.sqrt(fits[o][0]['mse']):.3g} N (seed {int(fits[o][0]['replicate'])})" for o in shown}
    handles: list[Any] = [Line2D([], [], label="measured", **{k: v for k, v in MEASURED.items() if k != "rasterized"})]
    handles += backend_handles(look, shown, text, marker=False)
    handles.append(REVERSAL)
    if noise is not None:
        handles.append(Patch(color="0.85", label=f"±2σ of the noise (truth's residual, σ = {noise:.2g} N)"))
    if best_problem.start.warmup:
        handles.append(Patch(**WARMUP, label=warmup_label(best_problem.start.warmup_s)))
    if band is not None:
        handles.append(
            Patch(
                color=BAND_COLOUR,
                alpha=0.45,
                label=(
                    f"posterior predictive 95 % (noise included; {band.draws} draws): the measured force leaves it at "
                    f"{band.outside:.1%} of the samples"
                ),
            )
        )
        handles.append(
            Patch(
                color=OKABE_ITO[4],
                alpha=0.55,
                label="posterior 95 % of the model force (no noise); residual panel: both as residuals of the best fit",
            )
        )
    legend(fig, handles, ncol=2)
    title(
        fig,
        f"{specimen}: best fit ({best_label}, seed {int(best_run['replicate'])}) and the residuals of the "
        f"best {len(shown) - len(randoms)} backends" + (" and random search" if randoms else "") + "\n"
        f"ranking runs only ({conditions(best_problem)})",
    )
    frame = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
    return save(fig, out_dir, f"loops_{slug(specimen)}", frame, synthetic(study, [specimen]))


def _noise_band(study, specimen, cache):
    """RMS of the truth's residual on a synthetic specimen (the noise), else None."""
    params = truth(study, specimen)
    if params is None:
        return None
    problem = problem_for(study, specimen, "paper", cache)
    error = (problem.simulate(params) - problem.specimen.f)[problem.start.loss]
    return float(np.sqrt(np.mean(error**2))) if np.all(np.isfinite(error)) else None
