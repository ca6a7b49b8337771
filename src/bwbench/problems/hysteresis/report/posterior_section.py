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
from bwbench.problems.hysteresis.report.posterior_draws import axis, cached, parameters, truth
from bwbench.render.format import number

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


PRIOR_TEXT = ("The prior is uniform on the search box in the searched coordinates (log-uniform in a parameter whose box "
              "is logarithmic), so ln Z is the log of the likelihood's mean over the box: widening the box by a factor c "
              "in a parameter the data pin down lowers ln Z by ln c (doubling it: −0.69), and a direction the data "
              "cannot pin down shows as a marginal as wide as its box, not removed. The likelihood's constant (σ "
              "integrated out under Jeffreys' prior) is the same for every model of the same data: differences of "
              "ln Z between models of one specimen are meaningful, their absolute values are not.")


def nested_text(pc) -> list[str]:
    """Paragraphs on a nested-sampling posterior: the verdict with the criteria that failed, and where
    the best ranking fit lies."""
    v = pc.nested
    ev = v["evidence"]
    out = []
    if v["converged"]:
        out.append(f"**Converged** across {pc.chain.walkers} independent runs: R̂ ≤ {R_HAT_MAX:g} and bulk ESS ≥ "
                   f"{ESS_MIN} for every parameter (each run's equal-weight draws one chain), the runs agree on ln Z "
                   f"(χ² p = {number(ev['p'], 2)}) and on every mode's mass, and no run was cut by the budget.")
    else:
        out.append("NOT converged — " + "; ".join(v["failed"]) + ".")
    place = v.get("best_fit_place")
    if place is not None:
        if place["where"] == "mode":
            out.append(f"The best ranking fit lies in mode {place['mode'] + 1} of the posterior.")
        elif place["where"] == "below":
            out.append(f"The best ranking fit lies below the posterior's support by Δ log p = {place['delta']:.1f} "
                       "(the sampler's draws are all more probable).")
        else:
            out.append("The best ranking fit lies where no draw goes (outside every draw, or more probable than "
                       "any draw), at least as probable as the draws: the sampler missed a mode at least as "
                       "probable as it.")
    return out


def good_fits_placed(study, pc) -> pd.DataFrame:
    """Every good ranking fit (``spread_decomposition.good_fits``) against a nested posterior's draws
    (``nested.locate``): in which mode, or below the posterior's support by how much, or outside every
    draw while as probable (a mode the sampler missed)."""
    from bwbench.analysis import nested
    from bwbench.problems.hysteresis.report.posterior_draws import in_coordinates, log_posterior
    from bwbench.problems.hysteresis.report.spread_decomposition import good_fits

    rows = []
    for _, run in good_fits(study, pc.chain.specimen).sort_values("mse").iterrows():
        theta = in_coordinates(run.to_dict(), pc.problem)
        if theta is None:
            continue
        like = float(log_posterior(pc.problem, theta[None, :])[0])
        u = np.asarray(pc.problem.to_unit(theta[None, :]), dtype=float)[0]
        place = nested.locate(u, like, pc.chain.samples, pc.chain.log_prob, pc.nested)
        where = (f"mode {place['mode'] + 1}" if place["where"] == "mode" else
                 f"below the posterior's support by Δ log p = {place['delta']:.1f}" if place["where"] == "below" else
                 "where no draw goes, as probable: the sampler missed a mode at least as probable as this fit")
        rows.append({"fit": f"{run['optimizer']}, seed {int(run['replicate']) + 1}", "MSE": number(float(run["mse"])),
                     "log-likelihood": f"{like:.1f}", "where": where})
    return pd.DataFrame(rows)


