"""The report's sections every problem has: what was compared, the ranking, the run figures, limits."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from bwbench.report import figures
from bwbench.report.palette import split_label
from bwbench.report.format import evals_text, number, p_text, percent
from bwbench.report.recommend import ALPHA, rule
from bwbench.study.timing import compute_time


def backends_table(study) -> pd.DataFrame:
    """One row per ranking backend: its family, the options it ran with, and its median wall time
    and evaluations per run."""
    try:
        from bwbench.optimize import registry

        backends = registry.available()
    except Exception:  # the report must not depend on every plug-in importing
        backends = {}
    ranking = study.ranking
    wall = ranking.groupby("optimizer")["wall_s"].median() if "wall_s" in ranking else pd.Series(dtype=float)
    nfev = ranking.groupby("optimizer")["nfev"].median()
    rows = []
    for name in study.optimizers:
        base = split_label(name)[0]  # "cmaes [identifiable]" ran the backend "cmaes" (study.tasks.run_label)
        options = study.config.get("optimizers", {}).get(base, {})
        backend = backends.get(base)
        rows.append({"backend": name, "family": getattr(backend, "family", "–"),
                     "evaluates": "–" if backend is None else ("populations" if backend.batched else "one point per call"),
                     "options": ", ".join(f"{k}={json.dumps(v)}" for k, v in options.items()) or "defaults",
                     "median wall time per run (s)": number(wall.get(name), 3),
                     "median evaluations": evals_text(nfev.get(name))})
    return pd.DataFrame(rows)


def pairwise_matrix(pairwise: pd.DataFrame, order: list[str]) -> pd.DataFrame:
    """The pairwise tests as a compact square table in ranking ``order``: row i, column j holds the
    median log10 loss ratio of i over j, starred when Holm's correction leaves it significant."""
    cells = {}
    for r in pairwise.itertuples():
        star = "*" if r.significant else ""
        cells[r.a, r.b] = number(r.median_diff, 2) + star
        cells[r.b, r.a] = number(-r.median_diff if np.isfinite(r.median_diff) else r.median_diff, 2) + star
    rows = []
    for i, a in enumerate(order, 1):
        row = {"backend (rank)": f"{i}. {a}"}
        row.update({str(j): ("–" if a == b else cells.get((a, b), "")) for j, b in enumerate(order, 1)})
        rows.append(row)
    return pd.DataFrame(rows)


def setup(report) -> None:
    study, doc = report.study, report.doc
    s = study.settings
    budget = s.get("budget", "?")
    problem_text = report.problem_type.setup_text(report)
    doc.h(2, "What was compared")
    doc.p(f"Study **{study.name}** (database `{study.path.name}`, bwbench {study.meta.get('bwbench_version', '?')}, "
          f"created {study.meta.get('created_utc', '?')}). Problem: {study.problem_type.description}. Every backend "
          f"had the same budget of **{budget} evaluations** per run (one evaluation = one simulation of one "
          f"parameter vector), {s.get('seeds', '?')} seeds per (specimen, backend), study seed {s.get('seed', '?')}."
          + (" " + problem_text if problem_text else ""))
    took = _compute_time_text(study)
    if took:
        doc.p(took)
    doc.table(backends_table(study), "Backends and their options (as run), with the wall time of their runs "
                                     "(one core each)")
    post = study.config.get("posterior")
    if post:
        doc.p(f"Posterior sampling (not part of the ranking): {post.get('optimizer')} on "
              f"{', '.join(post.get('specimens', []))}, budget {post.get('budget')} evaluations, "
              f"{post.get('seeds')} seed(s), options {json.dumps(post.get('options', {}))}.")


def _compute_time_text(study) -> str:
    """"Computed in 41.2 min …": elapsed over the runner's sessions, core-hours, and the machine."""
    took = compute_time(study.runs)
    if took is None:
        return ""
    sessions = "one session" if took.sessions == 1 else f"{took.sessions} sessions (the idle time between them left out)"
    machine = study.meta.get("machine")
    elapsed = (f"{number(took.elapsed_s, 3)} s" if took.elapsed_s < 120 else f"{number(took.elapsed_s / 60, 3)} min")
    return (f"Computed in **{elapsed}** elapsed, first run start to last run end, in "
            f"{sessions}; {number(took.core_s / 3600, 3)} core-hours of runs"
            + (f", on {machine}" if machine else "") + ". Writing this report is not included.")


