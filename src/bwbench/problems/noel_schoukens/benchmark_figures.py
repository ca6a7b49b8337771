"""Figures of a Bouc-Wen benchmark study (``problem = "bouc-wen-benchmark"``).

The convergence, ECDF and waterfall figures are ``bwbench.render.run_figures``' own; these two are the
benchmark's: the best fit against the ``test_multisine`` output, and the identified parameters
scaled to the search box with the truth marked. Each returns the PNG's path and writes the CSV
behind it beside it (same name). The data are the public benchmark: every figure says so (``DATA_MARK``).
``order``: the report's ranking (best first), for the backends' styles and legend order, the same
as in the study's other figures (see ``bwbench.render.palette``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from bwbench.analysis import statistics
from bwbench.engine.box import box_to_unit
from bwbench.problems.noel_schoukens import problem as bm
from bwbench.render.palette import (
    MAX_WIDTH_IN,
    TRUTH,
    backend_handles,
    figure,
    legend,
    save,
    styles,
    theme,
    truth_handle,
)
from bwbench.render.run_figures import finished

SPREAD_TOLERANCE = 0.10  # parameter spread: runs within 10 % of the best known training MSE
DATA_MARK = "BENCHMARK DATA (Noël & Schoukens 2016: a simulated Bouc-Wen system with noise)"

LABELS = {
    "m": "m",
    "c": "c",
    "k": "k",
    "alpha": "α",
    "beta": "β",
    "gamma": "γ",
    "delta": "δ",
    "nu": "ν",
    "beta_gamma": "βγ",
    "beta_delta": "βδ",
}
UNITS = {
    "m": "kg",
    "c": "N·s/m",
    "k": "N/m",
    "alpha": "N/m",
    "beta": "1/m",
    "gamma": "–",
    "delta": "–",
    "nu": "–",
    "beta_gamma": "1/m",
    "beta_delta": "1/m",
}
# The identifiable products, scaled to the box their factors span: βγ log-scaled like β and γ,
# βδ linear like δ (it changes sign inside the box).
COMBINATIONS = {
    "beta_gamma": (bm.LOWER[4] * bm.LOWER[5], bm.UPPER[4] * bm.UPPER[5], True),
    "beta_delta": (bm.UPPER[4] * bm.LOWER[6], bm.UPPER[4] * bm.UPPER[6], False),
}


def unit_values(P) -> np.ndarray:
    """(n, 10): the 8 parameters and βγ, βδ of each row of P (physical units, shape (n, 8)),
    scaled to the search box (log10 for the log-scaled ones)."""
    P = np.atleast_2d(np.asarray(P, dtype=float))
    columns = [bm.to_unit(P)]
    for product, (lo, hi, log) in COMBINATIONS.items():
        value = P[:, 4] * (P[:, 5] if product == "beta_gamma" else P[:, 6])
        columns.append(box_to_unit(value[:, None], np.array([lo]), np.array([hi]), np.array([log])))
    return np.hstack(columns)


def test_fit(study, out_dir, problem, params, label: str, window_s=(2.0, 2.4), order=None) -> Path:
    """The best fit against ``test_multisine`` over a short window: output (mm) on top, the error
    y_model − y_test (µm) of the fit and of the true parameters below, on the same time axis.
    e_RMS over the whole file in the legend. ``label``: "backend, seed N" (its colour is the
    backend's)."""
    theme()
    record = bm.read_benchmark_csv(Path(problem.data_dir) / "test_multisine.csv")
    y_fit = problem.simulate_test(params, "test_multisine")
    y_truth = problem.simulate_test(bm.TRUE_PARAMS, "test_multisine")
    e_fit = float(np.sqrt(np.mean((y_fit - record.y) ** 2)))
    e_truth = float(np.sqrt(np.mean((y_truth - record.y) ** 2)))
    shown = (record.t >= window_s[0]) & (record.t <= window_s[1])
    t = record.t[shown]
    backend = label.split(",")[0].strip()
    look = styles(study, order)
    colour = look[backend].colour if backend in look else look[next(iter(look))].colour
    fig, (top, bottom) = figure(
        MAX_WIDTH_IN, 6.6, nrows=2, ncols=1, sharex=True, gridspec_kw={"height_ratios": [1.2, 1]}
    )
    top.plot(t, 1e3 * record.y[shown], "-", color="black", lw=2.6, zorder=2)
    top.plot(t, 1e3 * y_fit[shown], "--", color=colour, lw=1.5, zorder=3)
    top.set_ylabel("displacement y (mm)")
    top.set_title(
        "output"
        + (": the curves overlap at this scale; the error is below" if e_fit < 0.05 * float(np.std(record.y)) else ""),
        loc="left",
    )
    bottom.plot(t, 1e6 * (y_fit - record.y)[shown], "-", color=colour, lw=1.2, zorder=3)
    bottom.plot(t, 1e6 * (y_truth - record.y)[shown], "-", color="black", lw=1.0, zorder=2)
    bottom.axhline(0.0, color="0.6", lw=0.8)
    bottom.set_ylabel("y_model − y_test (µm)")
    bottom.set_xlabel("time t (s)")
    bottom.set_title("error", loc="left")
    legend(
        fig,
        [
            Line2D([], [], color="black", lw=2.6, label="test_multisine (measured)"),
            Line2D(
                [], [], color=colour, lw=1.5, ls="--", label=f"best fit: {label} (e_RMS over the file {e_fit:.2e} m)"
            ),
            Line2D([], [], color="black", lw=1.0, label=f"true parameters, this simulator (e_RMS {e_truth:.2e} m)"),
        ],
        ncol=1,
    )
    fig.suptitle(
        f"Best fit vs the benchmark's test_multisine output, {window_s[0]:g}–{window_s[1]:g} s of the "
        f"{record.t[-1] - record.t[0] + 1 / bm.SAMPLE_RATE_HZ:.2f} s period"
    )
    frame = pd.DataFrame({"time_s": record.t, "y_test_m": record.y, "y_fit_m": y_fit, "y_truth_m": y_truth})
    return save(fig, out_dir, "test_multisine_fit", frame, DATA_MARK)


def parameter_spread(study, out_dir, tolerance: float = SPREAD_TOLERANCE, order=None) -> Path:
    """The 8 parameters and the products βγ, βδ of every ranking run whose training MSE is
    within ``tolerance`` of the best known, scaled to the search box; the truth as black ×.
    β, γ and δ may scatter along their exact invariance while βγ and βδ stay on the truth. Only
    backends with such runs are drawn and listed."""
    theme()
    specimen = study.specimens[0]
    best = statistics.best_known(study.runs)[specimen]
    runs = finished(study.ranking)
    good = runs[runs["mse"] <= best * (1 + tolerance)]
    total = runs.groupby("optimizer").size()
    look = styles(study, order)
    names = [*bm.PARAM_NAMES, *COMBINATIONS]
    optimizers = [o for o in look if o in set(good["optimizer"])]
    fig, ax = figure(MAX_WIDTH_IN, 5.6)
    width = 0.8 / max(len(optimizers), 1)
    rng = np.random.default_rng(0)  # jitter only: the figure is the same every time
    rows = []
    for b, optimizer in enumerate(optimizers):
        g = good[good["optimizer"] == optimizer]
        unit = unit_values(g[list(bm.PARAM_NAMES)].to_numpy(dtype=float))
        offset = (b - (len(optimizers) - 1) / 2) * width
        for j in range(len(names)):
            x = j + offset + rng.uniform(-0.25, 0.25, len(g)) * width
            ax.plot(x, unit[:, j], **look[optimizer].point(ms=6), alpha=0.85, zorder=3)
        for replicate, mse, u in zip(g["replicate"], g["mse"], unit):
            rows += [
                {
                    "optimizer": optimizer,
                    "replicate": int(replicate),
                    "mse_m2": mse,
                    "parameter": n,
                    "unit_value": float(u[j]),
                }
                for j, n in enumerate(names)
            ]
    truth = unit_values(bm.TRUE_PARAMS)[0]
    ax.hlines(truth, np.arange(len(names)) - 0.42, np.arange(len(names)) + 0.42, color="black", lw=1.0, zorder=1)
    ax.plot(np.arange(len(names)), truth, **TRUTH, zorder=4)
    rows += [
        {"optimizer": "truth", "replicate": -1, "mse_m2": np.nan, "parameter": n, "unit_value": float(u)}
        for n, u in zip(names, truth)
    ]
    ax.axvline(len(bm.PARAM_NAMES) - 0.5, color="0.3", lw=1.2)
    for j in range(len(names) - 1):
        ax.axvline(j + 0.5, color="0.85", lw=0.8)
    ax.grid(axis="x", visible=False)
    scale = ["log" if log else "lin" for log in bm.LOG_SCALED] + [
        "log" if c[2] else "lin" for c in COMBINATIONS.values()
    ]
    ax.set_xticks(np.arange(len(names)), [f"{LABELS[n]}\n({s})" for n, s in zip(names, scale)])
    ax.set_xlim(-0.6, len(names) - 0.4)
    ax.set_ylim(-0.04, 1.04)
    ax.set_ylabel("position in the search box (–)")
    ax.set_xlabel("parameter (log: log10 scaled to the box; lin: linear) | identifiable products")
    text = {o: f"{o} ({int((good['optimizer'] == o).sum())}/{int(total.get(o, 0))} runs)" for o in optimizers}
    legend(fig, [*backend_handles(look, optimizers, text, line=False), truth_handle()], ncol=5)
    fig.suptitle(
        f"Identified parameters of every ranking run with training MSE ≤ {1 + tolerance:g} × the best "
        f"known ({best:.3g} m²), scaled to the search box"
    )
    frame = pd.DataFrame(rows, columns=["optimizer", "replicate", "mse_m2", "parameter", "unit_value"])
    return save(fig, out_dir, "spread", frame, DATA_MARK)
