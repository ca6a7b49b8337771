"""Posterior predictive checks of a model on a specimen: the share of measured samples outside the 95 %
band of the predicted measurement, where the residual concentrates (near reversals or not), and the
figure of each model's residual within its band."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd


@dataclass(frozen=True)
class Check:
    """The posterior predictive check of one posterior: share of samples outside the 95 % band
    (``outside``), those near reversals (``outside_reversal``), the share of the squared residual near
    reversals (``residual_reversal``) and of the samples there (``samples_reversal``)."""

    outside: float
    outside_reversal: float
    residual_reversal: float
    samples_reversal: float
    draws: int = 0  # posterior draws the band rests on


REVERSAL = 0.2  # near a reversal: |ẋ| below this share of its peak


def predictive_check(pc, rng, bands: dict | None = None) -> Check | None:
    """The check of one posterior; its band goes into ``bands`` under (specimen, model) when given."""
    from bwbench.problems.hysteresis.report.posterior_predictive import predictive

    band = predictive(pc, rng)
    if band is None:
        return None
    if bands is not None:
        bands[(pc.chain.specimen, model_of(pc))] = (pc, band)
    f = np.asarray(pc.problem.specimen.f, dtype=float)
    v = np.abs(np.asarray(pc.problem.signal.v, dtype=float))
    near = v < REVERSAL * np.max(v)
    out = (f < band.lower) | (f > band.upper)
    residual2 = (f - 0.5 * (band.model_lower + band.model_upper)) ** 2
    total = float(residual2.sum())
    return Check(
        float(out.mean()),
        float(out[near].mean()) if near.any() else float("nan"),
        float(residual2[near].sum() / total) if total > 0 else float("nan"),
        float(near.mean()),
        band.draws,
    )


def residual_figure(study, out_dir, specimen: str, shown_bands: list):
    """One panel per model: the residual against time, the band of the predicted measurement about the
    median model force, and the samples near reversals shaded (where the residual concentrates)."""
    from bwbench.problems.hysteresis.report.figure_common import synthetic
    from bwbench.render.palette import OKABE_ITO, figure, save, slug, theme

    theme()
    fig, axes = figure(9.0, 1.9 * len(shown_bands) + 0.8, nrows=len(shown_bands), sharex=True, squeeze=False)
    frames = []
    for ax, (model, pc, band) in zip(axes[:, 0], shown_bands):
        t = np.asarray(pc.problem.specimen.t, dtype=float)
        f = np.asarray(pc.problem.specimen.f, dtype=float)
        v = np.abs(np.asarray(pc.problem.signal.v, dtype=float))
        mid = 0.5 * (band.model_lower + band.model_upper)
        near = v < REVERSAL * np.max(v)
        ax.fill_between(t, 0, 1, where=near, color="0.85", lw=0, transform=ax.get_xaxis_transform(), zorder=0)
        ax.fill_between(t, band.lower - mid, band.upper - mid, color=OKABE_ITO[5], alpha=0.5, lw=0, zorder=1)
        ax.plot(t, f - mid, color="black", lw=0.7, zorder=2)
        ax.set_title(
            f"{model}: {100 * band.outside:.1f} % of the samples outside the 95 % band ({band.draws} draws)", loc="left"
        )
        ax.set_ylabel("residual (N)")
        frames.append(
            pd.DataFrame(
                {
                    "model": model,
                    "time_s": t,
                    "residual_N": f - mid,
                    "band_lower_N": band.lower - mid,
                    "band_upper_N": band.upper - mid,
                    "near_reversal": near,
                }
            )
        )
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(f"{specimen}: residual, 95 % predictive band (blue), reversals (grey)")
    return save(
        fig,
        out_dir,
        f"evidence_residuals_{slug(specimen)}",
        pd.concat(frames, ignore_index=True),
        synthetic(study, [specimen]),
    )


def model_of(pc) -> str:
    model = getattr(pc.problem, "model", None)
    return str(getattr(model, "name", pc.chain.optimizer))
