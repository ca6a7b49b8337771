"""The posterior section's tables and what it writes: convergence per parameter, the summary against
the truth, the modes, the model's name, the draws as ArviZ InferenceData (netCDF)."""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.problems.hysteresis.report.posterior_draws import axis, parameters, truth
from bwbench.render.format import number

LEVEL = 0.95  # credible intervals: central 95 %


def convergence_table(pc) -> pd.DataFrame:
    """R̂, bulk and tail ESS of every parameter, one column group per mode; a parameter a reduced
    model held fixed says so."""
    table = parameters(pc.problem)
    rows = {n: {"parameter": axis(pc.problem, n, table)} for n in pc.names}
    several = len(pc.assessment["modes"]) > 1
    for i, diag in enumerate(pc.assessment["diagnostics"]):
        tag = f" (mode {i + 1})" if several else ""
        for r in diag.itertuples():
            rows[r.parameter].update(
                {
                    f"R̂{tag}": f"{r.r_hat:.3f}",
                    f"bulk ESS{tag}": f"{r.ess_bulk:,.0f}",
                    f"tail ESS{tag}": f"{r.ess_tail:,.0f}",
                }
            )
    for n in pc.fixed:
        value = pc.problem.from_unit(pc.chain.samples[:1, 0])[0][pc.names.index(n)]
        rows[n]["R̂"] = f"held at {number(float(value))} (reduced model)"
    return pd.DataFrame(list(rows.values())).fillna("")


def summary(pc, rng, true: dict | None) -> tuple[pd.DataFrame, list]:
    """Median and central 95 % interval of every parameter over the main mode's kept draws, the truth
    beside where there is one; and the names whose truth lies outside its interval."""
    draws = pc.draws(rng)
    table = parameters(pc.problem)
    rows, outside = [], []
    tail = (1 - LEVEL) / 2
    gauge = pc.problem.model.reduced_gauge(pc.fixed, pc.problem.state)
    for name, values in draws.items():
        values = values[np.isfinite(values)]
        if not values.size:
            continue
        lo, mid, hi = np.quantile(values, [tail, 0.5, 1 - tail])
        row = {
            "parameter": axis(pc.problem, name, table),
            "median": number(mid),
            "2.5 %": number(lo),
            "97.5 %": number(hi),
        }
        # held: by a reduced model, or by the problem itself (an unfitted inertia, a coefficient fixed)
        held = name in pc.fixed or np.ptp(values) == 0
        if held:
            row.update({"2.5 %": "held", "97.5 %": "held"})
        if true is not None and name in true:
            t = true[name]
            inside = held or name in gauge or lo <= t <= hi
            row.update(
                {
                    "truth": number(t),
                    "truth inside": "held fixed"
                    if held
                    else "not comparable (the reduced model's gauge)"
                    if name in gauge
                    else ("yes" if inside else "**no**"),
                }
            )
            if not inside:
                outside.append(name)
        rows.append(row)
    return pd.DataFrame(rows), outside


def modes_table(pc) -> pd.DataFrame:
    """One row per mode: its ensembles, median log-probability and the median of each sampled parameter."""
    table = parameters(pc.problem)
    rows = []
    for i, mode in enumerate(pc.assessment["modes"]):
        P = pc.problem.from_unit(pc.unit_draws(mode))
        row = {
            "mode": i + 1,
            "ensembles": ", ".join(str(e + 1) for e in mode.ensembles),
            "median log p": f"{mode.log_prob:.1f}",
        }
        row.update(
            {
                axis(pc.problem, n, table): number(float(np.median(P[:, j])), 3)
                for j, n in enumerate(pc.names)
                if n not in pc.fixed
            }
        )
        rows.append(row)
    return pd.DataFrame(rows)


def model_name(pc) -> str:
    model = getattr(pc.problem, "model", None)
    return str(getattr(model, "name", pc.chain.optimizer))


def write_inference_data(pc, out_dir) -> str | None:
    """The posterior's draws in physical units as an ArviZ InferenceData (netCDF) beside the report: one
    chain per run, equal weights; the log-likelihood in sample_stats. Returns the file name, or None
    when it cannot be written (no netCDF engine)."""
    from bwbench.threads import settle_numba_environment

    settle_numba_environment()  # ArviZ compiles numba code at import
    import arviz as az

    samples = pc.chain.samples  # (draws, runs, d)
    P = pc.problem.from_unit(samples.reshape(-1, samples.shape[2])).reshape(samples.shape)
    posterior = {n: np.swapaxes(P[:, :, j], 0, 1) for j, n in enumerate(pc.names)}
    stats = {} if pc.chain.log_prob is None else {"lp": np.swapaxes(pc.chain.log_prob, 0, 1)}
    data = az.from_dict(
        posterior=posterior,
        sample_stats=stats,
        attrs={
            "engine": "nested sampling (UltraNest)",
            "weights": "equal",
            "log_z": pc.nested["evidence"]["log_z"],
            "log_z_err": pc.nested["evidence"]["err"],
        },
    )
    name = f"posterior_{pc.chain.specimen}_{pc.chain.optimizer}".replace(" ", "_").replace("[", "").replace("]", "")
    path = f"{out_dir}/{name}.nc"
    try:
        data.to_netcdf(path)
    except (ImportError, ValueError, OSError):
        return None
    return f"{name}.nc"


def summary_against_truth(doc, study, pc, rng, caption: str) -> None:
    """The table of posterior medians and intervals, and where the truth (a synthetic specimen's) lies."""
    true = truth(study, pc.problem, pc.chain.specimen)
    table, outside = summary(pc, rng, true)
    doc.table(
        table,
        caption
        + (
            " (linear coefficients drawn from their conditional Gaussian)"
            if pc.problem.formulation == "identifiable"
            else ""
        ),
    )
    if true is not None:
        doc.p(
            "The truth lies inside every central 95 % interval."
            if not outside
            else f"The truth lies outside the central 95 % interval of {', '.join(outside)}."
        )
