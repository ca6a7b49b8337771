"""The report's held-out tests (``[validation] files`` or ``compare --validate``): how well each fit
predicts tests it never saw, every coefficient as stored (``fitted_model``), and the ranking of
(backend, model/formulation) by that error beside the ranking by training loss.

Held-out error of a run: the mean over the held-out files of NRMSE = RMSE / max|F measured| (a file
of 1 kN and one of 100 N count alike). Of a label: the median over its ranking runs (every training
specimen and seed), as the training ranking takes medians.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from bwbench.errors import UserError
from bwbench.render.format import number

FIGURE_TESTS = 4  # held-out tests drawn in the figure


def held_out_names(study) -> list[str]:
    return list((study.config.get("validation") or {}).keys())


def start_of(study) -> dict:
    """How the study started every record (its [study] initial_state and warmup_s; the defaults when absent)."""
    settings = study.settings or {}
    return {"initial_state": settings.get("initial_state", "auto"), "warmup_s": settings.get("warmup_s", 0.0)}


def predictions_table(study) -> pd.DataFrame:
    """One row per (ranking run, held-out file): label, specimen (training), replicate, held_out, rmse_N,
    nrmse and ``failure``: "" for a prediction, else why there is none (the run found nothing finite,
    its parameters make no model, the model blows up on the file: then rmse_N is inf)."""
    from bwbench.data.specimen import read_specimen
    from bwbench.problems.hysteresis.fitted_model import FittedModel

    runs = study.ranking
    held = {name: read_specimen(study.specimen_path(name)) for name in held_out_names(study)}
    signals, rows = {}, []
    for _, run in runs.iterrows():
        fitted, failure = None, ""
        if run["status"] != "ok":
            failure = "the run failed (an error)"
        elif not math.isfinite(float(run["mse"])):
            failure = "the fit found nothing finite"
        else:
            try:
                fitted = FittedModel.from_run(run, start_of(study))
            except UserError as err:
                failure = f"its parameters make no model: {err}"
        for name, spec in held.items():
            row = {
                "label": run["optimizer"],
                "specimen": run["specimen"],
                "replicate": int(run["replicate"]),
                "held_out": name,
                "rmse_N": math.nan,
                "nrmse": math.nan,
                "failure": failure,
            }
            if fitted is not None:
                key = (name, fitted.excitation)
                if key not in signals:
                    signals[key] = fitted.signal(spec)
                try:
                    force = fitted.force(signals[key])
                except UserError as err:  # a branch the fit never saw
                    force = np.full(spec.n_samples, np.inf)
                    row["failure"] = str(err)
                with np.errstate(over="ignore", invalid="ignore"):
                    rmse = float(np.sqrt(np.mean((force - spec.f) ** 2)))
                if not math.isfinite(rmse):
                    rmse = math.inf
                    row["failure"] = row["failure"] or "the model blows up on this test"
                row.update(rmse_N=rmse, nrmse=rmse / float(np.max(np.abs(spec.f))))
            rows.append(row)
    return pd.DataFrame(rows)


def ranking(report, table: pd.DataFrame) -> pd.DataFrame:
    """Per label of the study's ranking (every one, none dropped): training median RMSE (N), held-out
    median NRMSE and RMSE over the runs that predicted, both ranks, and ``failed``: how many runs gave
    no prediction and why (the first reason)."""
    per_run = table.groupby(["label", "specimen", "replicate"], sort=False).agg(
        nrmse=("nrmse", "mean"), rmse_N=("rmse_N", "mean"), failure=("failure", "first")
    )
    ranking_runs = report.study.ranking[report.study.ranking["status"] == "ok"]
    train = ranking_runs.groupby("optimizer")["mse"].median().map(lambda m: math.sqrt(float(m)))
    rows = []
    for label in report.table["optimizer"]:
        mine = per_run.loc[label] if label in per_run.index.get_level_values("label") else per_run.iloc[:0]
        failed = mine[mine["failure"] != ""]
        predicted = mine[mine["failure"] == ""]
        rows.append(
            {
                "label": label,
                "train": train.get(label, math.nan),
                "held_nrmse": float(predicted["nrmse"].median()) if len(predicted) else math.nan,
                "held_rmse": float(predicted["rmse_N"].median()) if len(predicted) else math.nan,
                "runs": len(mine),
                "failed": len(failed),
                "why": str(failed["failure"].iloc[0]) if len(failed) else "",
            }
        )
    out = pd.DataFrame(rows)
    out["rank_train"] = out["train"].rank(method="min", na_option="bottom").astype(int)
    out["rank_held"] = out["held_nrmse"].rank(method="min", na_option="bottom").astype(int)
    return out.sort_values(["rank_held", "rank_train"], kind="stable").reset_index(drop=True)


# Held-out errors within this share of the best are one prediction, not a ranking: the box decides.
HELD_OUT_TIE = 0.01


def conclusion(ranked: pd.DataFrame, choice: str | None) -> str:
    """The held-out verdict in words, read against the recommendation's ``choice``: the best by held-out
    error (with those within ``HELD_OUT_TIE`` of it), whether it agrees with the box, and, where it does
    not, in one sentence why the two answers differ."""
    ok = ranked[np.isfinite(ranked["held_nrmse"].astype(float))]
    if not len(ok):
        return "No run predicted the held-out tests: every fit failed on them (see the table for why)."
    best = ok.iloc[0]
    level = float(best["held_nrmse"])
    tied = list(ok.loc[ok["held_nrmse"] <= level * (1 + HELD_OUT_TIE), "label"])
    text = f"By held-out error the best is **{best['label']}** (median NRMSE {number(level, 3)})"
    if len(tied) > 1:
        text = (
            f"By held-out error {', '.join(f'**{n}**' for n in tied)} predict alike (median NRMSE within "
            f"{HELD_OUT_TIE:.0%} of {number(level, 3)})"
        )
    if choice is None:
        return text + "."
    if choice in tied:
        return text + f": this agrees with the recommendation ({choice})."
    mine = ranked.set_index("label").loc[choice] if choice in set(ranked["label"]) else None
    if mine is None or not np.isfinite(float(mine["held_nrmse"])):
        return (
            text + f"; the recommended {choice} gave no held-out prediction"
            f"{' (' + mine['why'] + ')' if mine is not None and mine['why'] else ''}: the recommendation is about "
            "reaching the best training loss, this table about predicting tests no fit saw."
        )
    factor = float(mine["held_nrmse"]) / level
    return (
        text + f"; the recommended {choice} predicts them at {number(float(mine['held_nrmse']), 3)} "
        f"({number(factor, 3)}× the best): the recommendation ranks by how reliably and fast a backend reaches "
        f"the best training loss, this table by how well the fits predict tests no fit saw — where prediction "
        f"is the aim, prefer {best['label']}."
    )


def section(report) -> None:
    """The held-out section; nothing when the study has no held-out tests."""
    names = held_out_names(report.study)
    if not names:
        return
    doc, study = report.doc, report.study
    report.progress("held-out tests")
    doc.h(2, "Held-out tests: predicting what no fit saw")
    missing = [n for n in names if not study.specimen_path(n).is_file()]
    if missing:
        doc.p(
            f"The held-out file(s) {', '.join(missing)} are not where the study found them: no held-out check "
            "(give `report --data` the folder they are in)."
        )
        return
    table = predictions_table(study)
    from bwbench.data.output_paths import write_frame

    write_frame(table, report.out / "held_out.csv", index=False)
    ranked = ranking(report, table)
    doc.p(
        f"Every ranking run's fit predicts the {len(names)} held-out test(s) ({', '.join(names)}), never fitted, "
        "with every coefficient as stored — the linear coefficients of the identifiable formulation included, "
        "nothing refitted (`bwbench predict`). Held-out error of a run: the mean over the held-out tests of "
        "NRMSE = RMSE / max|F measured|; of a label: the median over its runs. A fit that is good on its own test "
        "and poor here has learnt that test, not the specimen."
    )
    shown = pd.DataFrame(
        {
            "backend [variant]": ranked["label"],
            "training: median RMSE (N)": ranked["train"].map(number),
            "held-out: median NRMSE (–)": ranked["held_nrmse"].map(lambda x: number(x, 3)),
            "held-out: median RMSE (N)": ranked["held_rmse"].map(number),
            "rank by held-out error": ranked["rank_held"],
            "rank by training loss": ranked["rank_train"],
        }
    )
    if ranked["failed"].any():  # a failure is shown as one, with its reason, never as a bare "–"
        shown["runs without a prediction"] = [
            f"{f} of {n}: {why}" if f else "none" for f, n, why in zip(ranked["failed"], ranked["runs"], ranked["why"])
        ]
    doc.table(
        shown,
        "Ranked by held-out prediction error (NRMSE = RMSE / max|F|), with the training ranking beside; "
        "every run is in held_out.csv",
    )
    doc.p(conclusion(ranked, report.decision.choice))
    predicted = ranked[np.isfinite(ranked["held_nrmse"].astype(float))]
    if not len(predicted):
        return
    best = predicted.iloc[0]
    png = _figure(report, table, best["label"], names)
    doc.figure(
        png,
        f"Held-out tests predicted by the best run of {best['label']} (lowest mean held-out NRMSE), "
        "against the measured force; the residual over time with its RMSE and NRMSE",
    )


def _figure(report, table, label, names):
    """Predicted against measured loops of the held-out tests, by the best run of ``label``."""
    from bwbench.data.specimen import read_specimen
    from bwbench.problems.hysteresis.fitted_model import FittedModel
    from bwbench.problems.hysteresis.report.prediction_figures import draw_predictions
    from bwbench.render.palette import save, slug

    study = report.study
    mine = table[(table["label"] == label) & (table["failure"] == "")]
    mine = mine.groupby(["specimen", "replicate"], sort=False)["nrmse"].mean()
    specimen, replicate = mine.idxmin()
    runs = study.ranking
    run = runs[(runs["optimizer"] == label) & (runs["specimen"] == specimen) & (runs["replicate"] == replicate)].iloc[0]
    fitted = FittedModel.from_run(run, start_of(study))
    predictions = [fitted.predict(read_specimen(study.specimen_path(n))) for n in names[:FIGURE_TESTS]]
    fig = draw_predictions(predictions, f"{label}, fitted to {specimen} (seed {replicate}): held-out tests predicted")
    frame = pd.concat([p.frame().assign(held_out=p.specimen) for p in predictions], ignore_index=True)
    return save(fig, report.out, f"held_out_{slug(label)}", frame, report.problem_type.is_synthetic(study))
