"""The switched (asymmetric) Bouc-Wen model of the paper, eqs 2-5, compiled with numba.

Displacement-driven: given x(t), ẋ(t), ẍ(t) on sample times, the force is

    F = ẍ + 2·ξ·ωn·ẋ + α·ωn²·x + (1 − α)·ωn²·z
    dz = (A − (β + γ·sign(z·dx))·|z|^n)·dx        (eqs 4-5, rate-independent)

with the '+' set while ẋ ≥ 0 and the '−' set while ẋ < 0. Units follow the specimen files:
x in mm, t in s, F in N; ωn in rad/s, z in mm.

Parameter vectors are ordered as ``PARAM_NAMES``. Two state conventions:

- ``shared`` (default): one z, driven by whichever branch is active;
- ``split``: z₊ and z₋ are separate and each holds its value while its branch is idle.

Integration is in displacement, per sample interval, with the velocity reversal located inside
the interval (linear interpolation of ẋ, cubic Hermite for x). Each piece is integrated with
classical RK4 in as many substeps as the local stiffness needs. The loading attractor
z_s = (A/(β+γ))^(1/n) relaxes at rate n·A/z_s per mm, which for n < 1 reaches 10⁴/mm inside
Table 5; past ``_RK4_MAX_SUBSTEPS`` substeps an L-stable backward-Euler step (scalar Newton,
bracketed) takes over so such parameter sets cost bounded time and do not go unstable.
"""

from __future__ import annotations

import math

import numba
import numpy as np

PARAM_NAMES = (
    "A+", "n+", "alpha+", "beta+", "gamma+", "xi+", "wn+",
    "A-", "n-", "alpha-", "beta-", "gamma-", "xi-", "wn-",
)
N_PARAMS = len(PARAM_NAMES)
STATES = ("shared", "split")

# Index of each parameter inside one 7-element branch set.
_A, _N, _ALPHA, _BETA, _GAMMA, _XI, _WN = range(7)

# RK4 is stable for h·λ < 2.78; at h·λ = 1 it damps a transient by 0.375 per substep where the
# exact factor is 0.368: the transient dies either way, so the force error stays ~1e-6 of range.
_RK4_STIFFNESS_PER_SUBSTEP = 1.0
_RK4_MAX_SUBSTEPS = 32
_IMPLICIT_SUBSTEPS = 16


def symmetric_params(A, n, alpha, beta, gamma, xi, wn) -> np.ndarray:
    """The original 7-parameter Bouc-Wen model (eq 1 with ωn² in the z term) as a 14-vector."""
    half = [A, n, alpha, beta, gamma, xi, wn]
    return np.array(half + half, dtype=float)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rate(z, direction, A, n, beta, gamma):
    """dz/dx for motion in ``direction`` (+1 or −1); sign(z)·|z|^n keeps n < 1 finite at z = 0."""
    if z == 0.0:
        return A
    p = math.pow(abs(z), n)
    if (z > 0.0) == (direction > 0.0):
        return A - (beta + gamma) * p
    return A - (beta - gamma) * p


@numba.njit(cache=True, error_model="numpy")
def _backward_euler(z0, h, A, n, beta, gamma, z_att):
    """One backward-Euler step z1 = z0 + h·g(z1), root bracketed between z0 and the attractor.

    Returns NaN when there is no bracket: then g(z0) drives |z| away from the attractor (the
    runaway of β > γ on unloading), which is not stiff, and the caller uses RK4 instead.
    """
    direction = 1.0 if h > 0.0 else -1.0
    f_lo = -h * _rate(z0, direction, A, n, beta, gamma)
    f_hi = z_att - z0
    if f_lo == 0.0:
        return z0
    if f_lo * f_hi > 0.0:
        return np.nan
    lo, hi = z0, z_att
    z = 0.5 * (lo + hi)
    for _ in range(60):
        f = z - z0 - h * _rate(z, direction, A, n, beta, gamma)
        if f == 0.0:
            return z
        if (f > 0.0) == (f_hi > 0.0):
            hi = z
        else:
            lo = z
        # Newton where the derivative is usable, bisection otherwise.
        p = math.pow(abs(z), n) if z != 0.0 else 0.0
        c = (beta + gamma) if (z > 0.0) == (direction > 0.0) else (beta - gamma)
        dg = -c * n * p / abs(z) if z != 0.0 else -np.inf
        df = 1.0 - h * dg
        z_new = z - f / df if np.isfinite(df) and df != 0.0 else 0.5 * (lo + hi)
        if not (min(lo, hi) < z_new < max(lo, hi)):
            z_new = 0.5 * (lo + hi)
        if abs(z_new - z) <= 1e-14 * (abs(z) + 1e-300):
            return z_new
        z = z_new
    return z


