"""The posterior section's nested-sampling subsection: the prior stated, the runs and their agreement,
the modes with their masses, every good ranking fit placed, and the evidence."""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.problems.hysteresis.report.posterior_draws import axis, parameters
from bwbench.problems.hysteresis.report.posterior_tables import (
    LEVEL,
    convergence_table,
    model_name,
    summary_against_truth,
    write_inference_data,
)
from bwbench.render.format import number

PRIOR_TEXT = (
    "The prior is uniform on the search box in the searched coordinates (log-uniform in a parameter whose box "
    "is logarithmic), so ln Z is the log of the likelihood's mean over the box: widening the box by a factor c "
    "in a parameter the data pin down lowers ln Z by ln c (doubling it: −0.69), and a direction the data "
    "cannot pin down shows as a marginal as wide as its box, not removed. The likelihood's constant (σ "
    "integrated out under Jeffreys' prior) is the same for every model of the same data: differences of "
    "ln Z between models of one specimen are meaningful, their absolute values are not."
)


def best_fit_text(pc) -> str | None:
    """Where the best ranking fit lies against a nested posterior, in a sentence; None without one."""
    place = pc.nested.best_fit_place
    if place is None:
        return None
    if place["where"] == "mode":
        return f"The best ranking fit lies in mode {place['mode'] + 1} of the posterior."
    if place["where"] == "below":
        return (
            f"The best ranking fit lies below the posterior's support by Δ log p = {place['delta']:.1f} "
            "(the sampler's draws are all more probable)."
        )
    return (
        "The best ranking fit lies where no draw goes (outside every draw, or more probable than any draw), at "
        "least as probable as the draws: the sampler missed a mode at least as probable as it."
    )


def good_fits_placed(study, pc) -> pd.DataFrame:
    """Every good ranking fit (``posterior_draws.good_fits``) against a nested posterior's draws
    (``nested.locate``): in which mode, or below the posterior's support by how much, or outside every
    draw while as probable (a mode the sampler missed)."""
    from bwbench.analysis import nested
    from bwbench.problems.hysteresis.report.posterior_draws import good_fits, in_coordinates, log_posterior

    rows = []
    for _, run in good_fits(study, pc.chain.specimen).sort_values("mse").iterrows():
        theta = in_coordinates(run.to_dict(), pc.problem)
        if theta is None:
            continue
        like = float(log_posterior(pc.problem, theta[None, :])[0])
        u = np.asarray(pc.problem.to_unit(theta[None, :]), dtype=float)[0]
        place = nested.locate(u, like, pc.chain.samples, pc.chain.log_prob, pc.nested)
        where = _where_text(place, _on_box_edge(pc.problem, u))
        rows.append(
            {
                "fit": f"{run['optimizer']}, seed {int(run['replicate']) + 1}",
                "MSE": number(float(run["mse"])),
                "log-likelihood": f"{like:.1f}",
                "where": where,
            }
        )
    return pd.DataFrame(rows)


def _where_text(place: dict, edge: str) -> str:
    """Where a good fit lies against a nested posterior (``nested.locate``'s ``place``), in words; ``edge``:
    the parameters it has on an edge of the box (``_on_box_edge``)."""
    if place["where"] == "mode":
        return f"mode {place['mode'] + 1}"
    if edge:
        return (
            f"on an edge of the prior's box ({edge}), where no draw goes: a search stopped by its box; "
            "whether the posterior holds mass in that sliver, its draws do not say"
        )
    if place["where"] == "below":
        return f"below the posterior's support by Δ log p = {place['delta']:.1f}"
    return "where no draw goes, as probable: the sampler missed a mode at least as probable as this fit"


def _on_box_edge(problem, u, tolerance: float = 1e-3) -> str:
    """The parameters of a point (unit coordinates ``u`` of ``problem``'s box) within ``tolerance`` of an
    edge of the box or beyond it, named with the edge; "" when it lies inside. A search stopped by its box
    ends there (a fit in another formulation, whose box differs, too): a sliver of the uniform prior the
    draws seldom reach: the report says so rather than "a missed mode"."""
    table = parameters(problem)
    return ", ".join(
        f"{axis(problem, n, table)} at its {'lower' if u[i] <= tolerance else 'upper'} edge"
        for i, n in enumerate(problem.param_names)
        if u[i] <= tolerance or u[i] >= 1 - tolerance
    )


