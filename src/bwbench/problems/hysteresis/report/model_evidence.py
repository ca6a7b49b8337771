"""Which model the data support: the model evidence of each nested-sampling posterior, made comparable
between models, with the Bayes factor against the best model of the specimen, beside its posterior
predictive check and how much ln Z depends on the box.

**Comparable ln Z.** Models of one specimen share its data and σ (under Jeffreys' 1/σ, common to
all, so its improper constant cancels), but the sampler's likelihood differs by formulation:

- a direct formulation samples −(L/2)·log MSE, which is log p(y | θ) with σ integrated out up to
  the constant log Γ(L/2) − (L/2)·log(π·L) − log 2 (RSS = L·MSE), added here;
- the identifiable formulation samples its linear coefficients' marginal under an improper prior
  (flat on the fixed signals' coefficients, the g → ∞ g-prior on the θ-dependent ones:
  ``bwbench.problems.hysteresis.marginal``), whose evidence has an arbitrary constant that differs with the
  number of coefficients — meaningless between models. Here each free coefficient β_j gets a proper
  uniform prior on ±``COEF_RANGE``·‖F‖/‖X_j‖ (no term alone more than ``COEF_RANGE`` times the
  measured force, in RMS; X_j its column at θ), and the evidence is moved to it by importance
  weights over the posterior draws: Z = Z_sampled · E_post[p_flat(y | θ) / (V(θ) · p_sampled(y | θ))],
  p_flat the flat-prior marginal (exact, ``log_marginal(prior="flat")``) and V(θ) the box's volume.
  The Gaussian of β given θ lies well inside that box on every fit we have seen; the bounds of the
  point estimate (m ≥ 0, k₁ ≥ 0) are not part of the prior.

**Box sensitivity.** With a uniform prior, widening the box of a parameter the data pin down by a
factor c lowers ln Z by ln c; one the data leave to the prior loses nothing. Doubling every box
(the searched parameters' and the linear coefficients' ranges) moves ln Z by about −(pinned + p)·ln 2,
pinned = searched parameters whose central 95 % posterior interval spans less than half their box.
The Bayes factor between two models moves by the difference of those shifts: the verdict is robust
to the box when |ln B| is much larger.

**Posterior predictive check** (``posterior_predictive``): the share of the measured samples outside
the 95 % band of the predicted measurement (about 5 % when the model holds), and where the residual
(measured force − the band's model-force median) concentrates: near the displacement's reversals
(|ẋ| below ``REVERSAL`` of its peak), where hysteresis models differ most, or elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.special import gammaln

from bwbench.problems.hysteresis.report.predictive_checks import REVERSAL, model_of, predictive_check, residual_figure

COEF_RANGE = 10.0  # a linear coefficient's prior: its term alone within ± this many times ‖F‖ (RMS)
PINNED_WIDTH = 0.5  # a searched parameter is pinned when its 95 % interval spans less than this of its box
DRAWS = 200  # posterior draws of the importance weights
FEW_DRAWS = 20  # a predictive band from fewer posterior draws than this is no check
TOP = 5  # most likely draws whose comparable likelihood bounds ln Z from above


@dataclass(frozen=True)
class Evidence:
    """A posterior's comparable ln Z (``log_z`` ± ``err``), what was added to the sampled one
    (``correction``), the number of pinned searched parameters and of free linear coefficients."""

    log_z: float
    err: float
    sampled: float
    correction: float
    pinned: int
    coefficients: int

    @property
    def box_shift(self) -> float:
        """Change of ln Z when every box doubles: −(pinned + coefficients)·ln 2."""
        return -(self.pinned + self.coefficients) * float(np.log(2.0))


def direct_constant(n_data: int) -> float:
    """log p(y | θ) − (−(L/2)·log MSE) with σ under Jeffreys' prior: log Γ(L/2) − (L/2)·log(π·L) − log 2."""
    k = 0.5 * n_data
    return float(gammaln(k) - k * np.log(np.pi * n_data) - np.log(2.0))


def coefficient_log_volume(solution, force) -> np.ndarray:
    """log V(θ) of the uniform box of every free coefficient, one per row: Σ_j log(2·COEF_RANGE·‖F‖/‖X_j‖),
    ‖X_j‖ from the factor (XᵀX = RᵀR: the norm of R's column j)."""
    norms = np.sqrt(np.sum(np.asarray(solution.R, dtype=float) ** 2, axis=1))  # (m, p)
    with np.errstate(divide="ignore"):
        return np.sum(np.log(2.0 * COEF_RANGE * np.linalg.norm(force) / norms), axis=1)


