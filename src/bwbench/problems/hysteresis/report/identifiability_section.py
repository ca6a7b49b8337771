"""The report's identifiability section, in the coordinates the study searched.

At the best fit of each featured specimen in ``formulation``'s coordinates (the paper's 14 in its
box, or the identifiable hysteretic parameters in the box scaled from the data): the Jacobian's
singular values, the exact symmetries, each parameter's free range and standard error, the spread
of the good runs across seeds, and profiles of the widest ones on the first specimen
(``switched_identifiability.analyse``). Only what each tool can show is claimed: the local analysis
describes the neighbourhood of one point, and a profile bounds a parameter only where its
re-optimisations converged (``profile_sentence``).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bwbench.analysis import statistics
from bwbench.analysis.identifiability import POOR_SE
from bwbench.errors import UserError
from bwbench.problems.hysteresis import identifiability as switched_identifiability
from bwbench.problems.hysteresis.report.figure_common import formulation_of, model_of, problem_for, synthetic
from bwbench.render.format import join, number

GOOD = 0.10  # good runs: final loss within 10 % of the best known


def box_name(formulation: str, paper_data: bool) -> str:
    """How the report names a formulation's search box."""
    if formulation == "paper":
        return "Table 5" if paper_data else "the paper formulation's box"
    return "the box scaled from the data"


def runs_in(study, formulation: str, model: str | None = None) -> pd.DataFrame:
    """Finished runs (ranking and posterior) that searched ``formulation``'s coordinates (of ``model``,
    when given: a study comparing models has one set of coordinates per model)."""
    runs = study.runs[(study.runs["status"] == "ok") & np.isfinite(study.runs["mse"].astype(float))]
    return runs[
        [
            formulation_of(study, o) == formulation and (model is None or model_of(study, o) == model)
            for o in runs["optimizer"]
        ]
    ]


def good_run_spread(study, specimen, formulation, cache, tolerance=GOOD, label: str | None = None):
    """Per parameter, (max − min) of the good ranking runs in ``formulation`` (of the model of the run
    label ``label``, when given) as a fraction of its search range; None with fewer than 2 such runs."""
    best = statistics.best_known(study.runs)[specimen]
    ranking = runs_in(study, formulation, None if label is None else model_of(study, label))
    good = ranking[
        (ranking["kind"] == "ranking") & (ranking["specimen"] == specimen) & (ranking["mse"] <= best * (1 + tolerance))
    ]
    if len(good) < 2:
        return None, len(good)
    problem = problem_for(study, specimen, label or formulation, cache)
    unit = problem.to_unit(good[list(problem.param_names)].to_numpy(dtype=float))
    return dict(zip(problem.param_names, unit.max(axis=0) - unit.min(axis=0))), len(good)