@numba.njit(cache=True, error_model="numpy")
def _advance_z(z, dx, A, n, beta, gamma, z_s, attractor_rate):
    """Integrate dz/dx over a monotone displacement increment dx with one branch's parameters.

    ``z_s`` = (A/(β+γ))^(1/n) is the loading attractor and ``attractor_rate`` = n·A/z_s its
    relaxation rate per mm; both depend only on the parameters, so they are computed once.
    """
    if dx == 0.0 or not np.isfinite(z):
        return z
    direction = 1.0 if dx > 0.0 else -1.0
    stiffness = attractor_rate
    # First RK4 stage, whose |z|^n also gives the local stiffness n·|c|·|z|^(n−1).
    k1 = A
    if z != 0.0:
        p = math.pow(abs(z), n)
        c = (beta + gamma) if (z > 0.0) == (direction > 0.0) else (beta - gamma)
        k1 = A - c * p
        local = n * abs(c) * p / abs(z)
        if (n >= 1.0 or abs(z) > z_s) and local > stiffness:
            stiffness = local
    work = stiffness * abs(dx)
    if work > _RK4_STIFFNESS_PER_SUBSTEP * _RK4_MAX_SUBSTEPS:
        h = dx / _IMPLICIT_SUBSTEPS
        z_att = direction * z_s
        done = 0
        while done < _IMPLICIT_SUBSTEPS:
            z_new = _backward_euler(z, h, A, n, beta, gamma, z_att)
            if np.isnan(z_new):
                break
            z = z_new
            done += 1
        if done == _IMPLICIT_SUBSTEPS:
            return z
        # No bracket: not stiff after all (runaway); finish what is left with RK4 below.
        dx = h * (_IMPLICIT_SUBSTEPS - done)
        work = _RK4_STIFFNESS_PER_SUBSTEP * _RK4_MAX_SUBSTEPS
        k1 = _rate(z, direction, A, n, beta, gamma)
    m = max(1, int(math.ceil(work / _RK4_STIFFNESS_PER_SUBSTEP)))
    h = dx / m
    for i in range(m):
        if i > 0:
            k1 = _rate(z, direction, A, n, beta, gamma)
        k2 = _rate(z + 0.5 * h * k1, direction, A, n, beta, gamma)
        k3 = _rate(z + 0.5 * h * k2, direction, A, n, beta, gamma)
        k4 = _rate(z + h * k3, direction, A, n, beta, gamma)
        z = z + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        if not np.isfinite(z):
            return z
    return z


@numba.njit(cache=True, inline="always", error_model="numpy")
def _branch(v):
    """0 for the '+' set (ẋ ≥ 0, tension), 7 for the '−' set (ẋ < 0, compression)."""
    return 0 if v >= 0.0 else 7


@numba.njit(cache=True, inline="always", error_model="numpy")
def _force(p, b, x, v, a, z):
    wn = p[b + _WN]
    alpha = p[b + _ALPHA]
    return a + 2.0 * p[b + _XI] * wn * v + alpha * wn * wn * x + (1.0 - alpha) * wn * wn * z


@numba.njit(cache=True, inline="always", error_model="numpy")
def _step_z(p, b, z, dx, z_s, rate):
    i = b // 7
    return _advance_z(z, dx, p[b + _A], p[b + _N], p[b + _BETA], p[b + _GAMMA], z_s[i], rate[i])


@numba.njit(cache=True, error_model="numpy")
def _simulate_into(p, t, x, v, a, split, force):
    """Simulate one parameter vector, writing the force into ``force``; returns False on blow-up."""
    n_samples = x.shape[0]
    # Loading attractor z_s and its relaxation rate n·A/z_s for the '+' (0) and '−' (1) sets.
    z_s = np.empty(2)
    rate = np.empty(2)
    for i in range(2):
        b = 7 * i
        z_s[i] = math.pow(p[b + _A] / (p[b + _BETA] + p[b + _GAMMA]), 1.0 / p[b + _N])
        rate[i] = p[b + _N] * p[b + _A] / z_s[i]
    z_plus = 0.0
    z_minus = 0.0  # used only with the split convention
    b = _branch(v[0])
    force[0] = _force(p, b, x[0], v[0], a[0], z_plus)
    for k in range(n_samples - 1):
        v0 = v[k]
        v1 = v[k + 1]
        b0 = _branch(v0)
        b1 = _branch(v1)
        if b0 == b1:
            pieces_dx0 = x[k + 1] - x[k]
            pieces_dx1 = 0.0
        else:
            # Reversal inside the interval: ẋ linear in time, x a cubic Hermite.
            theta = v0 / (v0 - v1)
            dt = t[k + 1] - t[k]
            th2 = theta * theta
            th3 = th2 * theta
            x_rev = (
                (2.0 * th3 - 3.0 * th2 + 1.0) * x[k]
                + (th3 - 2.0 * th2 + theta) * dt * v0
                + (-2.0 * th3 + 3.0 * th2) * x[k + 1]
                + (th3 - th2) * dt * v1
            )
            pieces_dx0 = x_rev - x[k]
            pieces_dx1 = x[k + 1] - x_rev
        # Piece before the (possible) reversal, with the branch of v0.
        if split and b0 == 7:
            z_minus = _step_z(p, b0, z_minus, pieces_dx0, z_s, rate)
        else:
            z_plus = _step_z(p, b0, z_plus, pieces_dx0, z_s, rate)
        if pieces_dx1 != 0.0:
            if split and b1 == 7:
                z_minus = _step_z(p, b1, z_minus, pieces_dx1, z_s, rate)
            else:
                z_plus = _step_z(p, b1, z_plus, pieces_dx1, z_s, rate)
        z_active = z_minus if (split and b1 == 7) else z_plus
        f = _force(p, b1, x[k + 1], v1, a[k + 1], z_active)
        if not np.isfinite(f):
            return False
        force[k + 1] = f
    return True