def log_mean_exp(values: np.ndarray) -> tuple[float, float]:
    """(log of the mean of exp(values), its standard error by the delta method), over finite values."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if not v.size:
        return float("-inf"), float("inf")
    top = float(v.max())
    w = np.exp(v - top)
    mean = float(w.mean())
    err = float(w.std(ddof=1) / (np.sqrt(len(w)) * mean)) if len(w) > 1 else float("inf")
    return top + float(np.log(mean)), err


def log_likelihoods(problem, P) -> tuple[np.ndarray, np.ndarray]:
    """(what the sampler's likelihood is, the comparable log p(y | θ)) of each parameter row of P: equal
    up to ``direct_constant`` in a direct formulation; in the identifiable one the comparable value is
    the flat-prior marginal over the coefficients' box volume (module docstring). Its shift under a
    change of the force's unit (F → s·F) is −L·log s for every model, as a density of the data must be."""
    from bwbench.problems.hysteresis.marginal import log_marginal

    P = np.atleast_2d(np.asarray(P, dtype=float))
    if getattr(problem, "formulation", "") != "identifiable":
        n = int(problem.n_data)
        with np.errstate(divide="ignore", invalid="ignore"):
            sampled = -0.5 * n * np.log(problem.loss_batch(P))
        return sampled, sampled + direct_constant(n)
    solution = problem.solve(P)
    sampled = log_marginal(solution, prior="scale-free", varying=len(problem.design.w_names))
    with np.errstate(invalid="ignore"):
        comparable = log_marginal(solution, prior="flat") - coefficient_log_volume(solution, problem.specimen.f)
    return sampled, comparable


def identifiable_correction(problem, P) -> tuple[float, float]:
    """(log E[p_comparable/p_sampled], its error) over the posterior draws P (rows) of a problem."""
    sampled, comparable = log_likelihoods(problem, P)
    with np.errstate(invalid="ignore"):
        return log_mean_exp(comparable - sampled)


def best_log_likelihood(pc, study=None) -> float:
    """The best comparable log p(y | θ) known for a posterior's model: over its ``TOP`` most likely draws
    and, with ``study``, that model's best ranking fit on the specimen inside the box. ln Z, the mean of
    p(y | θ) over the prior, cannot exceed it unless a better θ exists that neither the sampler nor the
    ranking found: an upper bound of ln Z that needs no converged run."""
    from bwbench.problems.hysteresis.report.posterior_draws import best_ranking_fit

    problem = pc.problem
    flat = pc.chain.samples.reshape(-1, pc.chain.samples.shape[2])
    lp = (
        np.asarray(pc.chain.log_prob, dtype=float).reshape(-1) if pc.chain.log_prob is not None else np.zeros(len(flat))
    )
    order = np.argsort(np.where(np.isfinite(lp), lp, -np.inf))[-TOP:]
    U = [flat[order]]
    if study is not None:
        found = best_ranking_fit(study, problem, pc.chain.specimen)
        if found is not None:
            U.append(np.asarray(found[0], dtype=float)[None, :])
    values = log_likelihoods(problem, problem.from_unit(np.vstack(U)))[1]
    return float(np.max(values[np.isfinite(values)])) if np.isfinite(values).any() else float("-inf")


def pinned_count(pc) -> int:
    """Searched parameters whose central 95 % interval (unit coordinates) spans < ``PINNED_WIDTH`` of the box."""
    flat = pc.chain.samples.reshape(-1, pc.chain.samples.shape[2])
    lo, hi = np.quantile(flat, [0.025, 0.975], axis=0)
    return int(np.sum(hi - lo < PINNED_WIDTH))


def evidence(pc, rng) -> Evidence:
    """The comparable evidence of a nested-sampling ``posterior_draws.PosteriorChain``."""
    ev = pc.nested["evidence"]
    problem = pc.problem
    coefficients = 0
    if getattr(problem, "formulation", "") == "identifiable":
        flat = pc.chain.samples.reshape(-1, pc.chain.samples.shape[2])
        pick = rng.choice(len(flat), size=min(DRAWS, len(flat)), replace=False)
        correction, err = identifiable_correction(problem, problem.from_unit(flat[pick]))
        coefficients = problem.solve(problem.from_unit(flat[pick[:1]])).n_free
    else:
        correction, err = direct_constant(int(problem.n_data)), 0.0
    return Evidence(
        ev["log_z"] + correction,
        float(np.hypot(ev["err"], err)),
        ev["log_z"],
        correction,
        pinned_count(pc),
        coefficients,
    )


def table(chains, rng=None, study=None, bands: dict | None = None) -> pd.DataFrame:
    """One row per nested posterior: ``model``, ``ln Z``, ``±``, ``ln B against the best`` (of its
    specimen), ``specimen``, the box shift, the bound ``best log-likelihood`` (``best_log_likelihood``)
    and the predictive check (numbers, not text)."""
    rng = np.random.default_rng(0) if rng is None else rng
    rows = []
    for pc in chains:
        if pc.nested is None:
            continue
        e = evidence(pc, rng)
        check = predictive_check(pc, rng, bands)
        rows.append(
            {
                "model": model_of(pc),
                "ln Z": e.log_z,
                "±": e.err,
                "specimen": pc.chain.specimen,
                "formulation": getattr(pc.problem, "formulation", ""),
                "box shift": e.box_shift,
                "best log-likelihood": best_log_likelihood(pc, study),
                "pinned": e.pinned,
                "coefficients": e.coefficients,
                "outside": np.nan if check is None else check.outside,
                "outside near reversals": np.nan if check is None else check.outside_reversal,
                "residual near reversals": np.nan if check is None else check.residual_reversal,
                "samples near reversals": np.nan if check is None else check.samples_reversal,
                "band draws": 0 if check is None else check.draws,
                "converged": bool(pc.nested["converged"]),
            }
        )
    frame = pd.DataFrame(rows)
    if not len(frame):
        return frame
    best = frame.groupby("specimen")["ln Z"].transform("max")
    frame.insert(3, "ln B against the best", frame["ln Z"] - best)
    return frame


def shown(frame: pd.DataFrame) -> pd.DataFrame:
    """The table as the report prints it: ``| model | ln Z | ± | ln B against the best | specimen | ...``."""

    def pct(x):
        return "–" if not np.isfinite(x) else f"{100 * x:.1f} %"

    def band(x, draws):
        # a band of a few draws (a run cut early keeps few equal-weight draws) is no check of the model
        few = draws < FEW_DRAWS
        return pct(x) + (f" (from {draws} draw{'s' if draws != 1 else ''}: no check)" if few and np.isfinite(x) else "")

    return pd.DataFrame(
        {
            "model": frame["model"],
            "ln Z": [f"{z:.2f}" for z in frame["ln Z"]],
            "±": [f"{e:.2f}" for e in frame["±"]],
            "ln B against the best": [f"{b:+.2f}" for b in frame["ln B against the best"]],
            "specimen": frame["specimen"],
            "Δ ln Z, every box ×2": [f"{s:+.1f}" for s in frame["box shift"]],
            "best log-likelihood (ln Z ≤)": [
                f"{b:.1f}" for b in frame.get("best log-likelihood", np.full(len(frame), np.nan))
            ],
            "outside the 95 % band": [
                band(x, d) for x, d in zip(frame["outside"], frame.get("band draws", np.full(len(frame), FEW_DRAWS)))
            ],
            "share of the squared residual near reversals": [
                "–" if not np.isfinite(r) else f"{100 * r:.0f} % (on {100 * s:.0f} % of the samples)"
                for r, s in zip(frame["residual near reversals"], frame["samples near reversals"])
            ],
            "converged": ["yes" if c else "no" for c in frame["converged"]],
        }
    )


def verdicts(frame: pd.DataFrame) -> list[str]:
    """One sentence per specimen: the model the evidence favours, by how much, whether the box can flip
    it, and where the others' residual concentrates."""
    out = []
    for specimen, group in frame.groupby("specimen", sort=False):
        group = group.sort_values("ln Z", ascending=False)
        best = group.iloc[0]
        if len(group) < 2:
            out.append(f"{specimen}: one model ({best['model']}), nothing to weigh it against.")
            continue
        second = group.iloc[1]
        gap = best["ln Z"] - second["ln Z"]
        err = float(np.hypot(best["±"], second["±"]))
        flip = abs(best["box shift"] - second["box shift"])
        text = (
            f"{specimen}: the evidence favours **{best['model']}** — ln B = {gap:.1f} ± {err:.1f} over the next, "
            f"{second['model']}" + (f" (odds of about e^{gap:.0f})" if gap >= 1 else "") + ". "
        )
        if gap <= 2 * err:
            text += "Within twice its error: the data do not decide between them. "
        bounds = group.iloc[1:].get("best log-likelihood")
        if bounds is not None and np.all(np.isfinite(bounds)) and best["ln Z"] - 2 * best["±"] > bounds.max():
            text += (
                "Conclusive whatever the other runs' convergence: its ln Z exceeds the best log-likelihood known for "
                "every other model, which bounds their ln Z from above. "
            )
        text += f"Doubling every box would move that ln B by {best['box shift'] - second['box shift']:+.1f}" + (
            ", far less than it: the verdict does not hang on the box."
            if flip < 0.2 * gap
            else ", comparable to it: the verdict depends on the boxes."
        )

        def checked(r):
            return np.isfinite(r["residual near reversals"]) and r.get("band draws", FEW_DRAWS) >= FEW_DRAWS

        worse = [r for _, r in group.iloc[1:].iterrows() if checked(r)]
        if worse:
            text += (
                " "
                + "; ".join(
                    f"{r['model']}'s measured force leaves its 95 % band at {100 * r['outside']:.0f} % of the samples"
                    + (
                        f", {100 * r['residual near reversals']:.0f} % of its squared residual near reversals "
                        f"({100 * r['samples near reversals']:.0f} % of the samples)"
                    )
                    for r in worse
                )
                + "."
            )
        if checked(best):
            text += (
                f" {best['model']}: {100 * best['outside']:.1f} % outside its band (about 5 % when the model holds)."
            )
        out.append(text)
    return out


TEXT = (
    "Model evidence of each nested-sampling posterior, comparable between models of one specimen: "
    "σ under Jeffreys' prior (common to all models), each searched parameter uniform on its box, and in the "
    f"identifiable formulation each linear coefficient uniform on ±{COEF_RANGE:g}·‖F‖/‖X_j‖ (its term alone "
    f"within ±{COEF_RANGE:g} times the measured force, RMS), the sampler's improper-prior evidence moved to it by "
    "importance weights over the posterior draws. ln B against the best is the log Bayes factor (0 for the "
    "best model; −5 is odds of 1 to 150). Doubling every box lowers ln Z by ln 2 for each parameter the "
    "data pin down (here: a searched parameter whose 95 % interval spans less than half its box, and every "
    "linear coefficient); the column says by how much. ln Z, the mean likelihood over the prior, cannot exceed the "
    "best log-likelihood known (the sampler's most likely draws and the model's best ranking fit, in the same units): "
    "a bound that needs no converged run. The predictive check: the share of measured samples "
    "outside the 95 % band of the posterior's predicted measurement (about 5 % when the model holds), and the "
    f"share of the squared residual near the reversals (|ẋ| under {REVERSAL:.0%} of its peak), where hysteresis "
    "models differ."
)


def section(report, chains) -> None:
    """The model-evidence subsection of the posterior section: nothing without a nested posterior."""
    bands: dict = {}
    frame = table(chains, study=report.study, bands=bands)
    if not len(frame):
        return
    doc = report.doc
    doc.h(3, "Model evidence")
    doc.table(
        shown(frame),
        "Model evidence of each posterior (the runs' ln Z pooled, made comparable between "
        "models), the log Bayes factor against the best model of the specimen, ln Z's change "
        "when every box doubles, and the posterior predictive check",
    )
    doc.p(TEXT)
    if not frame["converged"].all():
        doc.p(
            "A posterior that is not converged gives a rough ln Z (its runs' spread is in ±); a Bayes factor "
            "many times its error still ranks the models."
        )
    for text in verdicts(frame):
        doc.p(text)
    for specimen in dict.fromkeys(frame["specimen"]):
        shown_bands = [
            (model, pc, band) for (s, model), (pc, band) in bands.items() if s == specimen and band.draws >= FEW_DRAWS
        ]
        if len(shown_bands) > 1 or (len(shown_bands) == 1 and len(frame[frame["specimen"] == specimen]) > 1):
            png = residual_figure(report.study, doc.out_dir, specimen, shown_bands)
            doc.figure(
                png,
                f"{specimen}: each model's residual (measured force − the posterior's median model force) "
                "against time, within the 95 % band of the predicted measurement; grey: near the "
                "displacement's reversals",
            )
