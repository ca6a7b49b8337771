"""The Bouc-Wen benchmark problem's report sections (``problem = "bouc-wen-benchmark"``).

What the benchmark adds to the generic report: the test e_RMS (m) of every run (computed by the
runner, never seen by the optimisers) next to the figures published with the benchmark, the
identified parameters next to the truth through the identifiable products βγ and βδ, and the
identifiability of the 8 parameters on the training residual (the exact β–γ–δ scaling invariance).
With one specimen, the generic report compares the backends by the Kruskal–Wallis test and unpaired
Mann–Whitney U tests (the seeds are independent samples, not blocks), and says so in its power
statement.
"""

from __future__ import annotations

import numpy as np

from bwbench.problems.noel_schoukens import benchmark_figures
from bwbench.problems.noel_schoukens.analysis import (
    analyse_identifiability,
    backend_results,
    finished,
    load_problem,
    truth_figures,
)
from bwbench.problems.noel_schoukens.report_sections import (
    NAMES,
    TARGET_M,
    section_identifiability,
    section_parameters,
    section_posterior,
    section_results,
)

SOURCE = (
    "J.P. Noël and M. Schoukens, “Hysteretic benchmark with a dynamic nonlinearity”, Workshop on Nonlinear "
    "System Identification Benchmarks, Brussels, 2016; data and description at www.nonlinearbenchmark.org"
)


def limits(report) -> list[str]:
    return [
        "The optimisers see one steady-state period of train_multisine only; the test files are used after the run, "
        "to score its best point, and never to choose between runs (a backend's best run is the one with the "
        "lowest training MSE).",
        "The model structure is the true one, so the fit has no model error; the published black-box models have "
        "to learn the structure.",
        "The simulator (RK4 at 2.25 kHz, no decimation filter) leaves 5e-07 m on test_multisine at the true "
        "parameters, and the sine sweep carries a 2.6e-06 m floor from how the file was made: differences between "
        "fits below these levels are not meaningful.",
        "Identifiability is analysed locally, at the best fit.",
    ]


# ----------------------------------------------------------------------------------- the hooks


def setup_text(report) -> str:
    return (
        "Fit the 8 parameters (m, c, k, α, β, γ, δ, ν) of the force-driven Bouc-Wen model to the displacement "
        "of one steady-state period of train_multisine (8,192 samples; loss = MSE in m²). Search box: every "
        "positive parameter a decade either side of the truth, log-scaled; δ in [−3, 3] and ν in [0.5, 3], "
        f"linear. Data: the public Bouc-Wen benchmark of nonlinear system identification — {SOURCE}; read from "
        f"`{report.study.data_dir}` (SHA-256 of the three files recorded with the study)."
    )


def _context(report) -> dict:
    """The benchmark's numbers every section uses, computed once per report."""
    if "benchmark" not in report.options:
        study = report.study
        problem = load_problem(study)
        for metric in ("test_multisine_erms_m", "test_sinesweep_erms_m"):
            if metric not in study.runs:  # no run has metrics (e.g. every finished run blew up on the tests)
                study.runs[metric] = np.nan
        order = list(report.table["optimizer"])
        report.options["benchmark"] = {
            "problem": problem,
            "results": backend_results(study, order),
            "truth": truth_figures(problem),
        }
    return report.options["benchmark"]


def report_intro(report) -> None:
    c = _context(report)
    section_results(
        report.doc,
        report.study,
        c["results"],
        c["truth"],
        report.best_backend,
        [n for n in report.verdict.peers if n not in report.verdict.avoid],
    )
    from bwbench.data.output_paths import write_frame

    write_frame(c["results"], report.out / "benchmark_results.csv", index=False)


def ranking_columns(report, table) -> dict:
    below = _context(report)["results"].set_index("optimizer")["seeds_below_target"]
    return {f"seeds test < {TARGET_M:g} m": [f"{below[o]}" for o in table["optimizer"]]}


def add_sections(report) -> None:
    study, doc, out = report.study, report.doc, report.out
    c = _context(report)
    problem, results, truth = c["problem"], c["results"], c["truth"]
    section_parameters(doc, study, results, problem, truth)
    ranking = study.ranking
    # the best fit of the study: the run with the lowest training MSE, whichever backend found it
    done = finished(ranking)
    run = done.loc[done["mse"].idxmin()]
    params = run[list(NAMES)].to_numpy(dtype=float)
    label = f"{run['optimizer']}, seed {int(run['replicate'])}"
    report.progress("identifiability")
    try:
        analysis = analyse_identifiability(problem, params)
    except ValueError:
        doc.p("Identifiability analysis not possible: the model is not finite next to the best fit.")
    else:
        section_identifiability(doc, analysis, label)
    doc.figure(
        benchmark_figures.test_fit(study, out, problem, params, label, order=list(report.table["optimizer"])),
        f"The best fit ({label}) against the test_multisine output, and the error of the fit and of the true "
        "parameters",
    )
    doc.figure(
        benchmark_figures.parameter_spread(study, out, order=list(report.table["optimizer"])),
        "Identified parameters of the runs within 10 % of the best training MSE, scaled to the search box, "
        "with the truth (×): β, γ, δ scatter along their invariance while βγ and βδ stay on the truth",
    )
    section_posterior(doc, study)
