"""Short reprs and notebook HTML of the API's objects: a fit, a fitted model, a prediction, a study.

A repr is one line of what matters (model, formulation, errors); the HTML adds a small table. The
long parts (every parameter, every run) are one call away: ``summary()``, ``params``, ``runs``.
"""

from __future__ import annotations

import html
import math


def _g(x, digits: int = 4) -> str:
    return f"{x:.{digits}g}" if isinstance(x, (int, float)) and math.isfinite(x) else "–"


def table_html(rows, header=None) -> str:
    """A small HTML table of rows of cells (escaped)."""
    head = "" if header is None else "<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>"
    body = "".join("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in row) + "</tr>" for row in rows)
    return f"<table>{head}{body}</table>"


def fit_repr(fit) -> str:
    p, r = fit.problem, fit.result
    files = ", ".join(f"{f['specimen']} RMSE {_g(f['rmse_N'])} N" for f in fit.files)
    return (
        f"<FitResult {p.model.name} {p.formulation} by {r.optimizer}, {r.nfev} evaluations: {files}; "
        f"{len(fit.notes)} notes; .summary(), .report(), .plot()>"
    )


def fit_html(fit) -> str:
    p, r = fit.problem, fit.result
    title = (
        f"<b>FitResult</b>: {html.escape(p.model.name)} ({html.escape(p.formulation)} formulation), "
        f"{html.escape(r.optimizer)}, {r.nfev} of {r.budget} evaluations"
    )
    files = table_html(
        [(f["specimen"], f["n"], _g(f["rmse_N"]), _g(f["nrmse"], 3)) for f in fit.files],
        ["specimen", "samples", "RMSE (N)", "NRMSE"],
    )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in fit.notes)
    return (
        f"<div>{title}{files}"
        + (f"<ul>{notes}</ul>" if notes else "")
        + "<small>.summary() for every parameter with its standard error</small></div>"
    )


def model_repr(model) -> str:
    return f"<FittedModel {model.describe()}: {len(model.params)} parameters; .predict(file), .simulate(file)>"


def model_html(model) -> str:
    rows = [(n, _g(v, 6), model.units.get(n, "")) for n, v in model.params.items() if n in model.needed()]
    return (
        f"<div><b>FittedModel</b>: {html.escape(model.describe())}"
        + table_html(rows, ["parameter", "value", "unit"])
        + "</div>"
    )


def prediction_repr(p) -> str:
    return f"<Prediction {p.specimen}: {p.n} samples, RMSE {_g(p.rmse_N)} N, NRMSE {_g(p.nrmse, 3)}; .frame(), .plot()>"


def prediction_html(p) -> str:
    return (
        f"<div><b>Prediction</b> of {html.escape(p.specimen)}: "
        + table_html(
            [(p.n, _g(p.rmse_N), _g(p.nrmse, 3), _g(float(max(abs(p.measured_N))), 4))],
            ["samples", "RMSE (N)", "NRMSE", "max |F measured| (N)"],
        )
        + "</div>"
    )
