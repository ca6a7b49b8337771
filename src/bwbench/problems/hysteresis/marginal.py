"""Marginal likelihood of the hysteretic parameters, the linear coefficients integrated out.

Model: y = X(θ)·β + ε, ε ~ N(0, σ²·I), L samples, p free linear coefficients (``LinearSolution``):
X = [G | W], G the p_G columns that do not depend on θ (ẍ, ẋ, x, 1 per branch), W the q columns
that do (the switched model's w per branch, Spencer's ẏ).

Prior "flat": p(β) = 1 on ℝ^p. Completing the square around β̂ (RSS = ‖y − Xβ̂‖²):

    p(y | θ, σ) = (2πσ²)^(−(L−p)/2) · |XᵀX|^(−1/2) · exp(−RSS/(2σ²)).

With also p(σ) = 1/σ (Jeffreys), substituting u = σ², ∫ u^(−k−1)·e^(−RSS/(2u)) du = Γ(k)·(RSS/2)^(−k),
k = (L − p)/2:

    log p(y | θ) = −k·log RSS − ½·log|XᵀX| + log Γ(k) − k·log π − log 2.

Both are exact (constants included) relative to those improper priors.

The flat prior is not invariant to the scale of W: w's unit is a gauge of the model (the switched
model's w = z/z_s₊, so the '−' branch's column scales with ρ), and |XᵀX| = |GᵀG|·|W⊥ᵀW⊥| (W⊥: W
orthogonal to G) changes with that scale and goes to 0 as W becomes collinear with G (x_y ≫ the
amplitude makes w ∝ x): the marginal then grows without the fit improving. On the shipped specimens
it pushed the posterior by e^5 towards ρ → 0 and x_y₊ → its cap, away from truths that fit as well.

Prior "scale-free" (the default of ``IdentifiableProblem.log_likelihood_batch``): flat on the
coefficients of G, and Zellner's g-prior on those of W, h | σ² ~ N(0, g·σ²·(W⊥ᵀW⊥)⁻¹), in the limit
g → ∞. It is invariant to any rescaling of W and has no volume term in it; integrating γ, h and σ
(Jeffreys) gives, with k' = (L − p_G)/2 and up to the constant (1 + g)^(−q/2),

    log p(y | θ) = −k'·log RSS − ½·log|GᵀG| + log Γ(k') − k'·log π − log 2,

i.e. the posterior of θ is the likelihood with σ integrated out: every θ that fits as well is as
probable. Conditionally on θ the limit gives the flat prior's Gaussian for β and σ² ~ Inv-Gamma(k', RSS/2).

log|XᵀX| = 2·Σ log|R_ii| from the factor the solve already has (G's block first). Rows that blew up
get −inf; under "flat" so do rows without a full-rank design (``full_rank`` False). Conditional
draws: σ² | θ, y ~ Inv-Gamma(k, RSS/2), β | σ², θ, y ~ N(β̂, σ²·(XᵀX)⁻¹), drawn as β̂ + σ·R⁻¹·ε,
ε ~ N(0, I). The bound m ≥ 0 of the point estimate is not part of these priors: these functions use
the unbounded LS quantities.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import gammaln

from bwbench.problems.hysteresis.linear.solve import LinearSolution

PRIORS = ("flat", "scale-free")


def log_marginal(
    sol: LinearSolution, sigma: float | None = None, *, prior: str = "flat", varying: int = 0
) -> np.ndarray:
    """log p(y | θ, σ) (``sigma`` in N given) or log p(y | θ) (σ integrated out), one per row (m,).

    ``prior``: "flat" or "scale-free" (module docstring); ``varying``: q, the number of θ-dependent
    columns, last in ``sol.free_names`` (needed by "scale-free"). −inf for rows that blew up, and
    under "flat" for rows whose design is not of full rank.
    """
    if prior not in PRIORS:
        raise ValueError(f"prior must be one of {PRIORS}, got {prior!r}")
    L, p = sol.n_data, sol.n_free
    fixed = p - int(varying) if prior == "scale-free" else p
    k = 0.5 * (L - fixed)
    if 0.5 * (L - p) <= 0:
        raise ValueError(f"need more samples ({L}) than free coefficients ({p})")
    rss = np.asarray(sol.rss_ls, dtype=float)
    if prior == "flat":
        logdet, ok = sol.logdet, sol.full_rank
    else:  # |GᵀG| from G's block of the factor: the same for every row
        diag = np.abs(np.diagonal(sol.R, axis1=1, axis2=2))[:, :fixed]
        with np.errstate(divide="ignore"):
            logdet, ok = 2.0 * np.sum(np.log(diag), axis=1), np.ones(len(rss), dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        if sigma is None:
            out = -k * np.log(rss) - 0.5 * logdet + gammaln(k) - k * np.log(np.pi) - np.log(2.0)
        else:
            s2 = float(sigma) ** 2
            out = -k * np.log(2 * np.pi * s2) - 0.5 * logdet - rss / (2 * s2)
    ok = ok & np.isfinite(rss)
    return np.where(ok & np.isfinite(out), out, -np.inf)


def draw_linear(
    sol: LinearSolution, rng: np.random.Generator, size: int, sigma: float | None = None, *, varying: int = 0
) -> dict:
    """Exact draws of (σ, β) given θ for a one-row solution (``sol.row(i)``).

    Returns ``sigma`` (size,) N — drawn from Inv-Gamma((L−p)/2, RSS/2) unless given, (L − p + q)/2 with
    ``varying`` = q > 0 (the "scale-free" prior) — and
    ``coef`` (size, k) in ``sol.names`` order: free coefficients drawn from N(β̂, σ²(XᵀX)⁻¹),
    fixed ones at their fixed value.
    """
    if len(sol.mse) != 1:
        raise ValueError("draw_linear takes the results of one θ row: use sol.row(i)")
    if not (np.isfinite(sol.rss_ls[0]) and sol.full_rank[0]):
        raise ValueError("no posterior: the trajectory blew up or the design is not of full rank")
    L, p = sol.n_data, sol.n_free
    if sigma is None:
        k = 0.5 * (L - p + int(varying))
        s2 = 0.5 * sol.rss_ls[0] / rng.gamma(k, 1.0, size)
    else:
        s2 = np.full(size, float(sigma) ** 2)
    eps = rng.standard_normal((p, size))
    beta = sol.coef_ls[0][:, None] + solve_triangular(sol.R[0], eps) * np.sqrt(s2)
    coef = np.repeat(sol.coef[:1], size, axis=0)
    coef[:, sol.free_index] = beta.T
    return {"sigma": np.sqrt(s2), "coef": coef, "names": sol.names}
