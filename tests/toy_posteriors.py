"""Toy problems whose posterior is known, for the sampler and the spread decomposition.

Each is a least-squares problem on the unit box (identity map) with ``residual_batch`` and
``loss_batch`` (MSE), so the emcee backend's posterior is the Gaussian likelihood with σ integrated
out, −(L/2)·log MSE, under a uniform prior on the box.
"""

from __future__ import annotations

import numpy as np


class ToyProblem:
    """Residual r(u) = model(u) − y on ``n_data`` points; subclasses fill in ``model``."""

    def __init__(self, dim: int, n_data: int, seed: int = 0, noise: float = 0.1):
        self.dim, self.n_data = dim, n_data
        self.param_names = tuple(f"p{i}" for i in range(dim))
        self.lower, self.upper = np.zeros(dim), np.ones(dim)
        self.info: dict = {}
        self.noise = noise
        rng = np.random.default_rng(seed)
        self.x = np.linspace(-1.0, 1.0, n_data)
        self.y = self.model(np.atleast_2d(self.truth))[0] + rng.normal(0.0, noise, n_data)

    def from_unit(self, U):
        return np.asarray(U, dtype=float)

    def to_unit(self, P):
        return np.asarray(P, dtype=float)

    def residual_batch(self, P):
        return self.model(np.atleast_2d(np.asarray(P, dtype=float))) - self.y

    def loss_batch(self, P):
        return np.mean(self.residual_batch(P) ** 2, axis=1)


class LinearToy(ToyProblem):
    """y = a + b·x: a Gaussian posterior of known covariance σ²·(XᵀX)⁻¹ (σ = ``noise``)."""

    truth = np.array([0.45, 0.55])

    def model(self, P):
        return P[:, :1] + P[:, 1:2] * self.x[None, :]

    def posterior_sd(self) -> np.ndarray:
        X = np.column_stack([np.ones_like(self.x), self.x])
        return self.noise * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))


class BimodalToy(ToyProblem):
    """y = (2·p0 − 1)²·x + p1: p0 = 0.5 ± s give the same force, so the posterior has two equal modes at
    p0 ≈ 0.25 and 0.75 with a valley between them (at p0 = 0.5 the slope vanishes)."""

    truth = np.array([0.25, 0.5])

    def model(self, P):
        return (2 * P[:, :1] - 1) ** 2 * self.x[None, :] + P[:, 1:2]
