"""A search box whose coordinates may be log-scaled: the map between unit coordinates and physical units.

Optimisers work in u ∈ [0, 1]^d; a log-scaled parameter maps linearly in log10 (it needs a positive
lower bound), the others linearly.
"""

from __future__ import annotations

import numpy as np


def box_from_unit(U, lower, upper, log_scaled) -> np.ndarray:
    """Unit coordinates (shape (..., d)) → physical units; log-scaled entries linear in log10."""
    lo, hi = _box_span(lower, upper, log_scaled)
    x = lo + np.asarray(U, dtype=float) * (hi - lo)
    return np.where(log_scaled, 10.0 ** np.where(log_scaled, x, 0.0), x)


def box_to_unit(P, lower, upper, log_scaled) -> np.ndarray:
    """Physical units → unit coordinates; the inverse of ``box_from_unit``."""
    lo, hi = _box_span(lower, upper, log_scaled)
    P = np.asarray(P, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        x = np.where(log_scaled, np.log10(np.where(log_scaled, P, 1.0)), P)
    return (x - lo) / (hi - lo)


def box_derivative(P, lower, upper, log_scaled) -> np.ndarray:
    """∂P/∂u of ``box_from_unit`` at physical point(s) P (..., d): the span, or P·ln 10·the log span."""
    lo, hi = _box_span(lower, upper, log_scaled)
    P = np.asarray(P, dtype=float)
    return np.where(log_scaled, P * np.log(10.0) * (hi - lo), hi - lo)


def _box_span(lower, upper, log_scaled):
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    lo = np.where(log_scaled, np.log10(np.where(log_scaled, lower, 1.0)), lower)
    hi = np.where(log_scaled, np.log10(np.where(log_scaled, upper, 1.0)), upper)
    return lo, hi
