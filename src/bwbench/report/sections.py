"""The report's sections every problem has: what was compared, the ranking, the run figures, limits."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from bwbench.analysis import statistics
from bwbench.render import ecdf_figures, figures, waterfall
from bwbench.render.floors import noise_floors
from bwbench.render.format import evals_text, number, p_text
from bwbench.render.palette import split_label
from bwbench.report.recommend import ALPHA, ratio_text, rule
from bwbench.report.verdict import TARGET
from bwbench.store.timing import compute_time


def backends_table(study) -> pd.DataFrame:
    """One row per ranking backend: its family, the options it ran with, and its median wall time
    and evaluations per run."""
    backends = study.backends  # family and calling style, as the runner recorded them
    ranking = study.ranking
    wall = ranking.groupby("optimizer")["wall_s"].median() if "wall_s" in ranking else pd.Series(dtype=float)
    nfev = ranking.groupby("optimizer")["nfev"].median()
    rows = []
    for name in study.optimizers:
        base = split_label(name)[0]  # "cmaes [identifiable]" ran the backend "cmaes" (study.tasks.run_label)
        options = study.config.get("optimizers", {}).get(base, {})
        backend = backends.get(base, {})
        batched = backend.get("batched")
        rows.append(
            {
                "backend": name,
                "family": backend.get("family", "–"),
                "evaluates": "–" if batched is None else ("populations" if batched else "one point per call"),
                "options": ", ".join(f"{k}={json.dumps(v)}" for k, v in options.items()) or "defaults",
                "median wall time per run (s)": number(wall.get(name), 3),
                "median evaluations": evals_text(nfev.get(name)),
            }
        )
    return pd.DataFrame(rows)


def setup(report) -> None:
    study, doc = report.study, report.doc
    s = study.settings
    budget = s.get("budget", "?")
    problem_text = report.problem_type.setup_text(report)
    doc.h(2, "What was compared")
    doc.p(
        f"Study **{study.name}** (database `{study.path.name}`, bwbench {study.meta.get('bwbench_version', '?')}, "
        f"created {study.meta.get('created_utc', '?')}). Problem: {study.problem_type.description}. Every backend "
        f"had the same budget of **{budget} evaluations** per run (one evaluation = one simulation of one "
        f"parameter vector), {s.get('seeds', '?')} seeds per (specimen, backend), study seed {s.get('seed', '?')}."
        + (" " + problem_text if problem_text else "")
    )
    took = _compute_time_text(study)
    if took:
        doc.p(took)
    doc.table(
        backends_table(study), "Backends and their options (as run), with the wall time of their runs (one core each)"
    )
    post = study.config.get("posterior")
    if post:
        samplers = post.get("optimizer")
        samplers = " and ".join(samplers) if isinstance(samplers, list) else samplers
        doc.p(
            f"Posterior sampling (not part of the ranking): {samplers} on "
            f"{', '.join(post.get('specimens', []))}, budget {post.get('budget')} evaluations, "
            f"{post.get('seeds')} seed(s), options {json.dumps(post.get('options', {}))}."
        )


def _compute_time_text(study) -> str:
    """ "Computed in 41.2 min …": elapsed over the runner's sessions, core-hours, and the machine."""
    took = compute_time(study.runs)
    if took is None:
        return ""
    sessions = (
        "one session" if took.sessions == 1 else f"{took.sessions} sessions (the idle time between them left out)"
    )
    machine = study.meta.get("machine")
    elapsed = f"{number(took.elapsed_s, 3)} s" if took.elapsed_s < 120 else f"{number(took.elapsed_s / 60, 3)} min"
    return (
        f"Computed in **{elapsed}** elapsed, first run start to last run end, in "
        f"{sessions}; {number(took.core_s / 3600, 3)} core-hours of runs"
        + (f", on {machine}" if machine else "")
        + ". Writing this report is not included."
    )


