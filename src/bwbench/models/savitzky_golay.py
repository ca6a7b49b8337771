"""Savitzky–Golay smoothing and differentiation of a uniformly sampled signal, in numpy.

The same filter as ``scipy.signal.savgol_filter(x, window, polyorder, deriv, delta, mode="interp")``
(tested against it to round-off), written out because importing ``scipy.signal`` costs ~1 s — more
than a whole fit with the paper's GA — and every command that reads a specimen needs the filter.

Each interior point gets the derivative at its centre of the least-squares polynomial of degree
``polyorder`` through the ``window`` samples around it (a correlation with fixed coefficients); the
first and last ``window // 2`` points take the derivatives of the polynomial fitted to the first and
last ``window`` samples ("interp" edges).
"""

from __future__ import annotations

import math

import numpy as np


def savgol(x, window: int, polyorder: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """The ``deriv``-th derivative of the Savitzky–Golay fit of ``x`` (1-D) at every sample; ``delta``
    is the sample spacing. ``window`` odd and ≤ len(x), ``polyorder`` < ``window``."""
    x = np.asarray(x, dtype=float)
    if window % 2 != 1 or window > x.size or not 0 <= polyorder < window:
        raise ValueError(f"need an odd window ≤ {x.size} and 0 ≤ polyorder < window, got {window}, {polyorder}")
    half = window // 2
    offsets = np.arange(-half, half + 1, dtype=float)
    # Polynomial coefficients c (in powers of the offset) = pinv(V) @ samples.
    pinv = np.linalg.pinv(np.vander(offsets, polyorder + 1, increasing=True))
    scale = 1.0 / delta**deriv
    out = np.empty_like(x)
    if deriv <= polyorder:
        centre = math.factorial(deriv) * pinv[deriv] * scale
        out[half:x.size - half] = np.correlate(x, centre, mode="valid")
    else:
        out[:] = 0.0
        return out
    # d^deriv/ds^deriv of Σ c_j s^j at the edge offsets
    powers = np.arange(polyorder + 1)
    falling = np.array([math.perm(j, deriv) if j >= deriv else 0 for j in powers], dtype=float)
    for rows, samples in ((slice(0, half), x[:window]), (slice(x.size - half, x.size), x[-window:])):
        c = pinv @ samples
        s = offsets[:half] if rows.start == 0 else offsets[half + 1:]
        exponents = np.clip(powers - deriv, 0, None)
        out[rows] = (s[:, None] ** exponents[None, :] * falling * c).sum(axis=1) * scale
    return out