def nested_modes_table(pc) -> pd.DataFrame:
    """One row per mode of a nested-sampling posterior: its mass with the run-to-run spread, its best
    log-likelihood and the median [central 95 % interval] of every parameter."""
    v, table = pc.nested, parameters(pc.problem)
    flat = pc.chain.samples.reshape(-1, pc.chain.samples.shape[2])
    rows = []
    for i, mode in enumerate(v["modes"]):
        P = pc.problem.from_unit(flat[mode.members])
        row = {"mode": i + 1, "mass": f"{mode.mass:.2f} ± {mode.spread:.2f}" if np.isfinite(mode.spread)
               else f"{mode.mass:.2f}", "best log-likelihood": f"{mode.best_log_like:.1f}"}
        for j, n in enumerate(pc.names):
            lo, mid, hi = np.quantile(P[:, j], [(1 - LEVEL) / 2, 0.5, 1 - (1 - LEVEL) / 2])
            row[axis(pc.problem, n, table)] = f"{number(mid, 3)} [{number(lo, 3)}, {number(hi, 3)}]"
        rows.append(row)
    return pd.DataFrame(rows)


def evidence_table(chains) -> pd.DataFrame:
    """``| specimen | model | ln Z | ± | ln B |``: each nested posterior's pooled ln Z, and the Bayes factor
    (log) against the best model of the same specimen."""
    from bwbench.analysis import nested

    rows = [{"specimen": pc.chain.specimen, "model": model_name(pc), "ln Z": pc.nested["evidence"]["log_z"],
             "±": pc.nested["evidence"]["err"]} for pc in chains if pc.nested is not None]
    if not rows:
        return pd.DataFrame()
    frame = pd.DataFrame(rows)
    for _, group in frame.groupby("specimen", sort=False):
        factors = nested.bayes_factors(dict(zip(group.index, group["ln Z"])))
        frame.loc[group.index, "ln B against the best"] = [factors[i] for i in group.index]
    return frame


def model_name(pc) -> str:
    model = getattr(pc.problem, "model", None)
    return str(getattr(model, "name", pc.chain.optimizer))


def write_inference_data(pc, out_dir) -> str | None:
    """The posterior's draws in physical units as an ArviZ InferenceData (netCDF) beside the report: one
    chain per run, equal weights; the log-likelihood in sample_stats. Returns the file name, or None
    when it cannot be written (no netCDF engine)."""
    import arviz as az

    samples = pc.chain.samples  # (draws, runs, d)
    P = pc.problem.from_unit(samples.reshape(-1, samples.shape[2])).reshape(samples.shape)
    posterior = {n: np.swapaxes(P[:, :, j], 0, 1) for j, n in enumerate(pc.names)}
    stats = {} if pc.chain.log_prob is None else {"lp": np.swapaxes(pc.chain.log_prob, 0, 1)}
    data = az.from_dict(posterior=posterior, sample_stats=stats,
                        attrs={"engine": "nested sampling (UltraNest)", "weights": "equal",
                               "log_z": pc.nested["evidence"]["log_z"], "log_z_err": pc.nested["evidence"]["err"]})
    name = f"posterior_{pc.chain.specimen}_{pc.chain.optimizer}".replace(" ", "_").replace("[", "").replace("]", "")
    path = f"{out_dir}/{name}.nc"
    try:
        data.to_netcdf(path)
    except (ImportError, ValueError, OSError):
        return None
    return f"{name}.nc"


def section(report) -> list:
    from bwbench.problems.hysteresis.report import figures, model_evidence, samplers_section

    doc, study = report.doc, report.study
    chains = cached(report)
    if not chains:
        return []
    doc.h(2, "Posterior sampling")
    if any(pc.nested is not None for pc in chains):
        doc.p("Nested sampling (UltraNest) per specimen, kept out of the ranking: several independent runs, each "
              "holding every mode it finds with its mass and giving the model evidence ln Z. Convergence across "
              "the runs: each run's equal-weight draws are one chain of ArviZ's rank-normalised split-R̂ and bulk "
              f"ESS (R̂ ≤ {R_HAT_MAX:g} and bulk ESS ≥ {ESS_MIN} for every parameter), the runs must agree on ln Z "
              "within their errors and on each mode's mass, no run may be cut by the budget, and the best ranking "
              "fit must not lie outside every draw while being as probable as them (with a flat prior the "
              "highest-likelihood region holds it: the sampler would have missed a mode). " + PRIOR_TEXT)
    if any(pc.nested is None for pc in chains):
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
        if pc.nested is not None:
            verdicts.append(_nested_subsection(report, pc, rng, order))
            continue
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
        _summary_against_truth(doc, study, pc, rng, f"Posterior medians and central {LEVEL:.0%} intervals")
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
    # which model the data support (nested posteriors of several models), and several samplers compared
    model_evidence.section(report, chains)
    samplers_section.section(report, chains)
    report.options["chain_diagnostics"] = verdicts
    return verdicts


