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

from bwbench.analysis import mcmc
from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs
from bwbench.problems.hysteresis.report.nested_section import PRIOR_TEXT, nested_subsection
from bwbench.problems.hysteresis.report.posterior_draws import cached, parameters
from bwbench.problems.hysteresis.report.posterior_tables import (
    LEVEL,
    convergence_table,
    modes_table,
    summary_against_truth,
)
from bwbench.render.format import number

R_HAT_MAX, ESS_MIN = mcmc.R_HAT_MAX, mcmc.ESS_MIN


def section(report) -> list:
    from bwbench.problems.hysteresis.report import model_evidence, posterior_figures, samplers_section

    doc, study = report.doc, report.study
    chains = cached(report)
    if not chains:
        return []
    doc.h(2, "Posterior sampling")
    if any(pc.nested is not None for pc in chains):
        doc.p(
            "Nested sampling (UltraNest) per specimen, kept out of the ranking: independent runs, each holding "
            "every mode it finds with its mass and giving the model evidence ln Z, added until the runs pin the "
            "posterior to a stated precision or the budget is spent. Judged by what the runs reproduce: hard "
            "checks (every run ends by its own rule; the runs' ln Z agree within their errors; every run puts mass "
            "in every region holding ≥ 5 % of the pooled mass; UltraNest's insertion-order test passes in every "
            "run; the slice steps, doubled in every fourth run, change nothing; the best ranking fit lies inside "
            "the posterior — with a flat prior the highest-likelihood region holds it), then the precision from "
            "the scatter between runs (pooled means and 5/95 % quantiles within 0.1 posterior sd, region masses "
            "within 0.05). R̂ and bulk ESS across runs are kept as a badge, on at least 300 effective draws a run. "
            + PRIOR_TEXT
        )
    if any(pc.nested is None for pc in chains):
        doc.p(
            "A long emcee run per specimen, kept out of the ranking. In the identifiable formulation it samples the "
            "hysteretic parameters with the linear coefficients integrated out analytically (flat prior on the "
            "coefficients of the fixed signals, the scale-free g-prior on those of the hysteretic column, so the "
            "arbitrary scale of w does not weigh in) and σ under Jeffreys' prior; the prior on the hysteretic "
            "parameters is uniform on the search box (log-uniform where the box is). The linear coefficients are then "
            "drawn exactly from their conditional Gaussian for each kept sample. The sampler starts independent "
            "ensembles around distinct good optima of independent local searches and stops when converged or when "
            "its budget ends. Convergence by ArviZ: rank-normalised split-R̂ and bulk and tail effective sample "
            "sizes, each walker taken as a chain, the first half of the chain dropped as burn-in, mode by mode "
            f"(ensembles that settled in different regions are not pooled); converged when R̂ ≤ {R_HAT_MAX:g} and "
            f"bulk ESS ≥ {ESS_MIN} for every sampled parameter (Vehtari et al. 2021)."
        )
    verdicts = []
    rng = np.random.default_rng(0)  # the conditional draws: the same summary every time
    order = list(report.table["optimizer"])
    for pc in chains:
        if pc.nested is not None:
            verdicts.append(nested_subsection(report, pc, rng, order))
            continue
        chain, a = pc.chain, pc.assessment
        worst = max((float(d["r_hat"].max()) for d in a["diagnostics"]), default=float("nan"))
        least = min((float(d["ess_bulk"].min()) for d in a["diagnostics"]), default=float("nan"))
        verdicts.append(
            (
                chain,
                {
                    "converged": a["converged"],
                    "steps": chain.steps,
                    "worst_r_hat": worst,
                    "min_ess": least,
                    "modes": len(a["modes"]),
                    "line": pc.verdict_line,
                },
            )
        )
        doc.h(3, f"{chain.specimen} ({chain.optimizer}, {pc.problem.formulation} formulation)")
        nfev = pc.run.get("nfev")
        doc.table(
            convergence_table(pc),
            f"{chain.steps:,} stored steps × {chain.walkers} walkers in {pc.ensembles} "
            f"ensemble(s) (acceptance fraction {number(chain.acceptance_fraction, 2)}"
            + (f", {int(nfev):,} evaluations" if nfev == nfev and nfev else "")
            + "), second half kept",
        )
        if a["converged"]:
            doc.p(
                f"**{pc.verdict_line}** (worst R̂ {worst:.3f}, least bulk ESS {least:,.0f}"
                + (", in every mode)." if len(a["modes"]) > 1 else ").")
            )
        else:
            doc.banner(
                f"{pc.verdict_line}. Worst R̂ {worst:.3f}, least bulk ESS {least:,.0f} (need ≤ {R_HAT_MAX:g} and ≥ "
                f"{ESS_MIN}): the summaries below are not reliable. " + "; ".join(pc.reasons) + "."
            )
        if pc.run.get("message"):
            doc.p(f"What the sampler did and why it stopped: {pc.run['message']}.")
        if len(a["modes"]) > 1:
            doc.p(
                f"The {pc.ensembles} ensembles settled in {len(a['modes'])} separate regions (their central 90 % "
                "intervals do not overlap in every parameter): separate modes, or one mode the chains have not "
                "crossed. They are summarised apart, not pooled; the summary below is mode 1's region with the most "
                "ensembles. Separate ensembles cannot weigh one mode against another."
            )
            doc.table(modes_table(pc), "Modes: median log-probability and the median of each sampled parameter")
        summary_against_truth(doc, study, pc, rng, f"Posterior medians and central {LEVEL:.0%} intervals")
        kept = pc.problem.from_unit(pc.unit_draws())
        moving = [j for j, n in enumerate(pc.names) if n not in pc.fixed]
        labels = parameters(pc.problem)
        pairs = strongest_pairs(posterior_correlation(kept[:, moving], [pc.names[j] for j in moving]), 3)
        if pairs:
            doc.p(
                "Strongest posterior correlations (kept samples): "
                + "; ".join(f"{labels[x][0]}–{labels[y][0]} r = {r:+.2f}" for x, y, r in pairs)
                + "."
            )
        png = posterior_figures.posterior(study, doc.out_dir, chain, problem=pc.problem, posterior=pc, order=order)
        doc.figure(
            png,
            f"{chain.specimen}: posterior marginals and the most correlated pairs, with the best fit on "
            "the specimen, the truth and the chain's convergence verdict",
        )
        if chain.specimen == report.featured[0]:
            doc.p(
                "The loops figure of this specimen above carries the posterior predictive 95 % band (model force "
                "plus noise) on the force and on the residual."
            )
        else:
            png = _loops_with_band(study, doc.out_dir, pc, order)
            if png is not None:
                doc.figure(
                    png,
                    f"{chain.specimen}: the best fits and the posterior predictive check — the measured "
                    "force against the 95 % band of the posterior's predictions (model force plus noise), "
                    "and the residual",
                )
    # which model the data support (nested posteriors of several models), and several samplers compared
    model_evidence.section(report, chains)
    samplers_section.section(report, chains)
    report.options["chain_diagnostics"] = verdicts
    return verdicts


def _loops_with_band(study, out_dir, pc, order):
    """The loops figure of ``pc``'s specimen with its posterior predictive band; None when the specimen
    has no finished ranking run to draw the fits of, or no draw gives a finite force. (Here, not in
    ``posterior_predictive``: the loops figure itself asks that module for the band.)"""
    from bwbench.problems.hysteresis.report import posterior_predictive
    from bwbench.problems.hysteresis.report.fit_figures import hysteresis_loops

    ranking = study.ranking
    runs = ranking[
        (ranking["specimen"] == pc.chain.specimen)
        & (ranking["status"] == "ok")
        & np.isfinite(ranking["mse"].astype(float))
    ]
    band = posterior_predictive.predictive(pc, np.random.default_rng(0))
    if not len(runs) or band is None:
        return None
    return hysteresis_loops(study, out_dir, pc.chain.specimen, order=order, band=band)
