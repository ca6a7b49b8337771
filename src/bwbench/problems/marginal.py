"""Marginal likelihood of the hysteretic parameters, the linear coefficients integrated out.

Model: y = X(θ)·β + ε, ε ~ N(0, σ²·I), L samples, p free linear coefficients (``LinearSolution``).
With a flat prior p(β) = 1 on ℝ^p, completing the square around β̂ (RSS = ‖y − Xβ̂‖²):

    p(y | θ, σ) = (2πσ²)^(−(L−p)/2) · |XᵀX|^(−1/2) · exp(−RSS/(2σ²)).

With also p(σ) = 1/σ (Jeffreys), substituting u = σ², ∫ u^(−k−1)·e^(−RSS/(2u)) du = Γ(k)·(RSS/2)^(−k),
k = (L − p)/2:

    log p(y | θ) = −k·log RSS − ½·log|XᵀX| + log Γ(k) − k·log π − log 2.

Both are exact (constants included) relative to those improper priors, so they compare θ values
but not models with different p. log|XᵀX| = 2·Σ log|R_ii| from the factor the solve already has.
Conditional draws: σ² | θ, y ~ Inv-Gamma(k, RSS/2), β | σ², θ, y ~ N(β̂, σ²·(XᵀX)⁻¹), drawn as
β̂ + σ·R⁻¹·ε, ε ~ N(0, I).

Caveat of the flat prior on h: as w becomes collinear with the other columns (x_y ≫ amplitude
makes w ∝ x) |XᵀX| → 0 and the marginal → +∞ while the fit does not improve; the search box
bounds this. Rows without a full-rank design (``full_rank`` False) get −inf. The bound m ≥ 0 of
the point estimate is not part of this prior: these functions use the unbounded LS quantities.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import solve_triangular
from scipy.special import gammaln

from bwbench.problems.linear_solve import LinearSolution


def log_marginal(sol: LinearSolution, sigma: float | None = None) -> np.ndarray:
    """log p(y | θ, σ) (``sigma`` in N given) or log p(y | θ) (σ integrated out), one per row (m,).

    −inf for rows that blew up or whose design is not of full rank.
    """
    L, p = sol.n_data, sol.n_free
    k = 0.5 * (L - p)
    if k <= 0:
        raise ValueError(f"need more samples ({L}) than free coefficients ({p})")
    rss = np.asarray(sol.rss_ls, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        if sigma is None:
            out = -k * np.log(rss) - 0.5 * sol.logdet + gammaln(k) - k * np.log(np.pi) - np.log(2.0)
        else:
            s2 = float(sigma) ** 2
            out = -k * np.log(2 * np.pi * s2) - 0.5 * sol.logdet - rss / (2 * s2)
    ok = np.isfinite(rss) & sol.full_rank
    return np.where(ok & np.isfinite(out), out, -np.inf)


def draw_linear(sol: LinearSolution, rng: np.random.Generator, size: int, sigma: float | None = None) -> dict:
    """Exact draws of (σ, β) given θ for a one-row solution (``sol.row(i)``).

    Returns ``sigma`` (size,) N — drawn from Inv-Gamma((L−p)/2, RSS/2) unless given — and
    ``coef`` (size, k) in ``sol.names`` order: free coefficients drawn from N(β̂, σ²(XᵀX)⁻¹),
    fixed ones at their fixed value.
    """
    if len(sol.mse) != 1:
        raise ValueError("draw_linear takes the results of one θ row: use sol.row(i)")
    if not (np.isfinite(sol.rss_ls[0]) and sol.full_rank[0]):
        raise ValueError("no posterior: the trajectory blew up or the design is not of full rank")
    L, p = sol.n_data, sol.n_free
    if sigma is None:
        k = 0.5 * (L - p)
        s2 = 0.5 * sol.rss_ls[0] / rng.gamma(k, 1.0, size)
    else:
        s2 = np.full(size, float(sigma) ** 2)
    eps = rng.standard_normal((p, size))
    beta = sol.coef_ls[0][:, None] + solve_triangular(sol.R[0], eps) * np.sqrt(s2)
    coef = np.repeat(sol.coef[:1], size, axis=0)
    coef[:, sol.free_index] = beta.T
    return {"sigma": np.sqrt(s2), "coef": coef, "names": sol.names}
