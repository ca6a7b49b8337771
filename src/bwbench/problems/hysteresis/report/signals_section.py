"""The report's paragraph on the signals that drive the model and on the best fits' box edges: which
velocities are recorded, the expected force error of the estimated ones at the best fit's coefficients
beside that fit's RMSE, and the parameters of best fits that ended on an edge of their search box."""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.engine.fitting import on_box_edge
from bwbench.models.derivatives import SPLINE_NAME
from bwbench.problems.hysteresis.fit_checks import expected_force_error, linear_branches
from bwbench.problems.hysteresis.report.figure_common import problem_for
from bwbench.render.format import number


def _best_fits(study):
    """(specimen, best run row, its problem) for every specimen with a finished run."""
    runs = study.runs[(study.runs["status"] == "ok") & np.isfinite(study.runs["mse"])]
    cache = {}
    for specimen, group in runs.groupby("specimen", sort=False):
        best = group.loc[group["mse"].idxmin()]
        problem = problem_for(study, specimen, best["optimizer"], cache)
        yield specimen, best, problem


def paragraph(report) -> None:
    """Add the paragraph (and a table when some velocity is estimated) to ``report.doc``."""
    doc = report.doc
    recorded, estimated, errors, edges = [], [], [], []
    for specimen, best, problem in _best_fits(report.study):
        params = np.array([best.get(name, np.nan) for name in problem.param_names], dtype=float)
        if not np.all(np.isfinite(params)):
            continue
        error = expected_force_error(problem, params)
        if error is None:
            recorded.append(specimen)
        else:
            errors.append(error["expected_force_error_N"])
            estimated.append(
                {
                    "specimen": specimen,
                    "best RMSE (N)": number(np.sqrt(best["mse"]), 3),
                    "expected force error (N)": number(error["expected_force_error_N"], 3),
                    "velocity error (mm/s)": f"{error['velocity_error_mm_s']:.2g}",
                    "∂F/∂ẋ rms (N·s/mm)": number(error["sensitivity_N_s_per_mm"], 4),
                }
            )
        linear = linear_branches(problem, params)
        edges += [
            f"{specimen} ({name} {side}"
            + (
                f": branch {name[-1]} linear, no yield within the stroke)"
                if side == "upper" and name.startswith("xy") and linear.get(name[-1])
                else ")"
            )
            for name, side in on_box_edge(problem, params).items()
        ]
    text = []
    if recorded:
        text.append(
            f"The velocity of {len(recorded)} of {len(recorded) + len(estimated)} specimens is recorded in "
            "their files (velocity_mm_s) and drives the model as recorded: no estimation error."
        )
    if estimated:
        worst = max(errors)
        text.append(
            f"The velocity of {len(estimated)} specimen{'s' if len(estimated) > 1 else ''} is estimated from the displacement ({SPLINE_NAME}, "
            f"smoothing set by the displacement noise): at the best fit's viscous coefficients its expected "
            f"force error is up to {worst:.3g} N rms, to be read beside the fit's RMSE (table)."
        )
    text.append(
        "Best fits with a parameter on an edge of its search box (the optimum may lie beyond it): "
        + (", ".join(edges) if edges else "none")
        + "."
    )
    doc.p("**Signals and box edges.** " + " ".join(text))
    if estimated:
        doc.table(
            pd.DataFrame(estimated),
            "Estimated velocities: expected force error at the best fit "
            "(|∂F/∂ẋ| × estimated velocity error) beside the best fit's RMSE",
        )