def recommendation(report) -> None:
    """The answer first, in a box a reader takes in at a glance; then the rule, then the paragraph
    that applies it with its statistics."""
    doc, decision = report.doc, report.decision
    doc.h(2, "Recommendation")
    provisional = report.study.provisional
    if provisional:
        doc.p(f"**{provisional[0].upper()}{provisional[1:]}**: the study is unfinished; this may change.")
    doc.box(decision.box())
    doc.h(2, "How the recommendation is decided")
    doc.p(
        "The rule below is fixed in the code (`bwbench.report.verdict`) and applied to every study the same "
        "way; its thresholds are constants, not fitted to this study."
    )
    doc.bullets(rule(report.tests.test_name, report.noun))
    doc.h(2, "The rule applied to this study")
    doc.p(decision.text)


def ranking_frame(report) -> pd.DataFrame:
    """The ranking table as shown: the rule's order, its verdict, both views, and the cost."""
    table, verdict, unit = report.table, report.verdict, report.study.problem_type.residual_unit
    one = report.tests.n_specimens == 1

    def count(row, tau):
        return f"{int(round(row[f'success_{tau:.0%}'] * row['runs']))}/{int(row['runs'])}"

    shown = pd.DataFrame(
        {
            "label": table["optimizer"],
            "verdict": [verdict.role(n) for n in table["optimizer"]],
            "failed runs": table["errors"],
            **{f"success ≤{tau:.0%}": [count(r, tau) for _, r in table.iterrows()] for tau in statistics.TOLERANCES},
            **{f"ERT {tau:.0%} (evals)": table[f"ert_{tau:.0%}"].map(evals_text) for tau in statistics.TOLERANCES},
            "ms per evaluation": (1000 * table["s_per_eval"]).map(lambda x: number(x, 2)),
            f"expected time to {TARGET:.0%} (s)": table[f"time_{TARGET:.0%}"].map(lambda x: number(x, 2)),
            "median final loss / best known": table["median_ratio"].map(
                lambda x: f"{x:.3f}" if x < 10 else number(x, 3)
            ),
            **({f"median RMSE ({unit})": table["median_rmse_N"].map(lambda x: number(x, 3))} if one else {}),
            f"mean rank (ties within {statistics.TIE:.0%})": table["mean_rank"].map(lambda x: number(x, 3)),
        }
    )
    extra = report.problem_type.ranking_columns(report, table)
    for name, values in extra.items():
        shown[name] = list(values)
    return shown


def per_specimen_rmse(report) -> pd.DataFrame:
    """Median RMSE over the seeds of each label (rows) on each specimen (columns)."""
    ranking = report.study.ranking
    rmse = np.sqrt(statistics.final_mse(ranking))
    frame = ranking.assign(rmse=rmse.to_numpy()).pivot_table(
        index="optimizer", columns="specimen", values="rmse", aggfunc="median"
    )
    frame = frame.loc[[n for n in report.table["optimizer"] if n in frame.index]]
    return frame.map(lambda x: number(x, 3)).reset_index().rename(columns={"optimizer": "label"})


def comparisons_frame(report) -> pd.DataFrame:
    """Every comparison the rule used, one family after another (comparisons.csv)."""
    verdict = report.verdict
    frames = [f for f in (verdict.vs_reference, verdict.vs_baseline, verdict.by_variant) if f is not None and len(f)]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


