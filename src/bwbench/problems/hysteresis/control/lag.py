"""Spencer et al. (1997)'s first-order lag between a command v and the control u that acts: u̇ = −η·(u − v)."""

from __future__ import annotations

import numba
import numpy as np

FILTER = "eta_u"  # the name of the lag's rate, 1/s


def filtered(v, dt, eta: float):
    """(u at the samples, u averaged over each interval) of u̇ = −η·(u − v) for a command v held over each
    interval, u = v at the first sample (exact for the held command)."""
    v = np.asarray(v, dtype=float)
    decay = np.exp(-eta * np.asarray(dt, dtype=float))
    u = _lag(v, decay)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(eta * dt > 1e-12, (1.0 - decay) / (eta * dt), 1.0)
    mean = v[:-1] + (u[:-1] - v[:-1]) * share
    return u, mean


@numba.njit(cache=True)
def _lag(v, decay):
    u = np.empty_like(v)
    u[0] = v[0]
    for k in range(len(decay)):
        u[k + 1] = v[k] + (u[k] - v[k]) * decay[k]
    return u
