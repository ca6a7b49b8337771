"""Is the model adequate for these data? The best fit of each specimen, judged by its residual.

An optimiser comparison says which backend finds the best fit of the model; it does not say the
model fits. This section does, per specimen, from the best run of the study (any backend):

- RMSE and RMSE relative to the peak |force|;
- where the residual concentrates: the share of the squared error within ±``WINDOW`` of a stroke
  around each reversal of travel, against the share of the samples there (a model that misses the
  transition at the reversals puts most of its error there: e.g. 60 % of the error in 10 % of the
  samples);
- the largest |residual| and whether it sits in such a window;
- for synthetic specimens whose manifest states the force noise: the RMSE against that noise.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bwbench.problems.hysteresis.report.figure_common import problem_for, reversals
from bwbench.render.floors import FACTOR, stated_noise_variance
from bwbench.render.format import join, number

WINDOW = 0.05  # ± this fraction of the mean stroke (samples between reversals) around each reversal
CONCENTRATED = 2.0  # error share ≥ 2 × sample share in the windows: the residual concentrates there
MAX_SPECIMENS = 8


def reversal_windows(x, window: float = WINDOW) -> np.ndarray:
    """Mask of the samples within ±``window`` of a stroke of a reversal of ``x`` (all False when
    the displacement never reverses)."""
    x = np.asarray(x, dtype=float)
    turns = reversals(x)
    mask = np.zeros(x.size, dtype=bool)
    if not turns.size:
        return mask
    edges = np.concatenate([[0], turns, [x.size - 1]])
    half = max(1, int(round(window * float(np.mean(np.diff(edges))))))
    for i in turns:
        mask[max(0, i - half) : i + half + 1] = True
    return mask


def residual_summary(x, f, fitted, window: float = WINDOW) -> dict:
    """RMSE (N), peak |F| (N), their ratio, the shares of squared error and of samples within the
    reversal windows, the largest |residual| (N) and whether it lies in a window."""
    f, fitted = np.asarray(f, dtype=float), np.asarray(fitted, dtype=float)
    r = fitted - f
    mask = reversal_windows(x, window)
    sse = float(np.sum(r**2))
    worst = int(np.argmax(np.abs(r)))
    return {
        "rmse_N": float(np.sqrt(np.mean(r**2))),
        "peak_N": float(np.max(np.abs(f))),
        "relative": float(np.sqrt(np.mean(r**2)) / np.max(np.abs(f))),
        "error_share": float(np.sum(r[mask] ** 2) / sse) if sse > 0 else float("nan"),
        "sample_share": float(mask.mean()),
        "reversals": int(len(reversals(x))),
        "max_abs_N": float(abs(r[worst])),
        "max_at_reversal": bool(mask[worst]),
    }


def table(study, specimens) -> pd.DataFrame:
    """One row per specimen: its best ranking run and ``residual_summary`` of it."""
    ranking = study.ranking
    ok = ranking[(ranking["status"] == "ok") & np.isfinite(ranking["mse"].astype(float))]
    cache: dict = {}
    rows: list = []
    for specimen in specimens:
        runs = ok[ok["specimen"] == specimen]
        if runs.empty:
            continue
        run = runs.loc[runs["mse"].idxmin()]
        problem = problem_for(study, specimen, run["optimizer"], cache)
        fitted = problem.simulate(run[list(problem.param_names)].to_numpy(dtype=float))
        if not np.all(np.isfinite(fitted)):
            continue
        scored = problem.start.loss  # the samples in the loss (after a warm-up)
        rows.append(
            {
                "specimen": specimen,
                "best run": f"{run['optimizer']} seed {int(run['replicate'])}",
                **residual_summary(problem.loss_signal.x, problem.f_loss, fitted[scored]),
            }
        )
    return pd.DataFrame(rows)


def section(report) -> None:
    """The report's "Model adequacy" section."""
    study, doc = report.study, report.doc
    specimens = list(study.specimens)[:MAX_SPECIMENS]
    frame = table(study, specimens)
    doc.h(2, "Model adequacy: how well the best fit reproduces the data")
    if frame.empty:
        doc.p("No finished fit to judge.")
        return
    noise = stated_noise_variance(study) if report.problem_type.is_synthetic(study) else None
    shown = pd.DataFrame(
        {
            "specimen": frame["specimen"],
            "best run": frame["best run"],
            "RMSE (N)": frame["rmse_N"].map(lambda v: number(v, 3)),
            "peak |F| (N)": frame["peak_N"].map(lambda v: number(v, 4)),
            "RMSE / peak |F|": frame["relative"].map(lambda v: f"{v:.2%}"),
            f"share of squared error within ±{WINDOW:.0%} of a stroke of the reversals": frame["error_share"].map(
                lambda v: f"{v:.0%}"
            ),
            "share of samples there": frame["sample_share"].map(lambda v: f"{v:.0%}"),
            "largest |residual| (N)": [
                f"{number(v, 3)}{' (at a reversal)' if at else ''}"
                for v, at in zip(frame["max_abs_N"], frame["max_at_reversal"])
            ],
            **(
                {"RMSE / stated noise σ": (frame["rmse_N"] / np.sqrt(noise)).map(lambda v: f"{v:.2f}")} if noise else {}
            ),
        }
    )
    more = len(study.specimens) - len(specimens)
    doc.table(
        shown,
        "The best run of each specimen (any backend), its residual (model − measured force)"
        + (f"; the first {len(specimens)} of {len(study.specimens)} specimens" if more > 0 else ""),
    )
    doc.p(verdict_text(frame, noise))


def verdict_text(frame: pd.DataFrame, noise_variance=None) -> str:
    """The section's sentence: the range of relative RMSE, and where the residual concentrates."""
    low, high = frame["relative"].min(), frame["relative"].max()
    rel = f"{low:.1%}" if np.isclose(low, high, rtol=0.05) else f"{low:.1%} to {high:.1%}"
    text = (
        f"The best fits leave an RMSE of {rel} of the peak force "
        f"({'one specimen' if len(frame) == 1 else f'{len(frame)} specimens'})."
    )
    concentrated = frame[frame["error_share"] >= CONCENTRATED * frame["sample_share"]]
    if len(concentrated):
        text += (
            f" On {join(list(concentrated['specimen']))} the residual concentrates at the reversals of travel: "
            + join(
                [
                    f"{e:.0%} of the squared error in {s:.0%} of the samples"
                    for e, s in zip(concentrated["error_share"], concentrated["sample_share"])
                ]
            )
            + ". The model misses the transition there (the fit is shaped by the strokes between them); "
            "parameters that act at the reversals are the least trustworthy."
        )
    else:
        text += (
            f" The squared error is spread along the strokes (within ±{WINDOW:.0%} of a stroke of the "
            "reversals it is no more than about twice the share of the samples there)."
        )
    if noise_variance:
        ratio = frame["rmse_N"] / np.sqrt(noise_variance)
        text += (
            f" Against the stated force noise (σ = {number(np.sqrt(noise_variance), 3)} N) the RMSE is "
            f"{ratio.min():.2f} to {ratio.max():.2f} σ: "
            + (
                "the model reproduces the data down to the noise."
                if ratio.max() <= math.sqrt(FACTOR)
                else "more than the noise alone explains."
            )
        )
    return text