def ranking(report) -> None:
    study, doc, table, rec = report.study, report.doc, report.table, report.recommendation
    unit = study.problem_type.residual_unit
    budget = study.settings.get("budget", "?")
    doc.h(2, "Ranking")
    shown = pd.DataFrame({
        "backend": table["optimizer"], "runs": table["runs"], "errors": table["errors"],
        f"median RMSE ({unit})": table["median_rmse_N"].map(lambda x: number(x, 3)),
        f"best RMSE ({unit})": table["best_rmse_N"].map(lambda x: number(x, 3)),
        "success ≤1 %": table["success_1%"].map(percent), "success ≤10 %": table["success_10%"].map(percent),
        "ERT 1 % (evals)": table["ert_1%"].map(evals_text),
        "ERT 10 % (evals)": table["ert_10%"].map(evals_text),
        **report.problem_type.ranking_columns(report, table),
        "mean rank": table["mean_rank"].map(lambda x: number(x, 3)),
        "median wall time (s)": table["median_wall_s"].map(lambda x: number(x, 2)),
    })
    doc.table(shown, f"Ranking runs at a budget of {budget} evaluations, best mean rank first")
    doc.p("Success at τ: the run's best loss came within (1 + τ) × the best known loss of its specimen (the lowest "
          "of any run in this database, ranking or posterior). ERT (expected running time, COCO definition) = "
          "evaluations spent by all runs (evaluations to target for the successful ones, all their evaluations for "
          "the others) / number of successful runs, pooled over specimens; ∞ = no run succeeded. Wall time is "
          "per run on one core; it is not part of the ranking (the budget is), but equal evaluations do not "
          "cost equal time: stiff parameter sets need more integration substeps.")
    omnibus = report.omnibus
    if np.isfinite(omnibus.pvalue):
        doc.p(f"{report.tests.omnibus_name} over {report.tests.omnibus_design}: statistic = {omnibus.statistic:.3g}, "
              f"**p = {p_text(omnibus.pvalue)}**.")
    else:
        doc.p(f"{omnibus.note}.")
    if len(report.pairwise):
        doc.table(pairwise_matrix(report.pairwise, list(table["optimizer"])),
                  f"Pairwise {report.tests.pairwise_name}: median log10(loss of the row / loss of the column); "
                  f"negative = the row reaches lower losses; * = significant after Holm's correction "
                  f"(α = {ALPHA:g}). Columns are numbered by rank; every p, win count and verdict is in "
                  "pairwise_tests.csv")
    doc.p(f"The pairwise tests are on log10 of the final loss (a ratio, so a specimen with larger forces does not "
          f"dominate); a failed run counts as one decade worse than the worst finished run on its specimen. "
          f"{report.tests.pairwise_note} Holm's step-down correction is written out in "
          "`bwbench.analysis.statistics.holm` because scipy offers only FDR corrections and statsmodels is not a "
          "dependency.")
    floor = float(report.pairwise["min_p"].min()) * len(report.pairwise) if len(report.pairwise) else np.nan
    if np.isfinite(floor) and floor >= ALPHA:
        doc.p(f"With these numbers of runs the smallest p a pairwise test can give, times Holm's factor for "
              f"{len(report.pairwise)} comparisons, is {p_text(floor)} ≥ α = {ALPHA:g}: no comparison can be "
              "significant however different the backends are. The order rests on the medians and success rates, "
              "not on significance; more seeds or specimens would be needed to test it.")
    doc.h(2, "Recommendation")
    doc.p(rec["text"])
    doc.p("Rule used: " + rule(report.tests.pairwise_name))


def run_figures(report) -> None:
    study, doc, out = report.study, report.doc, report.out
    doc.h(2, "Figures")
    floors = {}
    for specimen in report.featured:
        value = study.problem_type.noise_floor(study, specimen)
        if value is not None:
            floors[specimen] = (value, f"noise floor (truth): {value:.3g} {study.loss_unit}")
    order = list(report.table["optimizer"])
    doc.figure(figures.convergence(study, out, report.featured, floors=floors, order=order),
               "Convergence: median over seeds of the best-so-far loss relative to the noise floor (or the best "
               "known loss where no floor is known); interquartile band for the best 3")
    doc.figure(figures.runtime_ecdf(study, out, order=order),
               "Runtime ECDF: fraction of (specimen, seed, target) triples reached within x evaluations")
    # One panel per specimen reads well up to a handful; beyond, the featured ones (all in the CSV).
    many = len(study.specimens) > len(report.featured) + 1
    doc.figure(figures.waterfall(study, out, order=order, specimens=report.featured if many else None),
               "Waterfall: the final loss of every ranking run, per specimen, sorted per backend"
               + (f" — on the {len(report.featured)} featured specimens of {len(study.specimens)} (every run of "
                  "every specimen in the CSV)" if many else ""))


def limits(report) -> None:
    study, doc = report.study, report.doc
    s = study.settings
    n_spec = len(study.specimens)
    items = [f"{n_spec} specimen(s) and {s.get('seeds', '?')} seeds per backend: {report.tests.power_note}",
             f"One budget ({s.get('budget', '?')} evaluations): the ranking can change at another budget "
             "(see the ECDF and convergence figures for how each backend would do with less).",
             "The best known loss is the best found in this database, not the global optimum; success rates and "
             "ERT are relative to it."]
    items += report.problem_type.limits(report)
    omnibus = report.omnibus
    if np.isfinite(omnibus.pvalue) and omnibus.pvalue >= ALPHA:
        items.append(f"The {report.tests.omnibus_name} does not reject equal performance (p = {p_text(omnibus.pvalue)}).")
    doc.h(2, "Limits of this study")
    doc.bullets(items)