def verdict_frame(report) -> pd.DataFrame:
    """Per candidate: its comparison with the reference and with the baseline, and its worst
    success deficit."""
    verdict = report.verdict
    ref = verdict.vs_reference.set_index("a") if verdict.vs_reference is not None else pd.DataFrame()
    base = verdict.vs_baseline.set_index("a") if verdict.vs_baseline is not None else pd.DataFrame()
    # each candidate is compared with random search on its own variant
    base_column = (
        f"final loss / {verdict.baselines[0]}'s [95 % CI]"
        if len(verdict.baselines) == 1
        else "final loss / random search's on its variant [95 % CI]"
    )
    rows = []
    for label in verdict.candidates:
        row = {"label": label, "verdict": verdict.role(label)}
        if label in ref.index:
            r = ref.loc[label]
            specimen, gap = verdict.deficit.get(label, (None, np.nan))
            row.update(
                {
                    f"final loss / {verdict.reference}'s [95 % CI]": ratio_text(r),
                    "p": p_text(r["p"]),
                    "Holm p": p_text(r["p_holm"]),
                    "largest success deficit": f"{gap * 100:.0f} points on {specimen}" if specimen else "–",
                }
            )
        else:
            row[f"final loss / {verdict.reference}'s [95 % CI]"] = "reference"
        if label in base.index:
            b = base.loc[label]
            row.update(
                {
                    base_column: ratio_text(b) if len(verdict.baselines) == 1 else f"{ratio_text(b)} ({b['b']})",
                    "Holm p (baseline)": p_text(b["p_holm"]),
                }
            )
        rows.append(row)
    columns = [
        "label",
        "verdict",
        f"final loss / {verdict.reference}'s [95 % CI]",
        "p",
        "Holm p",
        "largest success deficit",
    ]
    if len(base):
        columns += [base_column, "Holm p (baseline)"]
    return pd.DataFrame(rows, columns=columns).astype(object).fillna("–")


def variant_frame(report) -> pd.DataFrame:
    frame = report.verdict.by_variant
    noun, ref = report.noun, report.verdict.reference_variant
    return pd.DataFrame(
        {
            "backend": frame["backend"],
            noun: frame["variant"],
            f"final loss / {ref}'s [95 % CI]": [ratio_text(r) for r in frame.to_dict("records")],
            "p": frame["p"].map(p_text),
            "Holm p": frame["p_holm"].map(p_text),
            "significant": np.where(frame["significant"], "yes", ""),
        }
    )


def ranking(report) -> None:
    study, doc = report.study, report.doc
    budget = study.settings.get("budget", "?")
    doc.h(2, "Ranking")
    doc.table(
        ranking_frame(report),
        f"Every label at a budget of {budget} evaluations, in the rule's order "
        "(success at the 1 % target, then mean rank, then ERT in evaluations, then name)",
    )
    doc.p(
        "Success at τ: the run's best loss came within (1 + τ) × the best known loss of its specimen (the lowest "
        "of any run in this database, ranking or posterior). ERT (expected running time, COCO definition) = "
        "evaluations spent by all runs (evaluations to target for the successful ones, all their evaluations for "
        "the others) / number of successful runs, pooled over specimens; ∞ = no run succeeded. Seconds per "
        "evaluation: all wall time of the label's runs / all their evaluations, one core each; equal evaluations "
        "do not cost equal time (stiff parameter sets need more integration substeps, a backend's own work "
        "counts too). Mean rank: on each specimen the labels are ranked by their median final loss, losses "
        f"within {statistics.TIE:.0%} of each other sharing a rank (round-off does not order them)."
    )
    if 1 < report.tests.n_specimens <= 8:
        doc.table(
            per_specimen_rmse(report),
            f"The median RMSE ({study.problem_type.residual_unit}) over the seeds "
            "of each label, per specimen: specimens of different force levels are "
            "not pooled into one median",
        )
    omnibus = report.omnibus
    if np.isfinite(omnibus.pvalue):
        doc.p(
            f"{report.tests.omnibus_name} over {report.tests.omnibus_design}: statistic = {omnibus.statistic:.3g}, "
            f"**p = {p_text(omnibus.pvalue)}** (descriptive: the rule does not use it)."
        )
    else:
        doc.p(f"{omnibus.note}.")
    if report.verdict.candidates:
        doc.table(
            verdict_frame(report),
            f"The comparisons the rule used: each candidate against the reference "
            f"({report.verdict.reference}) and against the baseline, Hodges–Lehmann "
            "ratios of final losses with 95 % bootstrap intervals, p from "
            f"{report.tests.test_name}, Holm within each family (every number in "
            "comparisons.csv)",
        )
    if report.noun:
        doc.table(
            variant_frame(report),
            f"The effect of the {report.noun} on each backend: final losses in each "
            f"{report.noun} over those in the {report.verdict.reference_variant} "
            f"{report.noun} (< 1: lower), Holm over these comparisons",
        )