@numba.njit(cache=True, error_model="numpy")
def _simulate_one(p, t, x, v, a, split):
    force = np.empty(x.shape[0])
    if not _simulate_into(p, t, x, v, a, split, force):
        force[:] = np.inf
    return force


@numba.njit(cache=True, error_model="numpy")
def _mse_one(p, t, x, v, a, f_meas, split, force):
    if not _simulate_into(p, t, x, v, a, split, force):
        return np.inf
    s = 0.0
    for k in range(x.shape[0]):
        r = force[k] - f_meas[k]
        s += r * r
    m = s / x.shape[0]
    return m if np.isfinite(m) else np.inf


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _mse_parallel(P, t, x, v, a, f_meas, split):
    out = np.empty(P.shape[0])
    for i in numba.prange(P.shape[0]):
        out[i] = _mse_one(P[i], t, x, v, a, f_meas, split, np.empty(x.shape[0]))
    return out


@numba.njit(cache=True, error_model="numpy")
def _mse_serial(P, t, x, v, a, f_meas, split):
    out = np.empty(P.shape[0])
    force = np.empty(x.shape[0])
    for i in range(P.shape[0]):
        out[i] = _mse_one(P[i], t, x, v, a, f_meas, split, force)
    return out


def _as_excitation(t, x, v, a):
    arrays = [np.ascontiguousarray(np.asarray(arr, dtype=np.float64)) for arr in (t, x, v, a)]
    n = arrays[0].shape[0]
    if any(arr.ndim != 1 or arr.shape[0] != n for arr in arrays):
        raise ValueError("t, x, v and a must be 1-D arrays of equal length")
    return arrays


def _check_state(state: str) -> bool:
    if state not in STATES:
        raise ValueError(f"state must be one of {STATES}, got {state!r}")
    return state == "split"


def simulate(params, t, x, v, a, state: str = "shared") -> np.ndarray:
    """Force (N) of one 14-parameter set on an excitation given at sample times.

    ``t`` in s, ``x`` in mm, ``v`` in mm/s, ``a`` in mm/s², all 1-D of length L. Returns an
    array of length L; every entry is +inf when the model blows up (z or F not finite).
    """
    split = _check_state(state)
    p = np.ascontiguousarray(np.asarray(params, dtype=np.float64))
    if p.shape != (N_PARAMS,):
        raise ValueError(f"params must have shape ({N_PARAMS},), got {p.shape}")
    t, x, v, a = _as_excitation(t, x, v, a)
    return _simulate_one(p, t, x, v, a, split)


def mse_batch(P, t, x, v, a, f_meas, state: str = "shared") -> np.ndarray:
    """Mean squared force error (N²) of each row of ``P`` (shape (m, 14)) against ``f_meas``.

    Rows whose simulation is not finite get +inf. Rows run in parallel over numba's threads;
    ``numba.set_num_threads(1)`` makes it single-core.
    """
    split = _check_state(state)
    P = np.ascontiguousarray(np.atleast_2d(np.asarray(P, dtype=np.float64)))
    if P.ndim != 2 or P.shape[1] != N_PARAMS:
        raise ValueError(f"P must have shape (m, {N_PARAMS}), got {P.shape}")
    t, x, v, a = _as_excitation(t, x, v, a)
    f_meas = np.ascontiguousarray(np.asarray(f_meas, dtype=np.float64))
    if f_meas.shape != x.shape:
        raise ValueError("f_meas must have the same length as the excitation")
    # One-point optimisers call this row by row: waking numba's thread pool would cost more
    # than the simulation, so small batches run on the calling thread.
    kernel = _mse_serial if P.shape[0] < 4 or numba.get_num_threads() == 1 else _mse_parallel
    return kernel(P, t, x, v, a, f_meas, split)  # IEEE semantics inside (error_model="numpy")
