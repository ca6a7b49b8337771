"""The report's held-out tests (``[validation] files`` or ``compare --validate``): how well each fit
predicts tests it never saw, every coefficient as stored (``fitted_model``), and the ranking of
(backend, model/formulation) by that error beside the ranking by training loss.

Held-out error of a run: the mean over the held-out files of NRMSE = RMSE / max|F measured| (a file
of 1 kN and one of 100 N count alike). Of a label: the median over its ranking runs (every training
specimen and seed), as the training ranking takes medians.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd

from bwbench.errors import UserError
from bwbench.render.format import number

FIGURE_TESTS = 4  # held-out tests drawn in the figure


def held_out_names(study) -> list[str]:
    return list((study.config.get("validation") or {}).keys())


def predictions_table(study) -> pd.DataFrame:
    """One row per (ranking run, held-out file): label, specimen (training), replicate, held_out, rmse_N,
    nrmse; NaN where the run found nothing finite, inf where its model blows up on the file."""
    from bwbench.data.specimen import read_specimen
    from bwbench.problems.hysteresis.fitted_model import FittedModel

    runs = study.ranking[study.ranking["status"] == "ok"]
    held = {name: read_specimen(study.specimen_path(name)) for name in held_out_names(study)}
    signals, rows = {}, []
    for _, run in runs.iterrows():
        params = json.loads(run["params_json"]) if isinstance(run.get("params_json"), str) else {}
        params = {k: math.nan if v is None else v for k, v in params.items()}
        try:
            fitted = FittedModel(
                run["model"] or "switched-bouc-wen",
                run["formulation"] or "paper",
                params,
                run.get("state") or None,
                run.get("excitation") or "measured",
            )
        except UserError:
            fitted = None
        for name, spec in held.items():
            row = {
                "label": run["optimizer"],
                "specimen": run["specimen"],
                "replicate": int(run["replicate"]),
                "held_out": name,
                "rmse_N": math.nan,
                "nrmse": math.nan,
            }
            if fitted is not None and math.isfinite(float(run["mse"])):
                key = (name, fitted.excitation)
                if key not in signals:
                    signals[key] = fitted.signal(spec)
                try:
                    force = fitted.force(signals[key])
                except UserError:  # a branch the fit never saw
                    force = np.full(spec.n_samples, np.inf)
                with np.errstate(over="ignore", invalid="ignore"):
                    rmse = float(np.sqrt(np.mean((force - spec.f) ** 2)))
                rmse = rmse if math.isfinite(rmse) else math.inf
                row.update(rmse_N=rmse, nrmse=rmse / float(np.max(np.abs(spec.f))))
            rows.append(row)
    return pd.DataFrame(rows)


def ranking(report, table: pd.DataFrame) -> pd.DataFrame:
    """Per label: training median RMSE (N), held-out median NRMSE and RMSE, both ranks."""
    per_run = table.groupby(["label", "specimen", "replicate"], sort=False).agg(
        nrmse=("nrmse", "mean"), rmse_N=("rmse_N", "mean")
    )
    held = per_run.groupby(level="label").agg(nrmse=("nrmse", "median"), rmse=("rmse_N", "median"))
    ranking_runs = report.study.ranking[report.study.ranking["status"] == "ok"]
    train = ranking_runs.groupby("optimizer")["mse"].median().map(lambda m: math.sqrt(float(m)))
    labels = [o for o in report.table["optimizer"] if o in held.index]
    out = pd.DataFrame(
        {
            "label": labels,
            "train": [train.get(o, math.nan) for o in labels],
            "held_nrmse": [held.loc[o, "nrmse"] for o in labels],
            "held_rmse": [held.loc[o, "rmse"] for o in labels],
        }
    )
    out["rank_train"] = out["train"].rank(method="min", na_option="bottom").astype(int)
    out["rank_held"] = out["held_nrmse"].rank(method="min", na_option="bottom").astype(int)
    return out.sort_values(["rank_held", "rank_train"]).reset_index(drop=True)


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
    doc.table(
        shown,
        "Ranked by held-out prediction error (NRMSE = RMSE / max|F|), with the training ranking beside; "
        "every run is in held_out.csv",
    )
    best, by_train = ranked.iloc[0], ranked.sort_values("rank_train").iloc[0]
    same = best["label"] == by_train["label"]
    doc.p(
        f"By held-out error the best is **{best['label']}** (median NRMSE {number(best['held_nrmse'], 3)})"
        + (
            ", which is also the best by training loss."
            if same
            else f"; by training loss it would be **{by_train['label']}** (median held-out NRMSE "
            f"{number(by_train['held_nrmse'], 3)}): choose by the error on tests the fit did not see."
        )
    )
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
    mine = table[table["label"] == label].groupby(["specimen", "replicate"], sort=False)["nrmse"].mean()
    specimen, replicate = mine.idxmin()
    runs = study.ranking
    run = runs[(runs["optimizer"] == label) & (runs["specimen"] == specimen) & (runs["replicate"] == replicate)].iloc[0]
    params = {k: math.nan if v is None else v for k, v in json.loads(run["params_json"]).items()}
    fitted = FittedModel(
        run["model"] or "switched-bouc-wen",
        run["formulation"] or "paper",
        params,
        run.get("state") or None,
        run.get("excitation") or "measured",
    )
    predictions = [fitted.predict(read_specimen(study.specimen_path(n))) for n in names[:FIGURE_TESTS]]
    fig = draw_predictions(predictions, f"{label}, fitted to {specimen} (seed {replicate}): held-out tests predicted")
    frame = pd.concat([p.frame().assign(held_out=p.specimen) for p in predictions], ignore_index=True)
    return save(fig, report.out, f"held_out_{slug(label)}", frame, report.problem_type.is_synthetic(study))