def section(report, formulation: str, paper_data: bool) -> list:
    """Write the section; return the analyses (one dict per specimen analysed)."""
    from bwbench.problems.hysteresis.report import profile_figures

    doc, study, log = report.doc, report.study, report.log
    box = box_name(formulation, paper_data)
    profile_params, profile_grid = report.options.get("profile_params", 2), report.options.get("profile_grid", 7)
    coordinates = "the paper's 14 parameters" if formulation == "paper" else "the identifiable hysteretic parameters"
    doc.h(2, "Identifiability: what the data cannot pin down")
    doc.p(
        f"At the best fit of each specimen in the coordinates the study searched ({coordinates}, scaled to "
        f"{box}): the Jacobian of the force residual (model − measured, N) by central differences (step 1e-4 of "
        "the range); its singular values say how strongly the force responds along each direction of parameter "
        "space. A direction is *undetermined* when even a step across the whole range changes the residual sum of "
        "squares by less than the 95 % threshold for one parameter (1.96² × the noise variance); moving along the "
        "undetermined directions inside the box gives each parameter a *free range*. A parameter is *poorly "
        f"determined* when its free range or its linearised standard error exceeds {POOR_SE:.0%} of its range. "
        "This is a local, linear analysis at one point; the profiles and the spread across seeds test it further."
    )
    runs = runs_in(study, formulation)
    cache: dict = {}
    results: list = []
    for k, specimen in enumerate(report.featured):
        mine = runs[runs["specimen"] == specimen]
        if mine.empty:
            doc.p(f"{specimen}: no finished fit in {box} to analyse.")
            continue
        # the model of the best fit: a study comparing models analyses each specimen in the winner's
        best_label = mine.loc[mine["mse"].idxmin(), "optimizer"]
        model = model_of(study, best_label)
        mine = mine[[model_of(study, o) == model for o in mine["optimizer"]]]
        problem = problem_for(study, specimen, best_label, cache)
        unit = problem.to_unit(mine[list(problem.param_names)].to_numpy(dtype=float))
        inside = mine[np.all(np.isfinite(unit) & (unit >= -1e-9) & (unit <= 1 + 1e-9), axis=1)]
        if inside.empty:
            doc.p(f"{specimen}: no fit inside {box} to analyse.")
            continue
        run = inside.loc[inside["mse"].idxmin()]
        widest = profile_params if k == 0 else 0
        if widest:
            print(f"profiling {widest} parameter(s) on {specimen} (about a second per point) ...", file=log, flush=True)
        try:
            result = switched_identifiability.analyse(
                study.specimen_path(specimen),
                run[list(problem.param_names)].to_numpy(dtype=float),
                study.settings.get("state", "shared"),
                study.settings.get("excitation", "measured"),
                formulation=formulation,
                bounds=study.settings.get("bounds"),
                profile_widest=widest,
                grid=profile_grid,
                model=model,
                progress=report.counter(f"profiles on {specimen}", "point") if hasattr(report, "counter") else None,
            )
        except UserError as err:
            doc.p(f"{specimen}: identifiability analysis not possible: {err}")
            continue
        results.append(result)
        names = result["names"]
        label = result["labels"].get  # the model's own labels (x_y₊, ωn₋, c₁, ...)
        doc.h(3, specimen)
        rel = result["relative_singular_values"]
        doc.p(
            f"Best fit: {run['optimizer']} ({run['kind']}, seed {int(run['replicate'])}), RMSE "
            f"{result['rmse_N']:.3g} N. The singular values span {math.log10(rel[0] / max(rel[-1], 1e-300)):.1f} "
            f"decades (condition number {number(result['condition_number'], 3)}); {result['numerically_zero']} "
            f"{'is' if result['numerically_zero'] == 1 else 'are'} below 1e-6 of the largest and "
            f"{result['undetermined_directions']} directions are undetermined at the "
            f"noise level ({result['noise_rmse_N']:.3g} N RMSE)."
        )
        doc.bullets([f"σ/σmax = {w['ratio']:.1e}: {w['text']}" for w in result["weakest"]])
        for s in result["symmetries"]:
            doc.p(
                f"**Exact symmetry {s['name']}**: along s ∈ [0.8, 1.25] the force changes by at most "
                f"{s['max_force_change_N']:.1g} N, and {s['in_null_space']:.0%} of its tangent "
                f"({s['direction']}) lies in the numerically zero directions: it accounts for one of them. "
                + " ".join(
                    f"The other zero direction {d['direction']} is "
                    + (
                        "invariant to round-off along a finite path at this point (an exact invariance "
                        "here, not a symmetry of the model)."
                        if d["exact"]
                        else "zero here only: weakly determined, not invariant."
                    )
                    for d in result["null_directions"]
                )
            )
        spread, n_good = good_run_spread(study, specimen, formulation, cache, label=best_label)
        poor = result["poorly_determined"]
        rows = []
        for n in names:
            lo, hi = result["free_range"][n]
            rows.append(
                {
                    "parameter": label(n),
                    "best fit": number(result["params"][n]),
                    "free range": f"{number(lo)} – {number(hi)}",
                    "free (% of range)": f"{result['free_range_unit'][n]:.0%}",
                    "s.e. (% of range)": f"{min(result['standard_error_unit'][n], 9.99):.1%}",
                    f"spread of {n_good} good run{'s' if n_good != 1 else ''} (% of range)": (
                        f"{spread[n]:.0%}" if spread else "–"
                    ),
                    "poorly determined": "yes" if n in poor else "",
                }
            )
        doc.table(pd.DataFrame(rows), f"{specimen}: local identifiability at the best fit (ranges: {box})")
        doc.p(_spread_text(names, poor, spread, n_good, label))
        if result["profiles"]:
            png = profile_figures.profiles(result, doc.out_dir, synthetic(study, [specimen]))  # names the data's source
            doc.figure(
                png,
                f"Profile likelihoods on {specimen}: each point re-optimises the other parameters "
                "(L-BFGS-B until its convergence test stops it; open circles: not converged, an upper "
                "bound only)",
            )
            doc.p(profile_sentence(result))
    return results