def run_figures(report) -> None:
    study, doc, out = report.study, report.doc, report.out
    doc.h(2, "Figures")
    floors = noise_floors(study, report.featured)
    order = list(report.table["optimizer"])
    png = figures.convergence(study, out, report.featured, floors=floors, order=order)
    drawn = pd.read_csv(png.with_suffix(".csv"))
    bands = (
        int(drawn.loc[drawn["band"]].groupby("variant", dropna=False)["optimizer"].nunique().max())
        if drawn["band"].any()
        else 0
    )
    doc.figure(
        png,
        "Convergence: median over seeds of the best-so-far loss relative to "
        + ("the noise floor" if floors else "the best known loss")
        + (
            " (where it is one: the truth's MSE within 1.25× of the stated noise variance; elsewhere the best "
            "known loss)"
            if floors
            else ""
        )
        + (f"; interquartile band for the best {bands}" + (" of each column" if report.noun else "") if bands else ""),
    )
    doc.figure(
        ecdf_figures.runtime_distributions(study, out, order=order, noun=report.noun),
        f"Runtime distributions. Left, fixed target: the fraction of (run, target) pairs reached within x "
        f"evaluations, {len(ecdf_figures.ECDF_TAUS)} targets log-spaced from 0.1 % to 100× above the best "
        "known loss of the specimen. Right, fixed budget: the fraction of runs whose final loss is within x "
        "of the best known"
        + (f"; one row per {report.noun}" if report.noun else "")
        + f"; the best {ecdf_figures.HIGHLIGHT} labels of each panel in colour when it has more than "
        f"{ecdf_figures.MAX_COLOURED}, random search dark grey, the others light grey",
    )
    # One panel per specimen reads well up to a handful; beyond, the featured ones (all in the CSV).
    many = len(study.specimens) > len(report.featured) + 1
    doc.figure(
        waterfall.waterfall(study, out, order=order, specimens=report.featured if many else None),
        "Waterfall: the final loss of every ranking run, per specimen, sorted per backend"
        + (
            f" — on the {len(report.featured)} featured specimens of {len(study.specimens)} (every run of "
            "every specimen in the CSV)"
            if many
            else ""
        ),
    )


def limits(report) -> None:
    study, doc = report.study, report.doc
    s = study.settings
    n_spec = len(study.specimens)
    unit = (
        "the runs of each label are independent samples on one specimen, so the comparisons say how the "
        "backends do on this data set, not on others"
        if n_spec == 1
        else "the specimens are the blocks of every comparison: the verdict holds for these specimens"
        + ("; with so few it need not carry over to others" if n_spec < 6 else "")
    )
    items = [
        f"{n_spec} specimen{'s' if n_spec != 1 else ''} and {s.get('seeds', '?')} seeds per label; {unit}.",
        f"One budget ({s.get('budget', '?')} evaluations): the ranking can change at another budget "
        "(see the ECDF and convergence figures for how each backend would do with less).",
        "The best known loss is the best found in this database, not the global optimum; success rates and "
        "ERT are relative to it.",
    ]
    items += report.problem_type.limits(report)
    omnibus = report.omnibus
    if np.isfinite(omnibus.pvalue) and omnibus.pvalue >= ALPHA:
        items.append(
            f"The {report.tests.omnibus_name} does not reject equal performance (p = {p_text(omnibus.pvalue)})."
        )
    doc.h(2, "Limits of this study")
    doc.bullets(items)
