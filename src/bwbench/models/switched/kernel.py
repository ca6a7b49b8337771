"""The switched Bouc-Wen model's scalar numba kernel: one parameter set at a time.

The numerical method is described in ``bwbench.models.switched.simulation`` (the public interface);
this module holds the compiled pieces that both the scalar path and the lockstep kernel
(``bwbench.models.switched.lockstep``) build on. The scalar path is the reference the lockstep kernel is
tested against, bit for bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bwbench.models.power import power

PARAM_NAMES = (
    "A+",
    "n+",
    "alpha+",
    "beta+",
    "gamma+",
    "xi+",
    "wn+",
    "A-",
    "n-",
    "alpha-",
    "beta-",
    "gamma-",
    "xi-",
    "wn-",
)
N_PARAMS = len(PARAM_NAMES)
STATES = ("shared", "split")

# Index of each parameter inside one 7-element branch set.
_A, _N, _ALPHA, _BETA, _GAMMA, _XI, _WN = range(7)

# RK4 is stable for h·λ < 2.78; at h·λ = 1 it damps a transient by 0.375 per substep where the
# exact factor is 0.368: the transient dies either way, so the force error stays ~1e-6 of range.
RK4_STIFFNESS_PER_SUBSTEP = 1.0
RK4_MAX_SUBSTEPS = 32
IMPLICIT_SUBSTEPS = 16
AT_ATTRACTOR = 1e-13  # |z_att − z0| ≤ this·|z_att| (100× the noise of g(z0) there): a backward-Euler step stays at z0
# A loading piece that starts within _SETTLED_BAND·z_s of its attractor with work above _SETTLED_WORK takes the
# backward-Euler substeps too (``takes_implicit``): z only relaxes onto z_s there (a yielded branch between two
# reversals), the linear decay exp(−work) that RK4 followed with up to 32 substeps of 4 powers each, where
# backward Euler's 16 substeps cost ~1 power each and leave at most (1/(1 + work/16))^16 of a deviation
# ≤ 1e-3·z_s (2e-6·z_s at work 8). Such pieces held 60 % of the RK4 substeps of the identifiable population's
# uniform half (bench_objective).
_SETTLED_WORK = 8.0
_SETTLED_BAND = 1e-2


def symmetric_params(A, n, alpha, beta, gamma, xi, wn) -> np.ndarray:
    """The original 7-parameter Bouc-Wen model (eq 1 with ωn² in the z term) as a 14-vector."""
    half = [A, n, alpha, beta, gamma, xi, wn]
    return np.array(half + half, dtype=float)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rate(z, direction, A, n, beta, gamma):
    """dz/dx for motion in ``direction`` (+1 or −1); sign(z)·|z|^n keeps n < 1 finite at z = 0."""
    if z == 0.0:
        return A
    p = power(abs(z), n)
    if (z > 0.0) == (direction > 0.0):
        return A - (beta + gamma) * p
    return A - (beta - gamma) * p


@numba.njit(cache=True, error_model="numpy")
def backward_euler(z0, h, A, n, beta, gamma, z_att):
    """One backward-Euler step z1 = z0 + h·g(z1), root bracketed between z0 and the attractor.

    Returns NaN when there is no bracket: then g(z0) drives |z| away from the attractor (the
    runaway of β > γ on unloading), which is not stiff, and the caller uses RK4 instead.
    """
    direction = 1.0 if h > 0.0 else -1.0
    f_lo = -h * _rate(z0, direction, A, n, beta, gamma)
    f_hi = z_att - z0
    if f_lo == 0.0 or abs(f_hi) <= AT_ATTRACTOR * abs(z_att):
        # z0 on the attractor to rounding: the root is z0 to that accuracy, and g(z0) is rounding
        # noise of either sign, so the bracket test below would read noise and send a stiff step
        # to RK4, unstable there (a blow-up seen after a last-bit change of the power).
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
        p = power(abs(z), n) if z != 0.0 else 0.0
        c = (beta + gamma) if (z > 0.0) == (direction > 0.0) else (beta - gamma)
        dg = -c * n * p / z if z != 0.0 else -np.inf  # d|z|^n/dz = n·|z|^n/z, of z's sign
        df = 1.0 - h * dg
        z_new = z - f / df if np.isfinite(df) and df != 0.0 else 0.5 * (lo + hi)
        if newton_done(z, z_new, lo, hi):
            return z_new
        if not (min(lo, hi) < z_new < max(lo, hi)):
            z_new = 0.5 * (lo + hi)
        if abs(z_new - z) <= 1e-14 * (abs(z) + 1e-300):
            return z_new
        z = z_new
    return z


@numba.njit(cache=True, inline="always", error_model="numpy")
def newton_done(z, z_new, lo, hi):
    """A Newton step that no longer moves z (within 1e-14, inside the closed bracket) has converged,
    also where z is the bracket's end: the strict bracket test sent that case to bisection, away from
    the root and ~45 halvings back (a runaway z ~1e14 with n < 1: 23 iterations per step on average)."""
    return abs(z_new - z) <= 1e-14 * (abs(z) + 1e-300) and min(lo, hi) <= z_new <= max(lo, hi)


@numba.njit(cache=True, inline="always", error_model="numpy")
def takes_implicit(work, z, direction, z_s):
    """Whether a piece of work = stiffness·|dx| starting at z takes backward-Euler substeps: past
    RK4's budget, or settled on its loading attractor direction·z_s (``_SETTLED_WORK``)."""
    if work > RK4_STIFFNESS_PER_SUBSTEP * RK4_MAX_SUBSTEPS:
        return True
    return work > _SETTLED_WORK and abs(z - direction * z_s) <= _SETTLED_BAND * z_s