def nested_modes_table(pc) -> pd.DataFrame:
    """One row per mode of a nested-sampling posterior: its mass with the run-to-run spread, its best
    log-likelihood and the median [central 95 % interval] of every parameter."""
    v, table = pc.nested, parameters(pc.problem)
    flat = pc.chain.samples.reshape(-1, pc.chain.samples.shape[2])
    rows = []
    for i, mode in enumerate(v["modes"]):
        P = pc.problem.from_unit(flat[mode.members])
        row = {
            "mode": i + 1,
            "mass": f"{mode.mass:.2f} ± {mode.spread:.2f}" if np.isfinite(mode.spread) else f"{mode.mass:.2f}",
            "best log-likelihood": f"{mode.best_log_like:.1f}",
        }
        for j, n in enumerate(pc.names):
            lo, mid, hi = np.quantile(P[:, j], [(1 - LEVEL) / 2, 0.5, 1 - (1 - LEVEL) / 2])
            row[axis(pc.problem, n, table)] = f"{number(mid, 3)} [{number(lo, 3)}, {number(hi, 3)}]"
        rows.append(row)
    return pd.DataFrame(rows)


def evidence_table(chains) -> pd.DataFrame:
    """``| specimen | model | ln Z | ± | ln B |``: each nested posterior's pooled ln Z, and the Bayes factor
    (log) against the best model of the same specimen."""
    from bwbench.analysis import nested

    rows = [
        {
            "specimen": pc.chain.specimen,
            "model": model_name(pc),
            "ln Z": pc.nested["evidence"]["log_z"],
            "±": pc.nested["evidence"]["err"],
        }
        for pc in chains
        if pc.nested is not None
    ]
    if not rows:
        return pd.DataFrame()
    frame = pd.DataFrame(rows)
    for _, group in frame.groupby("specimen", sort=False):
        factors = nested.bayes_factors(dict(zip(group.index, group["ln Z"])))
        frame.loc[group.index, "ln B against the best"] = [factors[i] for i in group.index]
    return frame


def nested_subsection(report, pc, rng, order):
    from bwbench.problems.hysteresis.report import posterior_figures
    from bwbench.problems.hysteresis.report.posterior_runs import box_block, verdict_block

    doc, study, chain, v = report.doc, report.study, pc.chain, pc.nested
    doc.h(3, f"{chain.specimen} ({chain.optimizer}, {pc.problem.formulation} formulation)")
    verdict_block(doc, pc)  # the verdict in one line first, then what it rests on
    ev = chain.evidence
    nfev = pc.run.get("nfev")
    wall = pc.run.get("wall_s")
    doc.p(
        f"{chain.walkers} independent runs × {chain.steps:,} equal-weight draws each"
        + (f"; {int(nfev):,} evaluations" if nfev == nfev and nfev else "")
        + (f" in {float(wall) / 60:.1f} min" if wall == wall and wall else "")
        + f"; ln Z per run: {', '.join(f'{z:.2f} ± {e:.2f}' for z, e in zip(ev['log_z'], ev['log_z_err']))}"
        + ("; effective draws per run: " + ", ".join(f"{e:,.0f}" for e in ev["run_ess"]) if ev.get("run_ess") else "")
        + "."
    )
    if v.diagnostics is not None:
        doc.table(convergence_table(pc), f"R̂ and ESS on each run's first {v.badge['draws']:,} draws (the badge)")
    placed_text = best_fit_text(pc)
    if placed_text:
        doc.p(placed_text)
    doc.table(
        nested_modes_table(pc),
        "Modes: posterior mass (± run-to-run spread), best log-likelihood, median "
        f"[central {LEVEL:.0%} interval] of each parameter",
    )
    placed = good_fits_placed(study, pc)
    if len(placed):
        doc.table(
            placed, "The good ranking fits (final MSE within 10 % of the best known) against the posterior's draws"
        )
    box_block(doc, pc, study, order)
    summary_against_truth(doc, study, pc, rng, f"Posterior medians and central {LEVEL:.0%} intervals over every mode")
    written = write_inference_data(pc, doc.out_dir)
    if written:
        doc.p(f"The draws in physical units, one chain per run, are in `{written}` (ArviZ InferenceData, netCDF).")
    png = posterior_figures.posterior(study, doc.out_dir, chain, problem=pc.problem, posterior=pc, order=order)
    doc.figure(
        png,
        f"{chain.specimen}: posterior marginals and the most correlated pairs, with the best fit on the "
        "specimen and the truth",
    )
    table = v.diagnostics
    return (
        chain,
        {
            "converged": v.converged,
            "steps": chain.steps,
            "worst_r_hat": float(table["r_hat"].max()) if table is not None else float("nan"),
            "min_ess": float(table["ess_bulk"].min()) if table is not None else float("nan"),
            "modes": len(v.modes),
            "line": v.line,
        },
    )
