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


class DensityToy:
    """A problem whose log-likelihood is a given density on the unit box (identity map), for samplers
    that read ``log_likelihood_batch``; the loss is −log-likelihood shifted to be ≥ 0 (MSE-like)."""

    n_data = 1

    def __init__(self, dim: int):
        self.dim = dim
        self.param_names = tuple(f"p{i}" for i in range(dim))
        self.lower, self.upper = np.zeros(dim), np.ones(dim)
        self.info: dict = {}

    def from_unit(self, U):
        return np.asarray(U, dtype=float)

    def to_unit(self, P):
        return np.asarray(P, dtype=float)

    def loss_batch(self, P):
        return self.log_likelihood_batch(P)[0]

    def log_likelihood_batch(self, P):
        ll = self.log_density(np.atleast_2d(np.asarray(P, dtype=float)))
        return self.peak - ll, ll


def _log_normal(P, mean, sd):
    z = (P - mean) / sd
    return np.sum(-0.5 * z**2 - np.log(sd * np.sqrt(2 * np.pi)), axis=1)


class GaussianToy(DensityToy):
    """L(u) = N(u; mean, diag sd²) times ``exp(log_scale)``: ln Z over the unit box is ``log_scale`` plus
    the log of the box's Gaussian probability, a product of normal CDF differences (closed form)."""

    def __init__(self, mean, sd, log_scale: float = -30.0):
        super().__init__(len(mean))
        self.mean, self.sd, self.log_scale = np.asarray(mean, float), np.asarray(sd, float), float(log_scale)
        self.peak = self.log_scale + _log_normal(self.mean[None, :], self.mean, self.sd)[0]

    def log_density(self, P):
        return self.log_scale + _log_normal(P, self.mean, self.sd)

    def log_z(self) -> float:
        from scipy.stats import norm

        inside = norm.cdf((1 - self.mean) / self.sd) - norm.cdf(-self.mean / self.sd)
        return self.log_scale + float(np.sum(np.log(inside)))


class MixtureToy(DensityToy):
    """Separated Gaussian modes of masses ``weights`` (e.g. 0.7/0.3): their centres ``centres``, an sd
    (one for all, or one per mode), well inside the box, so each mode's posterior mass is its weight and
    ln Z = 0."""

    def __init__(self, centres, sd, weights):
        centres = np.asarray(centres, float)
        super().__init__(centres.shape[1])
        self.centres, self.weights = centres, np.asarray(weights, float)
        self.sd = np.broadcast_to(np.asarray(sd, float), (len(centres),))
        self.peak = float(np.max(self.log_density(centres)))

    def log_density(self, P):
        parts = [
            np.log(w) + _log_normal(P, c, np.full(self.dim, s)) for c, s, w in zip(self.centres, self.sd, self.weights)
        ]
        return np.logaddexp.reduce(np.stack(parts), axis=0)


class RidgeToy(DensityToy):
    """A thin straight ridge p0 + p1 = 1 (Gaussian across it, sd ``sd``), flat along it, other coordinates
    Gaussian at 0.5: the data pin one combination and leave another to the prior."""

    def __init__(self, dim: int = 3, sd: float = 0.01):
        super().__init__(dim)
        self.sd = sd
        self.peak = 0.0

    def log_density(self, P):
        across = (P[:, 0] + P[:, 1] - 1.0) / (self.sd * np.sqrt(2))
        rest = ((P[:, 2:] - 0.5) / 0.05) ** 2
        return -0.5 * across**2 - 0.5 * np.sum(rest, axis=1)
