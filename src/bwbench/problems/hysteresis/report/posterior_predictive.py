"""The posterior predictive band of a specimen's force: what the posterior says the measurement
should look like, for the loops figure (``fit_figures.hysteresis_loops``).

For ``DRAWS`` kept draws of the main mode: the model force at the draw (the identifiable formulation:
its linear coefficients and σ drawn from their conditional posterior, ``marginal.draw_linear``; a
direct formulation: σ² ~ Inv-Gamma(L/2, RSS/2), Jeffreys' prior), plus noise N(0, σ²) at every sample.
The band is the central 95 % of those predictions at each sample (N); the measured force should
leave it at about 5 % of the samples, and where it leaves it in runs the model misses something.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

DRAWS = 200
LEVEL = 0.95


@dataclass(frozen=True, eq=False)
class Band:
    """Central ``LEVEL`` band of the predicted measurement (``lower``, ``upper``, N, per sample), of the
    model force alone (``model_lower``, ``model_upper``), and the share of measured samples outside it."""

    lower: np.ndarray
    upper: np.ndarray
    model_lower: np.ndarray
    model_upper: np.ndarray
    outside: float
    draws: int
    specimen: str


def predictive(pc, rng, draws: int = DRAWS) -> Band | None:
    """The band of the module docstring for one ``posterior_draws.PosteriorChain``; None when no
    draw gives a finite force."""
    from bwbench.problems.hysteresis.marginal import draw_linear

    problem = pc.problem
    f = problem.f_loss  # the samples in the loss (after a warm-up)
    P = problem.from_unit(pc.unit_draws(size=draws))
    forces, sigmas = [], []
    if getattr(problem, "formulation", "") == "identifiable":
        solution = problem.solve(P, residual=True)
        varying = len(problem.design.w_names)
        for i in range(len(P)):
            row = solution.row(i)
            if not np.isfinite(row.mse[0]):
                continue
            try:
                d = draw_linear(row, rng, 1, varying=varying)
            except ValueError:
                continue
            # model force at the drawn coefficients: the LS fit plus X·(β − β̂), X·R⁻¹ is orthonormal
            fitted = row.residual[0] + f
            shift = (d["coef"][0] - row.coef[0])[row.free_index]
            forces.append(fitted + _design_times(problem, P[i], shift, row))
            sigmas.append(float(d["sigma"][0]))
    else:
        L = len(f)
        for p in P:
            force = problem.simulate(p)[problem.start.loss]
            if not np.all(np.isfinite(force)):
                continue
            rss = float(np.sum((force - f) ** 2))
            forces.append(force)
            sigmas.append(float(np.sqrt(0.5 * rss / rng.gamma(0.5 * L, 1.0))))
    if not forces:
        return None
    F = np.array(forces)
    noisy = F + np.array(sigmas)[:, None] * rng.standard_normal(F.shape)
    tail = (1 - LEVEL) / 2
    lo, hi = np.quantile(noisy, [tail, 1 - tail], axis=0)
    mlo, mhi = np.quantile(F, [tail, 1 - tail], axis=0)
    outside = float(np.mean((f < lo) | (f > hi)))
    lo, hi, mlo, mhi = (np.concatenate([np.full(problem.start.warmup, np.nan), b]) for b in (lo, hi, mlo, mhi))
    return Band(lo, hi, mlo, mhi, outside, len(F), problem.specimen.name)  # NaN over a warm-up: not scored


def _design_times(problem, theta, shift, row) -> np.ndarray:
    """X(θ)·shift (N): the force change of moving the free linear coefficients by ``shift``."""
    design = problem.design
    w = problem.loss_trajectories(theta)[0]
    columns = {}
    s = problem.loss_signal
    for b, mask in design.masks.items():
        for name, source in design.layout.fixed:
            columns[f"{name}{b}"] = mask * (1.0 if source == "1" else np.asarray(getattr(s, source), dtype=float))
        columns[f"{design.layout.varying}{b}"] = mask * w
    if design.layout.mass:
        columns[design.layout.mass] = np.asarray(s.a, dtype=float)
    X = np.column_stack([columns[n] for n in row.free_names])
    return X @ shift


def band_of(study, specimen: str, rng=None) -> Band | None:
    """The band of the posterior chain on ``specimen`` in ``study`` (of the best ranking fit's model when
    several models were sampled, else the first); None when it has none."""
    from bwbench.problems.hysteresis.report.posterior_draws import posterior_chains

    chains = [c for c in study.chains if c.kind == "posterior" and c.specimen == specimen]
    found = posterior_chains(study, chains)
    if not found:
        return None
    # a study comparing models: the band of the model of the best ranking fit, whose loops the figure draws
    ranking = study.ranking
    runs = ranking[(ranking["specimen"] == specimen) & (ranking["status"] == "ok")].sort_values("mse")
    best_model = runs["model"].iloc[0] if len(runs) and "model" in runs else None
    chosen = next((pc for pc in found if getattr(pc.problem.model, "name", None) == best_model), found[0])
    return predictive(chosen, np.random.default_rng(0) if rng is None else rng)