def _summary_against_truth(doc, study, pc, rng, caption: str) -> None:
    """The table of posterior medians and intervals, and where the truth (a synthetic specimen's) lies."""
    true = truth(study, pc.problem, pc.chain.specimen)
    table, outside = summary(pc, rng, true)
    doc.table(table, caption + (" (linear coefficients drawn from their conditional Gaussian)"
                                if pc.problem.formulation == "identifiable" else ""))
    if true is not None:
        doc.p("The truth lies inside every central 95 % interval." if not outside else
              f"The truth lies outside the central 95 % interval of {', '.join(outside)}.")


def _nested_subsection(report, pc, rng, order):
    from bwbench.problems.hysteresis.report import figures

    doc, study, chain, v = report.doc, report.study, pc.chain, pc.nested
    table = v["diagnostics"]
    worst, least = float(table["r_hat"].max()), float(table["ess_bulk"].min())
    doc.h(3, f"{chain.specimen} ({chain.optimizer}, {pc.problem.formulation} formulation)")
    ev = chain.evidence
    nfev = pc.run.get("nfev")
    doc.table(convergence_table(pc), f"{chain.walkers} independent runs × {chain.steps:,} equal-weight draws"
              + (f", {int(nfev):,} evaluations" if nfev == nfev and nfev else "")
              + f"; ln Z per run: {', '.join(f'{z:.2f} ± {e:.2f}' for z, e in zip(ev['log_z'], ev['log_z_err']))}")
    for text in nested_text(pc):
        (doc.p if v["converged"] or not text.startswith("NOT") else doc.banner)(text)
    if pc.run.get("message"):
        doc.p(f"What the sampler did and why it stopped: {pc.run['message']}.")
    doc.table(nested_modes_table(pc), "Modes: posterior mass (± run-to-run spread), best log-likelihood, median "
                                      f"[central {LEVEL:.0%} interval] of each parameter")
    placed = good_fits_placed(study, pc)
    if len(placed):
        doc.table(placed, "The good ranking fits (final MSE within 10 % of the best known) against the posterior's draws")
    _summary_against_truth(doc, study, pc, rng, f"Posterior medians and central {LEVEL:.0%} intervals over every mode")
    written = write_inference_data(pc, doc.out_dir)
    if written:
        doc.p(f"The draws in physical units, one chain per run, are in `{written}` (ArviZ InferenceData, netCDF).")
    png = figures.posterior(study, doc.out_dir, chain, problem=pc.problem, posterior=pc, order=order)
    doc.figure(png, f"{chain.specimen}: posterior marginals and the most correlated pairs, with the best fit on the "
                    "specimen and the truth")
    return (chain, {"converged": v["converged"], "steps": chain.steps, "worst_r_hat": worst, "min_ess": least,
                    "modes": len(v["modes"])})


def _loops_with_band(study, out_dir, pc, order):
    """The loops figure of ``pc``'s specimen with its posterior predictive band; None when the specimen
    has no finished ranking run to draw the fits of, or no draw gives a finite force. (Here, not in
    ``posterior_predictive``: the loops figure itself asks that module for the band.)"""
    from bwbench.problems.hysteresis.report import posterior_predictive
    from bwbench.problems.hysteresis.report.fit_figures import hysteresis_loops

    ranking = study.ranking
    runs = ranking[(ranking["specimen"] == pc.chain.specimen) & (ranking["status"] == "ok")
                   & np.isfinite(ranking["mse"].astype(float))]
    band = posterior_predictive.predictive(pc, np.random.default_rng(0))
    if not len(runs) or band is None:
        return None
    return hysteresis_loops(study, out_dir, pc.chain.specimen, order=order, band=band)