@numba.njit(cache=True, inline="always", error_model="numpy")
def rk4_substeps(work):
    """RK4 substeps for work = stiffness·|dx|: ceil, at least 1, and 1 for NaN (int(NaN) is UB)."""
    return int(math.ceil(work / RK4_STIFFNESS_PER_SUBSTEP)) if work > RK4_STIFFNESS_PER_SUBSTEP else 1


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
        p = power(abs(z), n)
        c = (beta + gamma) if (z > 0.0) == (direction > 0.0) else (beta - gamma)
        k1 = A - c * p
        local = n * abs(c) * p / abs(z)
        if (n >= 1.0 or abs(z) > z_s) and local > stiffness:
            stiffness = local
    work = stiffness * abs(dx)
    if takes_implicit(work, z, direction, z_s):
        h = dx / IMPLICIT_SUBSTEPS
        z_att = direction * z_s
        done = 0
        while done < IMPLICIT_SUBSTEPS:
            z_new = backward_euler(z, h, A, n, beta, gamma, z_att)
            if np.isnan(z_new):
                break
            if z_new == z and z != 0.0:
                # A fixed point of the step (z on the attractor to the last bit): each remaining
                # substep would call it again with the same arguments and get the same z.
                return z
            z = z_new
            done += 1
        if done == IMPLICIT_SUBSTEPS:
            return z
        # No bracket: not stiff after all (runaway); finish what is left with RK4 below.
        dx = h * (IMPLICIT_SUBSTEPS - done)
        work = RK4_STIFFNESS_PER_SUBSTEP * RK4_MAX_SUBSTEPS
        k1 = _rate(z, direction, A, n, beta, gamma)
    m = rk4_substeps(work)
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
def branch_offset(v):
    """0 for the '+' set (ẋ ≥ 0, tension), 7 for the '−' set (ẋ < 0, compression)."""
    return 0 if v >= 0.0 else 7


@numba.njit(cache=True, inline="always", error_model="numpy")
def _force(p, b, x, v, a, z):
    wn = p[b + _WN]
    alpha = p[b + _ALPHA]
    return a + 2.0 * p[b + _XI] * wn * v + alpha * wn * wn * x + (1.0 - alpha) * wn * wn * z


# The 8 hysteretic parameters H = (A+, n+, β+, γ+, A−, n−, β−, γ−): 4 per branch, '+' first.
_HA, _HN, _HBETA, _HGAMMA = range(4)
HYSTERETIC_INDEX = (_A, _N, _BETA, _GAMMA, 7 + _A, 7 + _N, 7 + _BETA, 7 + _GAMMA)
_H_FROM_P = np.array(HYSTERETIC_INDEX)


@numba.njit(cache=True, inline="always", error_model="numpy")
def reversal_pieces(t0, t1, x0, x1, v0, v1):
    """Displacement before and after the reversal inside [t0, t1]: ẋ linear, x cubic Hermite."""
    theta = v0 / (v0 - v1)
    dt = t1 - t0
    th2 = theta * theta
    th3 = th2 * theta
    x_rev = (
        (2.0 * th3 - 3.0 * th2 + 1.0) * x0
        + (th3 - 2.0 * th2 + theta) * dt * v0
        + (-2.0 * th3 + 3.0 * th2) * x1
        + (th3 - th2) * dt * v1
    )
    return x_rev - x0, x1 - x_rev


@numba.njit(cache=True, inline="always", error_model="numpy")
def loading_attractor(H, i):
    """Loading attractor z_s = (A/(β+γ))^(1/n) of branch i (0 '+', 1 '−') and its rate n·A/z_s."""
    b = 4 * i
    z_s = math.pow(H[b + _HA] / (H[b + _HBETA] + H[b + _HGAMMA]), 1.0 / H[b + _HN])
    return z_s, H[b + _HN] * H[b + _HA] / z_s


