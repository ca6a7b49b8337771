"""The report's posterior section, for any model: a long MCMC run, its convergence by ArviZ mode by
mode, what the sampler did (starts, a reduced model), the credible intervals against the truth, and
the posterior predictive band on the loops.

A chain of the identifiable formulation samples the hysteretic parameters with the linear
coefficients integrated out analytically (``marginal.log_marginal``); the linear coefficients are then
drawn exactly from their conditional Gaussian for each kept sample (``marginal.draw_linear``), so the
summary covers all of them. A chain of a direct formulation samples its parameters directly.
Parameter names, labels and units come from the problem (``posterior_draws``).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import mcmc
from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs
from bwbench.problems.switched_vpp.posterior_draws import axis, cached, parameters, truth
from bwbench.report.format import number

R_HAT_MAX, ESS_MIN = mcmc.R_HAT_MAX, mcmc.ESS_MIN
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
            rows[r.parameter].update({f"R̂{tag}": f"{r.r_hat:.3f}", f"bulk ESS{tag}": f"{r.ess_bulk:,.0f}",
                                      f"tail ESS{tag}": f"{r.ess_tail:,.0f}"})
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
        row = {"parameter": axis(pc.problem, name, table), "median": number(mid), "2.5 %": number(lo),
               "97.5 %": number(hi)}
        # held: by a reduced model, or by the problem itself (an unfitted inertia, a coefficient fixed)
        held = name in pc.fixed or np.ptp(values) == 0
        if held:
            row.update({"2.5 %": "held", "97.5 %": "held"})
        if true is not None and name in true:
            t = true[name]
            inside = held or name in gauge or lo <= t <= hi
            row.update({"truth": number(t), "truth inside": "held fixed" if held else
                        "not comparable (the reduced model's gauge)" if name in gauge else
                        ("yes" if inside else "**no**")})
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
        row = {"mode": i + 1, "ensembles": ", ".join(str(e + 1) for e in mode.ensembles),
               "median log p": f"{mode.log_prob:.1f}"}
        row.update({axis(pc.problem, n, table): number(float(np.median(P[:, j])), 3)
                    for j, n in enumerate(pc.names) if n not in pc.fixed})
        rows.append(row)
    return pd.DataFrame(rows)


def section(report) -> list:
    from bwbench.problems.switched_vpp import figures

    doc, study = report.doc, report.study
    chains = cached(report)
    if not chains:
        return []
    doc.h(2, "Posterior sampling")
    doc.p("A long emcee run per specimen, kept out of the ranking. In the identifiable formulation it samples the "
          "hysteretic parameters with the linear coefficients integrated out analytically (flat prior on the "
          "coefficients of the fixed signals, the scale-free g-prior on those of the hysteretic column, so the "
          "arbitrary scale of w does not weigh in) and σ under Jeffreys' prior; the prior on the hysteretic "
          "parameters is uniform on the search box (log-uniform where the box is). The linear coefficients are then "
          "drawn exactly from their conditional Gaussian for each kept sample. The sampler starts independent "
          "ensembles around distinct good optima of independent local searches and stops when converged or when "
          "its budget ends. Convergence by ArviZ: rank-normalised split-R̂ and bulk and tail effective sample "
          "sizes, each walker taken as a chain, the first half of the chain dropped as burn-in, mode by mode "
          f"(ensembles that settled in different regions are not pooled); converged when R̂ ≤ {R_HAT_MAX:g} and "
          f"bulk ESS ≥ {ESS_MIN} for every sampled parameter (Vehtari et al. 2021).")
    verdicts = []
    rng = np.random.default_rng(0)  # the conditional draws: the same summary every time
    order = list(report.table["optimizer"])
    for pc in chains:
        chain, a = pc.chain, pc.assessment
        worst = max((float(d["r_hat"].max()) for d in a["diagnostics"]), default=float("nan"))
        least = min((float(d["ess_bulk"].min()) for d in a["diagnostics"]), default=float("nan"))
        verdicts.append((chain, {"converged": a["converged"], "steps": chain.steps, "worst_r_hat": worst,
                                 "min_ess": least, "modes": len(a["modes"])}))
        doc.h(3, f"{chain.specimen} ({chain.optimizer}, {pc.problem.formulation} formulation)")
        nfev = pc.run.get("nfev")
        doc.table(convergence_table(pc), f"{chain.steps:,} stored steps × {chain.walkers} walkers in {pc.ensembles} "
                                         f"ensemble(s) (acceptance fraction {number(chain.acceptance_fraction, 2)}"
                                         + (f", {int(nfev):,} evaluations" if nfev == nfev and nfev else "")
                                         + "), second half kept")
        if a["converged"]:
            doc.p(f"**Converged**: R̂ ≤ {R_HAT_MAX:g} (worst {worst:.3f}) and bulk ESS ≥ {ESS_MIN} (least {least:,.0f}) "
                  "for every sampled parameter" + (" in every mode." if len(a["modes"]) > 1 else "."))
        else:
            doc.banner(f"NOT converged: worst R̂ {worst:.3f}, least bulk ESS {least:,.0f} (need ≤ {R_HAT_MAX:g} and ≥ "
                       f"{ESS_MIN}): the summaries below are not reliable. " + "; ".join(a["why"]) + ".")
        if pc.run.get("message"):
            doc.p(f"What the sampler did and why it stopped: {pc.run['message']}.")
        if len(a["modes"]) > 1:
            doc.p(f"The {pc.ensembles} ensembles settled in {len(a['modes'])} separate regions (their central 90 % "
                  "intervals do not overlap in every parameter): separate modes, or one mode the chains have not "
                  "crossed. They are summarised apart, not pooled; the summary below is mode 1's region with the most "
                  "ensembles. Separate ensembles cannot weigh one mode against another.")
            doc.table(modes_table(pc), "Modes: median log-probability and the median of each sampled parameter")
        true = truth(study, pc.problem, chain.specimen)
        table, outside = summary(pc, rng, true)
        doc.table(table, f"Posterior medians and central {LEVEL:.0%} intervals"
                  + (" (linear coefficients drawn from their conditional Gaussian)"
                     if pc.problem.formulation == "identifiable" else ""))
        if true is not None:
            doc.p("The truth lies inside every central 95 % interval." if not outside else
                  f"The truth lies outside the central 95 % interval of {', '.join(outside)}.")
        kept = pc.problem.from_unit(pc.unit_draws())
        moving = [j for j, n in enumerate(pc.names) if n not in pc.fixed]
        labels = parameters(pc.problem)
        pairs = strongest_pairs(posterior_correlation(kept[:, moving], [pc.names[j] for j in moving]), 3)
        if pairs:
            doc.p("Strongest posterior correlations (kept samples): " + "; ".join(
                f"{labels[x][0]}–{labels[y][0]} r = {r:+.2f}" for x, y, r in pairs) + ".")
        png = figures.posterior(study, doc.out_dir, chain, problem=pc.problem, posterior=pc, order=order)
        doc.figure(png, f"{chain.specimen}: posterior marginals and the most correlated pairs, with the best fit on "
                        "the specimen, the truth and the chain's convergence verdict")
        if chain.specimen == report.featured[0]:
            doc.p("The loops figure of this specimen above carries the posterior predictive 95 % band (model force "
                  "plus noise) on the force and on the residual.")
        else:
            png = _loops_with_band(study, doc.out_dir, pc, order)
            if png is not None:
                doc.figure(png, f"{chain.specimen}: the best fits and the posterior predictive check — the measured "
                                "force against the 95 % band of the posterior's predictions (model force plus noise), "
                                "and the residual")
    report.options["chain_diagnostics"] = verdicts
    return verdicts


def _loops_with_band(study, out_dir, pc, order):
    """The loops figure of ``pc``'s specimen with its posterior predictive band; None when the specimen
    has no finished ranking run to draw the fits of, or no draw gives a finite force. (Here, not in
    ``posterior_predictive``: the loops figure itself asks that module for the band.)"""
    from bwbench.problems.switched_vpp import posterior_predictive
    from bwbench.problems.switched_vpp.fit_figures import hysteresis_loops

    ranking = study.ranking
    runs = ranking[(ranking["specimen"] == pc.chain.specimen) & (ranking["status"] == "ok")
                   & np.isfinite(ranking["mse"].astype(float))]
    band = posterior_predictive.predictive(pc, np.random.default_rng(0))
    if not len(runs) or band is None:
        return None
    return hysteresis_loops(study, out_dir, pc.chain.specimen, order=order, band=band)
