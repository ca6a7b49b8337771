"""The identified parameters per specimen, in the coordinates a study searched.

For each specimen: the best run that searched those coordinates, the recommended label's runs
across its seeds (an honest aggregate: the values themselves for one or two seeds, median [min,
max] from three), and, for a synthetic specimen searched in the paper's coordinates, the truth. In
the paper's coordinates the 14 parameters are split into the tension and compression sets (the
paper's Tables 6–8, on the paper's data); in the identifiable ones the hysteretic parameters and
the solved linear coefficients, each with its unit.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.models.switched import parameters as switched_parameters
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.models.switched.parameters import LABELS
from bwbench.problems.hysteresis.report.figure_common import formulation_of, problem_for, study_variants, variant_of
from bwbench.render.format import number


def aggregate_text(values) -> str:
    """One value as it is, two listed ("a, b"), three or more as median [min, max]: a median of two
    would be their mean."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return "–"
    if values.size <= 2:
        return ", ".join(number(v) for v in values)
    return f"{number(np.median(values))} [{number(values.min(), 3)}, {number(values.max(), 3)}]"


def aggregate_label(n: int) -> str:
    return {0: "no run", 1: "its one run", 2: "both runs"}.get(n, f"median [min, max] of {n} runs")


def column_groups(problem) -> list[tuple[str, list[str]]]:
    """(title, parameter names) of each table for the coordinates ``problem`` searched."""
    names = list(problem.param_names)
    if getattr(problem, "formulation", "") == "identifiable":
        return [
            ("hysteretic parameters (searched)", names),
            ("linear coefficients (solved per simulation)", list(problem.linear_names)),
        ]
    if problem.model.name == "switched-bouc-wen":
        return [("tension set (+)", list(PARAM_NAMES[:7])), ("compression set (−)", list(PARAM_NAMES[7:]))]
    return [("parameters (searched)", names)]


def headings(problem) -> dict:
    """Column heading (symbol and unit) of every parameter ``problem`` reports."""
    out = {p.name: p.text for p in problem.parameter_list}
    out.update({n: f"{n} ({u})" for n, u in getattr(problem, "linear_units", {}).items()})
    if problem.model.name == "switched-bouc-wen" and problem.formulation == "paper":
        out.update(LABELS)
    return out


FACTS = ("material", "underpressure_MPa", "repeat")  # a manifest's facts of a specimen (meta_json)


def with_facts(runs: pd.DataFrame) -> pd.DataFrame:
    """``runs`` with a column for each of ``FACTS``, NaN where no specimen had a manifest to say it."""
    missing = {name: np.nan for name in FACTS if name not in runs}
    return runs.assign(**missing) if missing else runs


def section(report, formulation: str, paper_data: bool) -> None:
    doc, study = report.doc, report.study
    shown = (
        report.best_backend
        if formulation_of(study, report.best_backend) == formulation
        else next(
            (o for o in report.table["optimizer"] if formulation_of(study, o) == formulation), report.best_backend
        )
    )
    variant = variant_of(study, shown)
    paper = paper_data and formulation == "paper" and variant[1] == "switched-bouc-wen"
    doc.h(2, "Identified parameters per specimen" + (" (the paper's Tables 6–8)" if paper else ""))
    several_models = len({m for _, m, _ in study_variants(study)}) > 1
    coordinates = (
        "the paper's 14 parameters"
        if paper
        else f"the {formulation} coordinates" + (f" of the {variant[1]} model" if several_models else "")
    )
    doc.p(
        f"In {coordinates}, the coordinates the study searched. For each specimen: the best run that searched "
        f"them (loss = MSE, N²), the runs of {shown} across its seeds"
        + (", and the truth the synthetic specimen was generated from" if paper else "")
        + "."
    )
    ranking = with_facts(study.ranking)
    ranking = ranking.assign(material=ranking["material"].fillna("Specimens"))  # no manifest: one group
    ok = ranking[(ranking["status"] == "ok") & np.isfinite(ranking["mse"].astype(float))]
    ok = ok[[variant_of(study, o) == variant for o in ok["optimizer"]]]
    if ok.empty:
        return
    cache: dict = {}
    problem = problem_for(study, ok["specimen"].iloc[0], shown, cache)
    heading = headings(problem)
    for material, group in ranking.groupby("material", sort=False):
        specimens = group.drop_duplicates("specimen").sort_values(["underpressure_MPa", "repeat", "specimen"])
        for title, names in column_groups(problem):
            rows = []
            for specimen in specimens["specimen"]:
                runs = ok[ok["specimen"] == specimen]
                if runs.empty:
                    continue
                first = group[group["specimen"] == specimen].iloc[0]
                label = (
                    specimen
                    if not np.isfinite(first["underpressure_MPa"])
                    else f"{first['underpressure_MPa']:g} MPa r{int(first['repeat'])}"
                )
                b = runs.loc[runs["mse"].idxmin()]
                rows.append(
                    {
                        "specimen": label,
                        "row": f"best: {b['optimizer']} seed {int(b['replicate'])}",
                        "MSE (N²)": number(b["mse"], 5),
                        **{heading[n]: number(b.get(n)) for n in names},
                    }
                )
                mine = runs[runs["optimizer"] == shown]
                rows.append(
                    {
                        "specimen": "",
                        "row": f"{shown}: {aggregate_label(len(mine))}",
                        "MSE (N²)": aggregate_text(mine["mse"]),
                        **{heading[n]: aggregate_text(mine[n]) if n in mine else "–" for n in names},
                    }
                )
                truth = switched_parameters.truth_params(study.specimen_path(specimen)) if paper else None
                if truth is not None:
                    truth_problem = problem_for(study, specimen, "paper", cache)
                    rows.append(
                        {
                            "specimen": "",
                            "row": "truth (synthetic)",
                            "MSE (N²)": number(float(truth_problem.loss_batch(truth[None, :])[0]), 5),
                            **{heading[n]: number(truth[PARAM_NAMES.index(n)]) for n in names},
                        }
                    )
            if rows:
                doc.table(pd.DataFrame(rows), f"{material}: {title}")
