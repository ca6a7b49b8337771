"""The report's posterior section: a long MCMC run, its convergence by ArviZ, and what it says.

A chain of the identifiable formulation samples the 7 (shared) or 6 (split) hysteretic parameters
with the linear coefficients integrated out analytically (``marginal.log_marginal``); the linear
coefficients are then drawn exactly from their conditional Gaussian for each kept sample
(``marginal.draw_linear``), so the summary covers all of them. A chain of the paper formulation
samples its 14 parameters directly.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from bwbench.analysis import mcmc
from bwbench.analysis.identifiability import posterior_correlation, strongest_pairs
from bwbench.report.format import number

R_HAT_MAX = 1.01
ESS_MIN = 400
DRAWS = 1000  # kept samples summarised (thinned evenly)


def coordinates(study, chain):
    """(problem, names, labels) of the chain: the paper's 14 or the identifiable hysteretic ones."""
    from bwbench.models.switched_bouc_wen import PARAM_NAMES
    from bwbench.problems.switched_vpp.formulations import make_problem
    from bwbench.problems.switched_vpp.identifiability import label

    s = study.settings
    identifiable = chain.samples.shape[2] != len(PARAM_NAMES)
    settings = {"state": s.get("state", "shared"), "excitation": s.get("excitation", "measured"),
                "formulation": "identifiable" if identifiable else "paper", "fix_mass": s.get("fix_mass", "auto"),
                "bounds": s.get("bounds", {})}
    from bwbench.data.specimen import read_specimen

    problem = make_problem(read_specimen(study.specimen_path(chain.specimen)), settings)
    names = list(problem.param_names)
    return problem, names, [label(n) for n in names]


def summary(problem, samples: np.ndarray, rng) -> pd.DataFrame:
    """Median and 90 % interval of every parameter over ``samples`` (physical, (n, d)); for the
    identifiable formulation also the linear coefficients, drawn from their conditional Gaussian."""
    from bwbench.problems.switched_vpp.figure_common import axis_label

    columns = {axis_label(n): samples[:, j] for j, n in enumerate(problem.param_names)}
    if getattr(problem, "formulation", "paper") == "identifiable":
        from bwbench.problems.marginal import draw_linear

        solution = problem.solve(samples)
        names, units = problem.linear_names, problem.linear_units
        coef = np.full((len(samples), len(names)), np.nan)
        for i in range(len(samples)):
            try:
                coef[i] = draw_linear(solution.row(i), rng, 1)["coef"][0]
            except ValueError:  # a sample whose design is not of full rank: no draw
                pass
        columns.update({f"{n} ({units[n]})": coef[:, j] for j, n in enumerate(names)})
    rows = []
    for name, values in columns.items():
        values = values[np.isfinite(values)]
        if values.size:
            q5, q50, q95 = np.quantile(values, [0.05, 0.5, 0.95])
            rows.append({"parameter": name, "median": number(q50), "5 %": number(q5), "95 %": number(q95)})
    return pd.DataFrame(rows)


def section(report) -> list:
    from bwbench.problems.switched_vpp import figures

    doc, study = report.doc, report.study
    chains = [c for c in study.chains if c.kind == "posterior"]
    if not chains:
        return []
    doc.h(2, "Posterior sampling")
    doc.p("A long emcee run on one specimen, kept out of the ranking. In the identifiable formulation it samples "
          "the symmetry-free hysteretic parameters with the linear coefficients (mass, damping, stiffnesses, offsets) "
          "integrated out analytically under a flat prior and σ under Jeffreys' prior; the linear coefficients are "
          "then drawn exactly from their conditional Gaussian for each kept sample. Convergence by ArviZ: "
          "rank-normalised split-R̂ and bulk and tail effective sample sizes, each walker taken as a chain, the "
          f"first half of the chain dropped as burn-in; converged when R̂ ≤ {R_HAT_MAX:g} and bulk ESS ≥ "
          f"{ESS_MIN} for every parameter (Vehtari et al. 2021).")
    verdicts = []
    rng = np.random.default_rng(0)  # the conditional draws: the same summary every time
    order = list(report.table["optimizer"])
    for chain in chains:
        problem, names, labels = coordinates(study, chain)
        burn = chain.steps // 2
        diag = mcmc.convergence(chain.samples, names, burn)
        converged = bool((diag["r_hat"] <= R_HAT_MAX).all() and (diag["ess_bulk"] >= ESS_MIN).all())
        verdicts.append((chain, {"converged": converged, "steps": chain.steps,
                                 "worst_r_hat": float(diag["r_hat"].max()), "min_ess": float(diag["ess_bulk"].min())}))
        doc.h(3, f"{chain.specimen} ({chain.optimizer}, {problem.formulation} formulation)")
        shown = diag.assign(parameter=labels, r_hat=diag["r_hat"].map(lambda x: f"{x:.3f}"),
                            ess_bulk=diag["ess_bulk"].map(lambda x: f"{x:,.0f}"),
                            ess_tail=diag["ess_tail"].map(lambda x: f"{x:,.0f}"))
        doc.table(shown.rename(columns={"r_hat": "R̂", "ess_bulk": "bulk ESS", "ess_tail": "tail ESS"}),
                  f"{chain.steps:,} steps × {chain.walkers} walkers (acceptance fraction "
                  f"{number(chain.acceptance_fraction, 2)}), second half kept")
        verdict = (f"**Converged**: R̂ ≤ {R_HAT_MAX:g} (worst {diag['r_hat'].max():.3f}) and bulk ESS ≥ {ESS_MIN} "
                   f"(least {diag['ess_bulk'].min():,.0f}) for every parameter." if converged else
                   f"NOT converged: worst R̂ {diag['r_hat'].max():.3f}, least bulk ESS {diag['ess_bulk'].min():,.0f} "
                   f"(need ≤ {R_HAT_MAX:g} and ≥ {ESS_MIN}): the summaries below are not reliable; run it longer.")
        (doc.p if converged else doc.banner)(verdict)
        kept = chain.physical(burn, from_unit=problem.from_unit)
        thin = max(1, len(kept) // DRAWS)
        doc.table(summary(problem, kept[::thin], rng), "Posterior medians and 90 % intervals"
                  + (" (linear coefficients drawn from their conditional Gaussian)"
                     if problem.formulation == "identifiable" else ""))
        pairs = strongest_pairs(posterior_correlation(kept, names), 3)
        doc.p("Strongest posterior correlations (kept samples): "
              + "; ".join(f"{labels[names.index(a)]}–{labels[names.index(b)]} r = {r:+.2f}" for a, b, r in pairs) + ".")
        png = figures.posterior(study, doc.out_dir, chain, diagnostics=diag, from_unit=problem.from_unit,
                                names=names, order=order)
        doc.figure(png, f"{chain.specimen}: posterior marginals and the most correlated pairs, with the best fit on "
                        "the specimen, the truth and the chain's convergence verdict")
    report.options["chain_diagnostics"] = verdicts
    return verdicts

