"""Figures of a single fit. Study-level figures live with the report."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # files only: no display on test machines and CI
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import seaborn as sns  # noqa: E402

SYNTHETIC_LABEL = "SYNTHETIC DATA (generated from the paper's Tables 6–8)"


def mark_synthetic(fig) -> None:
    fig.text(0.995, 0.005, SYNTHETIC_LABEL, ha="right", va="bottom", fontsize=8, color="0.35", style="italic")


def plot_fit(problem, result, path, synthetic: bool = False) -> None:
    """Measured and fitted force against displacement (loops) and against time; PNG at ``path``."""
    sns.set_theme(style="whitegrid", context="notebook")
    spec = problem.specimen
    params = np.array([result.params[name] for name in problem.param_names])
    fitted = problem.simulate(params)
    fig, (loops, series) = plt.subplots(1, 2, figsize=(13, 5), gridspec_kw={"width_ratios": [1, 1.4]})
    loops.plot(spec.x, spec.f, ".", ms=2.5, color="0.55", label="measured")
    loops.plot(problem.signal.x, fitted, "-", lw=1.2, color="C3", label="fitted model")
    loops.set_xlabel("displacement x (mm)")
    loops.set_ylabel("force F (N)")
    loops.set_title("hysteresis loops")
    loops.legend(loc="upper left")
    series.plot(spec.t, spec.f, ".", ms=2, color="0.55", label="measured")
    series.plot(spec.t, fitted, "-", lw=1.0, color="C3", label="fitted model")
    series.set_xlabel("time t (s)")
    series.set_ylabel("force F (N)")
    series.set_title("force over time")
    series.legend(loc="upper left")
    fig.suptitle(
        f"{spec.name} — {result.optimizer}, seed {result.seed}, {result.nfev} evaluations: "
        f"RMSE {result.rmse_N:.3g} N, F_err {result.f_err:.4g} N² ({problem.state} state, "
        f"{problem.excitation} excitation)",
        fontsize=11,
    )
    if synthetic:
        mark_synthetic(fig)
    fig.tight_layout(rect=(0, 0.02, 1, 0.97))
    fig.savefig(path, dpi=120)
    plt.close(fig)
