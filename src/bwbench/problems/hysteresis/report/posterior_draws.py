"""A study's posterior chain as the report reads it, for any model: its problem, its run, its modes,
its kept draws in physical units (linear coefficients drawn from their conditional Gaussian in the
identifiable formulation), parameter labels and units, and the truth in the chain's coordinates.

Everything is asked of the problem (``parameter_list``, ``linear_names``/``linear_units``) and its
model (``from_direct``), so a Spencer or classic Bouc-Wen chain reads like a switched one.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from bwbench.analysis import mcmc
from bwbench.models.switched import parameters as switched_parameters

TOLERANCE = 0.10  # good fits: final MSE within 10 % of the best known for the specimen
EDGE = 1e-3  # a fit within this of an edge of the box (unit coordinates) lies on it
DRAWS = 1000  # kept draws summarised and pushed through the model (thinned evenly)


@dataclass(eq=False)
class PosteriorChain:
    """One posterior run: ``chain`` (``bwbench.study.results.Chain``), its ``problem``, ``run`` (row of
    ``study.runs``), ``ensembles``, ``assessment`` (``mcmc.assess``), ``names`` (the chain's
    coordinates), ``fixed`` (names held fixed by a reduced model) and ``burn``."""

    chain: Any  # bwbench.database.reader.Chain
    problem: Any  # the problem the chain sampled
    run: dict
    ensembles: int
    assessment: dict
    names: list
    fixed: list = field(default_factory=list)
    # a nested-sampling posterior: ``posterior_verdict.judge`` of its runs, a ``Verdict`` (the chain's
    # walkers are the runs, its steps their equal-weight draws); ``assessment`` then has one "mode"
    nested: Any = None

    @property
    def burn(self) -> int:
        return 0 if self.nested is not None else self.chain.steps // 2

    @property
    def converged(self) -> bool:
        return bool(self.nested.converged if self.nested is not None else self.assessment["converged"])

    @property
    def reasons(self) -> list:
        """Why the posterior is not converged (empty when it is), in the report's words."""
        if self.nested is not None:
            return list(self.nested.reasons)
        return [] if self.assessment["converged"] else list(self.assessment.get("why") or ["R̂ or ESS off target"])

    @property
    def verdict_line(self) -> str:
        """The verdict in one line: what the report's posterior section, the terminal and the API show."""
        from bwbench.analysis import posterior_verdict

        if self.nested is not None:
            return self.nested.line
        return posterior_verdict.sentence(
            self.converged,
            self.reasons,
            "R̂ ≤ 1.01 and bulk ESS ≥ 400 for every sampled parameter"
            + (f", parameters held by a reduced model: {', '.join(self.fixed)}" if self.fixed else "")
            + ", and the best ranking fit lies within the draws",
        )

    @property
    def main(self):
        """The mode whose summaries the report shows: the most ensembles, then the best log-probability."""
        modes = self.assessment["modes"]
        return max(modes, key=lambda m: (len(m.ensembles), m.log_prob if np.isfinite(m.log_prob) else -np.inf))

    def unit_draws(self, mode=None, size: int = DRAWS) -> np.ndarray:
        """Kept samples of ``mode`` (default: the main one) in unit coordinates, thinned evenly to ≤ ``size``."""
        mode = self.main if mode is None else mode
        kept = self.chain.samples[self.burn :, mode.walkers].reshape(-1, self.chain.samples.shape[2])
        return kept[:: max(1, -(-len(kept) // size))]

    def draws(self, rng, mode=None, size: int = DRAWS) -> dict:
        """{name: values} of kept samples (physical units) of every sampled and solved parameter."""
        P = self.problem.from_unit(self.unit_draws(mode, size))
        out = {n: P[:, j] for j, n in enumerate(self.names)}
        if getattr(self.problem, "formulation", "") == "identifiable":
            out.update(linear_draws(self.problem, P, rng))
        return out


def linear_draws(problem, P, rng) -> dict:
    """{coefficient: values}: one draw per θ row of P from the conditional Gaussian (NaN where the
    design is not of full rank)."""
    from bwbench.problems.hysteresis.marginal import draw_linear

    solution = problem.solve(P)
    names = problem.linear_names
    coef = np.full((len(P), len(names)), np.nan)
    varying = len(problem.design.w_names)
    for i in range(len(P)):
        try:
            coef[i] = draw_linear(solution.row(i), rng, 1, varying=varying)["coef"][0]
        except ValueError:  # a sample whose design is not of full rank: no draw
            pass
    return {n: coef[:, j] for j, n in enumerate(names)}


def parameters(problem) -> dict:
    """{name: (label, unit)} of every parameter a result of ``problem`` reports: searched, solved, direct."""
    out = {p.name: (p.label or p.name, p.unit) for p in problem.model.direct_parameters(problem.state)}
    out.update({p.name: (p.label or p.name, p.unit) for p in problem.parameter_list})
    if getattr(problem, "formulation", "") == "identifiable":
        labels = problem.model.linear_layout(problem.state).labels
        for n in problem.linear_names:
            base = n.rstrip("+-") if n not in labels else n
            label = labels.get(n, labels.get(base, base) + n[len(base) :].replace("+", "₊").replace("-", "₋"))
            out[n] = (label, problem.linear_units[n])
    return out


def pretty(unit: str) -> str:
    if unit in ("-", ""):
        return "–"
    return unit.replace("^-n+", "^(−n₊)").replace("^-n-", "^(−n₋)")


def axis(problem, name: str, table: dict | None = None) -> str:
    """ "x_y₊ (mm)": the label and unit of ``name`` for an axis or a table row."""
    label, unit = (table or parameters(problem)).get(name, (name, "-"))
    return f"{label} ({pretty(unit)})"


def truth(study, problem, specimen) -> dict | None:
    """{name: value} of the specimen's truth (manifest) in ``problem``'s coordinates (and its linear
    coefficients in the identifiable formulation); None without a truth or a map to these coordinates."""

    P = switched_parameters.truth_params(study.specimen_path(specimen))
    if P is None:
        return None
    model = problem.model
    direct = [p.name for p in model.direct_parameters(problem.state)]
    if len(P) != len(direct):
        return None
    if getattr(problem, "formulation", "") != "identifiable":
        return dict(zip(direct, map(float, P)))
    try:
        theta, coef = model.from_direct(np.asarray(P, dtype=float), problem.state)
    except (NotImplementedError, ValueError):
        return None
    return {**dict(zip(problem.param_names, map(float, theta))), **{k: float(v) for k, v in coef.items()}}


def posterior_chains(study, chains=None) -> list[PosteriorChain]:
    """Every posterior chain of ``study`` with its problem, run and assessment."""
    from bwbench.problems.hysteresis.report.figure_common import problem_for

    cache: dict = {}
    out: list = []
    for chain in chains if chains is not None else [c for c in study.chains if c.kind == "posterior"]:
        # the run label names its model and formulation (a study comparing models samples each model)
        problem = problem_for(study, chain.specimen, chain.optimizer, cache)
        names = list(problem.param_names)
        if chain.samples.shape[2] != len(names):
            continue  # not this problem's coordinates: nothing to read it with
        runs = study.runs
        row = runs[
            (runs["kind"] == chain.kind)
            & (runs["specimen"] == chain.specimen)
            & (runs["optimizer"] == chain.optimizer)
            & (runs["replicate"] == chain.replicate)
        ]
        run = row.iloc[0].to_dict() if len(row) else {}
        try:
            options = json.loads(run.get("options_json") or "{}")
        except (TypeError, json.JSONDecodeError):
            options = {}
        if getattr(chain, "evidence", None) is not None:
            out.append(nested_chain(study, chain, problem, run, names))
            continue
        ensembles = int(options.get("ensembles", 1) or 1)
        if chain.walkers % ensembles:
            ensembles = 1
        assessment = mcmc.assess(chain.samples, chain.log_prob, ensembles, names)
        moving = mcmc.sampled(chain.samples)
        pc = PosteriorChain(
            chain, problem, run, ensembles, assessment, names, [n for n, m in zip(names, moving) if not m]
        )
        _best_fit_covered(study, pc)
        out.append(pc)
    return out


def _best_fit_covered(study, pc: PosteriorChain) -> None:
    """An emcee posterior is not converged when the best ranking fit lies where none of its kept draws go
    while as probable as them (``nested.locate``: "missed"): the chain missed a mode, whatever R̂ says.
    The reason joins ``pc.assessment["why"]``."""
    from bwbench.analysis import nested

    fits = good_ranking_fits(study, pc.problem, pc.chain.specimen)
    if not fits or pc.chain.log_prob is None:
        return
    kept = pc.chain.samples[pc.burn :]
    lp = pc.chain.log_prob[pc.burn :]
    modes, cut, unit = nested.find_modes(kept, lp)
    for point, like, label in fits:
        place = nested.locate(point, like, kept, lp, {"scale": unit, "cut": cut, "modes": modes})
        if place["where"] != "missed":
            continue
        pc.assessment["converged"] = False
        pc.assessment["why"] = [
            *pc.assessment.get("why", []),
            f"the sampler missed a mode at least as probable as {label} (log-likelihood {like:.1f}, where no "
            f"kept draw goes; the draws' best {np.nanmax(lp):.1f})",
        ]
        return


def good_fits(study, specimen: str, tolerance: float = TOLERANCE) -> pd.DataFrame:
    """Ranking runs on ``specimen`` whose final MSE is within ``tolerance`` of the best known."""
    from bwbench.analysis import statistics

    best = statistics.best_known(study.runs)[specimen]
    runs = study.ranking[(study.ranking["specimen"] == specimen) & (study.ranking["status"] == "ok")]
    return runs[runs["mse"] <= best * (1 + tolerance)]


def good_ranking_fits(study, problem, specimen: str) -> list:
    """[(unit point, log-likelihood, label)] of the ranking's good fits on ``specimen`` (final MSE within
    10 % of the best known: ``good_fits``), best first, in ``problem``'s coordinates;
    fits outside the box, on its edge (a search stopped by its box: a sliver of the prior the draws seldom
    reach) or of another model are left out."""
    out: list = []
    for _, row in good_fits(study, specimen).sort_values("mse").iterrows():
        theta = in_coordinates(row.to_dict(), problem)
        if theta is None:
            continue
        u = np.asarray(problem.to_unit(theta[None, :]), dtype=float)[0]
        if np.any(u <= EDGE) or np.any(u >= 1 - EDGE):
            continue
        like = float(log_posterior(problem, theta[None, :])[0])
        best = "the best ranking fit" if not out else "the good ranking fit"
        out.append((u, like, f"{best} ({row['optimizer']}, seed {int(row['replicate']) + 1}, MSE {row['mse']:.4g} N²)"))
    return out


def best_ranking_fit(study, problem, specimen: str):
    """(unit point, log-likelihood, label) of the ranking's best fit on ``specimen`` in ``problem``'s
    coordinates (the sampler's log-likelihood), or None when no finished run maps to them."""
    ranking = study.ranking
    runs = ranking[(ranking["specimen"] == specimen) & (ranking["status"] == "ok")]
    runs = runs[np.isfinite(runs["mse"].astype(float))].sort_values("mse")
    for _, row in runs.iterrows():
        theta = in_coordinates(row.to_dict(), problem)
        if theta is None:
            continue
        u = np.asarray(problem.to_unit(theta[None, :]), dtype=float)[0]
        if np.any(u < 0) or np.any(u > 1):
            continue  # outside the posterior's box: no prior mass there
        like = float(log_posterior(problem, theta[None, :])[0])
        label = f"the best ranking fit ({row['optimizer']}, seed {int(row['replicate']) + 1}, MSE {row['mse']:.4g} N²)"
        return u, like, label
    return None


def nested_chain(study, chain, problem, run: dict, names) -> PosteriorChain:
    """A nested-sampling posterior read for the report and the API: its verdict (``posterior_verdict.judge``
    on the stored runs, with the best ranking fit located against the draws) and a single "mode" holding
    every run, so that the summaries, figures and the decomposition read the whole posterior, every mode
    with its mass."""
    verdict = verdict_of(study, chain, problem, names)
    lp = chain.log_prob
    whole = mcmc.Mode(
        tuple(range(chain.walkers)), np.arange(chain.walkers), float(np.median(lp)) if lp is not None else float("nan")
    )
    assessment = {
        "converged": verdict.converged,
        "modes": [whole],
        "diagnostics": [verdict.diagnostics] if verdict.diagnostics is not None else [],
        "why": verdict.reasons,
        "modes_text": "",
        "steps": chain.steps,
    }
    return PosteriorChain(chain, problem, run, chain.walkers, assessment, list(names), [], verdict)


def verdict_of(study, chain, problem, names):
    """``posterior_verdict.judge`` of a stored nested-sampling chain: what the report, the terminal and the
    API say of it (the best ranking fit of its specimen located against the draws)."""
    from bwbench.analysis import posterior_verdict

    ev = chain.evidence
    table = parameters(problem)
    return posterior_verdict.judge(
        chain.samples,
        chain.log_prob,
        ev["log_z"],
        ev["log_z_err"],
        names,
        complete=ev.get("run_complete"),
        ess=ev.get("run_ess"),
        insertion=ev.get("insertion"),
        run_nfev=ev.get("run_nfev"),
        steps=ev.get("run_steps"),
        best_fit=good_ranking_fits(study, problem, chain.specimen),
        from_unit=problem.from_unit,
        labels=[axis(problem, n, table) for n in names],
    )


def in_coordinates(values: dict, problem):
    """A run's parameters (``values``: name → value) as a vector of ``problem``'s searched coordinates:
    taken as they are when present, mapped from the model's direct parameters (``Model.from_direct``)
    otherwise; None when neither works, or when the run fitted another model (a study comparing models:
    the classic Bouc-Wen's x_y, n, η are not Spencer's)."""
    model = values.get("model")
    if isinstance(model, str) and model != getattr(problem.model, "name", model):
        return None
    names = list(problem.param_names)
    if all(np.isfinite(values.get(n, np.nan)) for n in names):
        return np.array([float(values[n]) for n in names])
    direct = [p.name for p in problem.model.direct_parameters(problem.state)]
    if getattr(problem, "formulation", "") != "identifiable" or not all(
        np.isfinite(values.get(n, np.nan)) for n in direct
    ):
        return None
    try:
        theta, _ = problem.model.from_direct(np.array([values[n] for n in direct], dtype=float), problem.state)
    except (NotImplementedError, ValueError):
        return None
    return np.asarray(theta, dtype=float)


def log_posterior(problem, P) -> np.ndarray:
    """The sampler's log-posterior (up to its constant) of parameter rows P (physical units): the
    problem's marginal likelihood when it has one, else −(L/2)·log MSE; the box is not applied."""
    P = np.atleast_2d(np.asarray(P, dtype=float))
    if hasattr(problem, "log_likelihood_batch"):
        return problem.log_likelihood_batch(P)[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        mse = problem.loss_batch(P)
        return np.where(
            np.isfinite(mse), -0.5 * problem.n_data * np.log(np.maximum(mse, np.finfo(float).tiny)), -np.inf
        )


def cached(report) -> list:
    """``posterior_chains`` of the report's study, read once per report."""
    if "posterior_chains" not in report.options:
        report.options["posterior_chains"] = posterior_chains(report.study)
    return report.options["posterior_chains"]