@numba.njit(cache=True, inline="always", error_model="numpy")
def _step_z(H, i, z, dx, z_s, rate):
    b = 4 * i
    return _advance_z(z, dx, H[b + _HA], H[b + _HN], H[b + _HBETA], H[b + _HGAMMA], z_s[i], rate[i])


@numba.njit(cache=True, error_model="numpy")
def _hysteretic_into(H, t, x, v, split, z):
    """z of the active branch at each sample into ``z`` (the one integration path of this module).

    Returns False as soon as that z is not finite; ``z`` is then only partly written.
    """
    n_samples = x.shape[0]
    z_s = np.empty(2)
    rate = np.empty(2)
    for i in range(2):
        z_s[i], rate[i] = loading_attractor(H, i)
    z_plus = 0.0
    z_minus = 0.0  # used only with the split convention
    z[0] = z_plus
    for k in range(n_samples - 1):
        b0 = branch_offset(v[k]) // 7
        b1 = branch_offset(v[k + 1]) // 7
        if b0 == b1:
            pieces_dx0 = x[k + 1] - x[k]
            pieces_dx1 = 0.0
        else:
            pieces_dx0, pieces_dx1 = reversal_pieces(t[k], t[k + 1], x[k], x[k + 1], v[k], v[k + 1])
        # Piece before the (possible) reversal, with the branch of v[k].
        if split and b0 == 1:
            z_minus = _step_z(H, b0, z_minus, pieces_dx0, z_s, rate)
        else:
            z_plus = _step_z(H, b0, z_plus, pieces_dx0, z_s, rate)
        if pieces_dx1 != 0.0:
            if split and b1 == 1:
                z_minus = _step_z(H, b1, z_minus, pieces_dx1, z_s, rate)
            else:
                z_plus = _step_z(H, b1, z_plus, pieces_dx1, z_s, rate)
        z_active = z_minus if (split and b1 == 1) else z_plus
        if not np.isfinite(z_active):
            return False
        z[k + 1] = z_active
    return True


@numba.njit(cache=True, error_model="numpy")
def force_from_z(p, x, v, a, z, force):
    """Force of parameter vector ``p`` given the z trajectory; returns False if not finite."""
    force[0] = _force(p, branch_offset(v[0]), x[0], v[0], a[0], z[0])
    for k in range(1, x.shape[0]):
        f = _force(p, branch_offset(v[k]), x[k], v[k], a[k], z[k])
        if not np.isfinite(f):
            return False
        force[k] = f
    return True


@numba.njit(cache=True, error_model="numpy")
def _simulate_into(p, t, x, v, a, split, force):
    """Simulate one parameter vector, writing the force into ``force``; returns False on blow-up."""
    # z goes through ``force`` itself: each sample's force needs only that sample's z.
    return _hysteretic_into(p[_H_FROM_P], t, x, v, split, force) and force_from_z(p, x, v, a, force, force)


@numba.njit(cache=True, error_model="numpy")
def simulate_one(p, t, x, v, a, split):
    force = np.empty(x.shape[0])
    if not _simulate_into(p, t, x, v, a, split, force):
        force[:] = np.inf
    return force


@numba.njit(cache=True, inline="always", error_model="numpy")
def mse_of_force(force, f_meas):
    s = 0.0
    for k in range(force.shape[0]):
        r = force[k] - f_meas[k]
        s += r * r
    m = s / force.shape[0]
    return m if np.isfinite(m) else np.inf


@numba.njit(cache=True, error_model="numpy")
def _mse_one(p, t, x, v, a, f_meas, split, force):
    if not _simulate_into(p, t, x, v, a, split, force):
        return np.inf
    return mse_of_force(force, f_meas)


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def hysteretic_batch_scalar(H, t, x, v, split):
    Z = np.empty((H.shape[0], x.shape[0]))
    for i in range(H.shape[0]):
        if not _hysteretic_into(H[i], t, x, v, split, Z[i]):
            Z[i, :] = np.inf
    return Z


@numba.njit(cache=True, parallel=True, error_model="numpy")
def mse_parallel(P, t, x, v, a, f_meas, split):
    out = np.empty(P.shape[0])
    for i in numba.prange(P.shape[0]):
        out[i] = _mse_one(P[i], t, x, v, a, f_meas, split, np.empty(x.shape[0]))
    return out


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def mse_serial(P, t, x, v, a, f_meas, split):
    out = np.empty(P.shape[0])
    force = np.empty(x.shape[0])
    for i in range(P.shape[0]):
        out[i] = _mse_one(P[i], t, x, v, a, f_meas, split, force)
    return out
