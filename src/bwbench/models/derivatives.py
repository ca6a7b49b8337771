"""Velocity and acceleration estimated from a sampled displacement, when the file does not record them.

The estimator (chosen by ``benchmarks/bench_differentiator.py`` on exact ramps with smooth reversals,
sines and random motions at 0.5–10 Hz with 0–5 µm encoder noise; docs/file-formats.md#signals-recorded-or-estimated),
linear in the record's length (``benchmarks/bench_signal_speed.py``: the time per sample is flat from 10⁴ to 10⁷):

1. σ̂, the displacement noise, from the 4th differences of the record (``robust_noise``): a robust
   estimate that smooth motion barely touches (its 4th differences are tiny) and that sees the
   print resolution of a noise-free file as the noise it is.
2. A discrete quintic smoothing spline (Whittaker–Henderson: minimise Σ(y − z)² + λ·Σ(Δ³z)², a banded
   symmetric system solved by banded Cholesky in O(n)) with the classical smoothing condition
   Σ residual² = L·σ̂²: λ is found by bisection on log λ; on a long record on evenly spread windows
   of it (the smoother is local: its kernel spans λ^(1/6) samples), so the whole record is solved once.
   Each end is extended by a cubic fitted to its last samples before smoothing (else the penalty bends
   the ends straight). x̂, ẋ and ẍ are the quintic interpolating spline through z, continued beyond the
   ends by point reflection, and its derivatives (banded, O(n)).
3. Within 2k samples of each end, a velocity that differs from the interpolating spline's (through the
   raw samples) by more than 4 of that spline's noise standard deviations (σ̂ times its noise gain at
   that position) is replaced by the interpolating spline's values.

Until this round the smoothing spline was FITPACK's (``UnivariateSpline``, k = 5, knots placed
adaptively), super-linear in the length (a 400k-sample record took minutes). On the benchmark's 48
cases the force error this estimator causes is, per case, 1.08× FITPACK's (geometric mean; worst
case 12.8 N against 14.0 N): worse on noisy slow ramps (up to 2×, where adaptive knots smooth the
straight parts more), better on noisy random motions (up to 10×).
``velocity_error`` estimates the RMS error of the estimated velocity (a parametric bootstrap).
The long steps are single C calls of at most a few seconds on 10⁷ samples: Ctrl-C is seen between them.
scipy is imported only here, when a velocity is estimated: it costs 0.3–0.8 s of start-up.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from math import comb

import numpy as np

SPLINE_DEGREE = 5
END_TOLERANCE = 4.0  # noise standard deviations of the interpolating spline's velocity, at the ends
BOOTSTRAP_REPLICATES = 4
BOOTSTRAP_SEED = 20240521  # fixed: the same file always gives the same error estimate
SPLINE_NAME = "quintic smoothing spline"
# λ is calibrated on the whole record up to this many samples, beyond it on CALIBRATION_WINDOWS windows
# of WINDOW samples spread evenly over it; the bootstrap of ``velocity_error`` likewise.
WHOLE_RECORD = 40_000
WINDOW = 4_000
CALIBRATION_WINDOWS = 10
LOG_LAMBDA_RANGE = (
    -8.0,
    12.0,
)  # log10 λ searched; 10^12: a kernel of ~100 samples; far beyond, Cholesky fails in float64
REFLECTED = 16  # samples of point reflection beyond each end of the interpolating spline
PIECE = 1_000_000  # samples per interpolating-spline evaluation: Ctrl-C is seen between pieces


def robust_noise(y) -> float:
    """Standard deviation (units of y) of white noise on a smooth sampled signal: the median absolute
    deviation of its 4th differences (×1.4826, over √70 = their noise gain). Reversals, where the
    4th differences of the motion itself are large, are outliers the median ignores. 0 for < 5 samples."""
    d = np.diff(np.asarray(y, dtype=float), 4)
    if d.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(comb(8, 4)))


@dataclass(frozen=True, eq=False)  # eq=False: comparing ndarray fields would raise
class Derivatives:
    """Smoothed displacement x (mm), velocity v (mm/s) and acceleration a (mm/s²) at the sample
    times; ``noise`` is σ̂ (mm) and ``ends_replaced`` the number of end samples the guard replaced;
    ``smoothing`` is λ (0: the interpolating spline)."""

    x: np.ndarray
    v: np.ndarray
    a: np.ndarray
    noise: float
    ends_replaced: int
    smoothing: float = 0.0


@functools.lru_cache(maxsize=4)
def _end_gains(k: int, m: int) -> np.ndarray:
    """Noise gain of the interpolating spline's first derivative at the first m samples (unit step):
    the norm of the row of the linear map samples → derivative, from splines through unit vectors."""
    from scipy.interpolate import make_interp_spline

    n = max(4 * m, 32)
    spline = make_interp_spline(np.arange(n, dtype=float), np.eye(n), k=k)
    return np.linalg.norm(spline(np.arange(m, dtype=float), 1), axis=1)


def _degree(n: int) -> int:
    return SPLINE_DEGREE if n >= 4 * SPLINE_DEGREE else 3


PENALTY_ORDER = 3  # the difference penalised: the 3rd, as a quintic smoothing spline penalises the 3rd derivative


def _smooth(y: np.ndarray, lam: float) -> np.ndarray:
    """z minimising Σ(y − z)² + λ·Σ(Δ³z)²: (I + λ·D₃ᵀD₃) z = y, banded Cholesky (LAPACK pbsv), O(n)."""
    from scipy.linalg import solveh_banded

    n, q = y.size, PENALTY_ORDER
    if lam <= 0 or n < 8:
        return y.copy()
    d = np.array([(-1.0) ** (q - i) * comb(q, i) for i in range(q + 1)])  # the q-th difference
    ab = np.zeros((q + 1, n))  # upper banded form: row q the diagonal, row q - o the o-th superdiagonal
    for i in range(q + 1):  # row r of D_q adds d_i*d_j at (r + i, r + j)
        for j in range(i, q + 1):
            ab[q - (j - i), j : n - q + j] += lam * d[i] * d[j]
    ab[q] += 1.0
    return solveh_banded(ab, y, check_finite=False)


def _padded_smooth(y: np.ndarray, lam: float) -> np.ndarray:
    """``_smooth`` with each end extended by a cubic fitted to its last samples: without it the penalty
    bends the smoothed record towards a straight line over the kernel's width at each end (measured: a
    velocity 50× worse there on a sine). The extension is cropped again."""
    if lam <= 0 or y.size < 8:
        return y.copy()
    # three kernel widths of extension, fitted on twice that (at least 6 samples): no wider, or the cubic
    # misses a fast motion (a 5 Hz sine at 200 Hz) and the smoother follows it
    pad = int(np.clip(3.0 * lam ** (1.0 / 6.0), 2, max(2, y.size // 2)))
    fit = min(max(2 * pad, 6), y.size)
    s = np.arange(fit, dtype=float) / fit  # local abscissa, scaled for a well-conditioned fit
    ahead = np.arange(1, pad + 1, dtype=float) / fit
    head = np.polynomial.polynomial.polyval(-ahead[::-1], np.polynomial.polynomial.polyfit(s, y[:fit], 3))
    tail = np.polynomial.polynomial.polyval(1.0 - 1.0 / fit + ahead, np.polynomial.polynomial.polyfit(s, y[-fit:], 3))
    return _smooth(np.concatenate([head, y, tail]), lam)[pad : pad + y.size]


def _windows(n: int) -> list[slice]:
    """The whole record, or CALIBRATION_WINDOWS windows of WINDOW samples spread evenly over it."""
    if n <= WHOLE_RECORD:
        return [slice(0, n)]
    starts = np.linspace(0, n - WINDOW, CALIBRATION_WINDOWS).astype(int)
    return [slice(int(s), int(s) + WINDOW) for s in starts]


def smoothing_for(y: np.ndarray, sigma: float) -> float:
    """λ for which the smoothed record leaves residuals of rms σ (the smoothing condition); 0 when σ is."""
    if not sigma > 0:
        return 0.0
    pieces = [y[w] for w in _windows(y.size)]
    target = sigma**2 * sum(p.size for p in pieces)

    def excess(log_lam: float) -> float:
        lam = 10.0**log_lam
        return sum(float(np.sum((p - _padded_smooth(p, lam)) ** 2)) for p in pieces) - target

    low, high = LOG_LAMBDA_RANGE
    if excess(high) <= 0:  # even the smoothest allowed leaves less than the noise: as smooth as allowed
        return 10.0**high
    if excess(low) >= 0:
        return 0.0
    while high - low > 0.02:  # bisection on log λ: the residual grows monotonically with λ
        mid = 0.5 * (low + high)
        low, high = (mid, high) if excess(mid) < 0 else (low, mid)
    return 10.0 ** (0.5 * (low + high))


def _reflected_spline(t: np.ndarray, z: np.ndarray, k: int):
    """The interpolating spline of degree k through z, continued beyond each end by z's point reflection
    about its end sample (2·z₀ − z(t₀ − s)): the record's ends become interior points of the spline, whose
    derivative there no longer swings with the end samples' noise (measured: 20× the interior's error on
    a 5 Hz sine sampled at 200 Hz without it)."""
    from scipy.interpolate import make_interp_spline

    m = min(REFLECTED, z.size - 1)
    step = (t[-1] - t[0]) / (t.size - 1)
    head_t = t[0] - step * np.arange(m, 0, -1)
    tail_t = t[-1] + step * np.arange(1, m + 1)
    head = 2.0 * z[0] - z[m:0:-1]
    tail = 2.0 * z[-1] - z[-2 : -m - 2 : -1]
    return make_interp_spline(np.concatenate([head_t, t, tail_t]), np.concatenate([head, z, tail]), k=k)


def _evaluate(spline, t: np.ndarray, nu: int) -> np.ndarray:
    """``spline(t, nu)`` in pieces of PIECE samples (each piece is a short C call: Ctrl-C is seen)."""
    return np.concatenate([spline(t[i : i + PIECE], nu) for i in range(0, t.size, PIECE)])


def estimate(t, y, sigma: float | None = None, *, smoothing: float | None = None) -> Derivatives:
    """The estimator of the module docstring on samples y (t in s, strictly increasing, ≥ 8 samples).

    Works on any smooth signal (a recorded velocity gives the acceleration the same way); ``sigma``
    overrides the noise estimate, ``smoothing`` the λ found from it. Raises ValueError for mismatched
    or too short arrays.
    """
    from scipy.interpolate import make_interp_spline

    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.ndim != 1 or t.shape != y.shape or t.size < 8:
        raise ValueError("t and the signal must be 1-D arrays of equal length, at least 8 samples")
    step = float(np.median(np.diff(t)))
    # The noise estimate (differences), the difference penalty and the end guard's gains assume an even
    # grid. The specimen reader refuses worse (one line naming the file and line); this guards arrays
    # that did not come through it.
    if not step > 0 or np.max(np.abs(np.diff(t) - step)) > 0.01 * step:
        raise ValueError("estimating a derivative needs uniformly sampled, increasing time")
    sigma = robust_noise(y) if sigma is None else float(sigma)
    lam = smoothing_for(y, sigma) if smoothing is None else float(smoothing)
    k = _degree(y.size)
    spline = _reflected_spline(t, _padded_smooth(y, lam), k)
    ys, vs, acc = (_evaluate(spline, t, nu) for nu in (0, 1, 2))
    m = min(2 * k, y.size // 4)
    tolerance = END_TOLERANCE * _end_gains(k, m) * sigma / step
    replaced = 0
    span = min(y.size, max(8 * m, 64))  # the interpolating spline is local: the end's own samples pin it
    for piece, ends in ((slice(0, span), np.arange(m)), (slice(y.size - span, y.size), span - 1 - np.arange(m))):
        tp = t[piece]
        interp = make_interp_spline(tp, y[piece], k=k)
        j_all = np.arange(y.size)[piece][ends]
        v_interp = interp(tp[ends], 1)
        off = np.abs(vs[j_all] - v_interp) > tolerance
        j = j_all[off]
        ys[j], vs[j], acc[j] = interp(tp[ends[off]]), v_interp[off], interp(tp[ends[off]], 2)
        replaced += int(off.sum())
    return Derivatives(ys, vs, acc, sigma, replaced, lam)


def velocity_error(t, y, estimated: Derivatives | None = None) -> float:
    """Estimated RMS error (units of y per s) of ``estimate(t, y).v``, by a parametric bootstrap: the
    estimator rerun on x̂ + N(0, σ̂²) (``BOOTSTRAP_REPLICATES`` draws, fixed seed, the same λ), the root
    mean square of the re-estimates' differences from v̂ (the spread and the smoothing's bias on x̂).
    On a long record the bootstrap runs on the windows the smoothing was calibrated on (their middle
    halves, away from the windows' own ends).

    Against the truth on the benchmark's motions (ramps, sines, random; 0.5–10 Hz): see
    ``benchmarks/bench_differentiator.py``. On a noise-free record it is a lower bound: there the error
    is the smoothing of under-sampled reversals, which re-smoothing x̂ does not see.
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    e = estimate(t, y) if estimated is None else estimated
    if not e.noise > 0:
        return 0.0
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    spread = []
    windows = _windows(y.size)
    for _ in range(BOOTSTRAP_REPLICATES):
        for w in windows:
            again = estimate(t[w], e.x[w] + rng.normal(0.0, e.noise, e.x[w].shape), e.noise, smoothing=e.smoothing).v
            keep = slice(None) if len(windows) == 1 else slice(WINDOW // 4, 3 * WINDOW // 4)
            spread.append((again - e.v[w])[keep])
    return float(np.sqrt(np.mean(np.square(np.concatenate(spread)))))