def _spread_text(names, poor, spread, n_good, label) -> str:
    well = [n for n in names if n not in poor]
    text = (
        f"The data cannot pin down {', '.join(label(n) for n in poor)}"
        if poor
        else f"Every parameter is determined to better than {POOR_SE:.0%} of its range"
    )
    text += f"; well determined: {', '.join(label(n) for n in well) or 'none'}."
    if not spread:
        return text + (
            f" Only {n_good} ranking run(s) came within {GOOD:.0%} of the best known MSE, too few to "
            "compare the spread across seeds with this analysis."
        )
    wide = [n for n in names if spread[n] > POOR_SE]
    explained = [n for n in wide if n in poor]
    unexplained = [n for n in wide if n not in poor]
    text += (
        f" Across the {n_good} ranking runs within {GOOD:.0%} of the best known MSE, {len(wide)} parameters "
        f"spread over more than {POOR_SE:.0%} of their range; {len(explained)} of them are flagged poorly "
        "determined"
    )
    if unexplained:
        text += (
            f", while {join([f'{label(n)} ({spread[n]:.0%})' for n in unexplained])} "
            f"{'is' if len(unexplained) == 1 else 'are'} determined locally yet scatter"
            f"{'s' if len(unexplained) == 1 else ''}: there the good runs sit in different minima, not along "
            "one flat valley"
        )
    text += "."
    if wide and len(explained) >= len(wide) / 2:
        text += (
            " So most of the scatter across seeds is what the data allow: runs that fit equally well land at "
            "different points along the undetermined combinations, so the scatter of these parameters is no "
            "fault of the optimisers."
        )
    return text


def profile_sentence(result: dict) -> str:
    """What the profiles can show, in words. A profile point is an upper bound of the true profile
    (the re-optimisation may stop early or in a local minimum): a profile below the 95 % threshold
    over the whole range shows the data do not identify the parameter there, whatever the search
    did; a bound is claimed only from converged points above the threshold, and then only for the
    minimum the search found."""
    from bwbench.problems.hysteresis.report.profile_figures import BOUNDED_TEXT, bounded, threshold_of

    floor, threshold = threshold_of(result)
    parts = []
    for name, points in result["profiles"].items():
        mse = np.array([p["mse"] if p["mse"] is not None else math.inf for p in points])
        converged = np.array([p.get("converged", False) for p in points])
        values = np.array([p["value"] for p in points])
        side = bounded(values, mse, threshold, converged)
        label = result.get("labels", {}).get(name) or switched_identifiability.label(name)
        if side == "neither":
            parts.append(
                f"{label}: below the 95 % threshold over its whole search range, so the data do not "
                "identify it at all (the others compensate; an upper-bound profile shows this whether or "
                "not every re-optimisation converged)"
            )
        elif side == "not shown":
            parts.append(
                f"{label}: the profile rises above the 95 % threshold only at points whose "
                f"re-optimisation did not converge ({int((~converged).sum())} of {len(points)}): those "
                "points are upper bounds, so no bound is shown"
            )
        else:
            worst = float(mse[converged & np.isfinite(mse)].max())
            parts.append(
                f"{label}: the 95 % region is {BOUNDED_TEXT[side]}, shown"
                f" by converged re-optimisations (up to {number(worst, 3)} {'N²'}, best "
                f"{number(floor, 3)} N²); a local result: another minimum could lower the profile"
            )
    return (
        "Profiles (each point: L-BFGS-B on the other parameters until its own convergence test stops it, at "
        f"most {result.get('profile_maxiter', '?')} iterations, from the neighbouring point and, if that does "
        "not converge, from the best fit) — " + "; ".join(parts) + "."
    )
