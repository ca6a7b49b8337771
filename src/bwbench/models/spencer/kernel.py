"""Spencer et al. (1997)'s MR-damper model: the compiled integration of its internal states.

In the symmetry-free coordinates of ``bwbench.models.spencer.model`` (mm, s, N), per unit c₁:

    ẏ = (v_y·w + r₀·ẋ + κ₀·(x − y)) / (1 + r₀)
    ẇ = ((ẋ − ẏ)/x_y)·(1 − c·|w|^n),   c = 1 if w·(ẋ − ẏ) > 0 (loading), η otherwise

and the force is F = c₁·ẏ + k₁·x + f₀. y (mm) is the internal displacement, w = z/z_s the
evolutionary variable in units of its saturation value. The excitation between two samples: ẋ is
the cubic Hermite interpolant of (ẋ, ẍ) at the samples, x the sample's x plus its integral. The
velocity, recorded or estimated, drives the model: a derivative of the noisy displacement between
samples would not (with 1 µm of encoder noise at 500 Hz it wiggles by ~1 mm/s inside each interval,
and an MR damper's pre-yield damping of ~20 N·s/mm turns that into ~20 N of force).

Integration: the L-stable Rosenbrock-W method ROS34PW2 (order 3, embedded order 2) with step-size
control (tolerance ``TOL`` = 1e-5 per step on w and on y relative to the record's amplitude), the
step carried from one sample interval to the next. Each step solves 2×2 linear systems with the
analytic Jacobian of the rates at its start. The stiffness reaches (v_y/(1 + r₀))·(1 + |η|)/x_y +
n·|ẋ − ẏ|/x_y: for an MR damper (x_y ≈ 0.02 mm, v_y ≈ 20–40 mm/s) 10³–10⁴ s⁻¹. The explicit
Dormand–Prince 5(4) used before was bound there by stability to steps of ~3/λ (2.6–8 steps per sample
interval at 500 Hz–1 kHz); the L-stable step is bound only by accuracy (1.5–3.7 per interval, each
about half the cost of a Dormand–Prince step), and a stiff corner of the search box (x_y = 1e-6 mm:
10⁸ s⁻¹) needs no fallback. The force agrees with solve_ivp to ~1e-5 of its range (tests: 5e-5),
100× below a measured test's force noise; tighter tolerances (``tol`` of ``ydot_batch``) serve tests.
The error control shortens the step where the relative velocity reverses (a kink of the rates).
A state that is not finite makes the whole row +inf.
"""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.power import exp, log

_XY, _N, _ETA, _VY, _R0, _K0 = range(6)
# Two reciprocals every rate needs, computed once per simulation (``with_reciprocals``): a multiply
# instead of a division on the chain each stage waits for.
_INV_S, _INV_XY = 6, 7


@numba.njit(cache=True, error_model="numpy")
def with_reciprocals(p):
    """The parameters p = (x_y, n, η, v_y, r₀, κ₀) followed by 1/(1 + r₀) and 1/x_y, as the rates read them."""
    q = np.empty(8)
    q[:6] = p[:6]
    q[_INV_S] = 1.0 / (1.0 + p[_R0])
    q[_INV_XY] = 1.0 / p[_XY]
    return q


@numba.njit(cache=True, inline="always", error_model="numpy")
def abs_power(w, n):
    """|w|^n (n ≥ 1) by the switched kernels' table-driven log and exp (``bwbench.models.power``):
    inlined arithmetic, shorter on the stages' chain than libm's pow, and the same bits as the
    sensitivity kernel's, which needs log|w| itself."""
    return exp(n * log(abs(w)))


@numba.njit(cache=True, inline="always", error_model="numpy")
def hermite_excitation(tau, h, x0, v0, v1, a0, a1):
    """x (mm) and ẋ (mm/s) at fraction tau of an interval of length h (s): ẋ is the cubic Hermite
    interpolant of (ẋ, ẍ) at its ends, x the sample x0 plus its integral."""
    t2 = tau * tau
    t3 = t2 * tau
    t4 = t3 * tau
    xd = (2 * t3 - 3 * t2 + 1) * v0 + (t3 - 2 * t2 + tau) * h * a0 + (-2 * t3 + 3 * t2) * v1 + (t3 - t2) * h * a1
    x = x0 + h * (
        (tau - t3 + 0.5 * t4) * v0
        + (0.5 * t2 - 2 * t3 / 3 + 0.25 * t4) * h * a0
        + (t3 - 0.5 * t4) * v1
        + (0.25 * t4 - t3 / 3) * h * a1
    )
    return x, xd


@numba.njit(cache=True, inline="always", error_model="numpy")
def rates_at(y, w, x, xd, p):
    """(ẏ, ẇ) at state (y, w) and excitation (x, ẋ) for parameters p = (x_y, n, η, v_y, r₀, κ₀, and
    the reciprocals of ``with_reciprocals``)."""
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) * p[_INV_S]
    u = xd - yd
    c = 1.0 if w * u > 0.0 else p[_ETA]
    wd = u * p[_INV_XY] * (1.0 - c * abs_power(w, p[_N]))
    return yd, wd


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rates_jacobian(y, w, x, xd, p):
    """``rates_at`` (the same numbers) and the matrix W of a Rosenbrock-W step, ∂(ẏ, ẇ)/∂(y, w) at state
    (y, w) and excitation (x, ẋ) on the current branch (loading or not), sharing one |w|^n: (ẏ, ẇ,
    ∂ẏ/∂y, ∂ẏ/∂w, ∂ẇ/∂y, ∂ẇ/∂w). (W on the stiffer of the two branches where the relative velocity
    hovers about 0 was tried: 3× the steps there.)"""
    j11 = -p[_K0] * p[_INV_S]
    j12 = p[_VY] * p[_INV_S]
    yd = (p[_VY] * w + p[_R0] * xd + p[_K0] * (x - y)) * p[_INV_S]
    u = xd - yd
    c = 1.0 if w * u > 0.0 else p[_ETA]
    pw = abs_power(w, p[_N])
    sat = 1.0 - c * pw
    dsat = -c * p[_N] * pw / w if w != 0.0 else 0.0  # ∂(1 − c·|w|^n)/∂w; 0 at w = 0 (n ≥ 1)
    ux = u * p[_INV_XY]
    return yd, ux * sat, j11, j12, -j11 * p[_INV_XY] * sat, -j12 * p[_INV_XY] * sat + ux * dsat


# Rosenbrock-W method ROS34PW2 (Rang & Angermann, BIT 45:761–787, 2005): 4 stages, order 3 with an
# embedded order-2 solution for the error estimate, L-stable and stiffly accurate, and a W-method: its
# order holds for any matrix W in place of the Jacobian, so the excitation's time dependence needs no
# ∂f/∂t term (time is a state whose row of W is left out) and the sensitivities can step with the same W
# (``spencer_sensitivity``). Per stage i (k_i the increments, W the 2×2 Jacobian at the step's start):
#     (I − h·γ·W)·k_i = h·f(t + c_i·h, u + Σ_j a_ij·k_j) + h·W·Σ_j γ_ij·k_j,   u_new = u + Σ_i b_i·k_i.
_GAMMA = 0.43586652150845900
A21 = 0.87173304301691801
A31, A32 = 0.84457060015369423, -0.11299064236484185  # a_4 = (0, 0, 1): the 4th stage is at u + k_3
G21 = -0.87173304301691801
G31, G32 = -0.90338057013044082, 0.054180672388095326
G41, G42, G43 = 0.24212380706095346, -1.2232505839045147, 0.54526025533510214
B1, B2, B3, B4 = 0.24212380706095346, -1.2232505839045147, 1.5452602553351020, 0.43586652150845900
# b − b̂ (b̂ the embedded order-2 weights 0.37810903145819369, −0.096042292212423178, 0.5, 0.21793326075422950)
E1, E2, E3, E4 = B1 - 0.37810903145819369, B2 + 0.096042292212423178, B3 - 0.5, B4 - 0.21793326075422950
C2, C3 = A21, A31 + A32  # stage times (fractions of the step); the 4th is at the step's end
TOL = 1e-5  # per step, on w (no unit, |w| ≲ 1) and on y relative to the record's amplitude


@numba.njit(cache=True, error_model="numpy")
def integrate_interval(y, w, t0, t1, x0, v0, v1, a0, a1, p, h, y_scale, allowance, tol):
    """Advance (y, w) over [t0, t1] with ROS34PW2 and step-size control; ``h`` is the step (s) to try
    first (the last accepted one of the previous interval), ``tol`` the tolerance per step (``TOL``).
    Returns (y, w, h, steps tried); (NaN, NaN, h, steps) once more than ``allowance`` steps were tried
    (the simulation's step budget, ``_run``)."""
    span = t1 - t0
    s = 0.0
    steps = 0
    xs, xds = x0, v0  # the excitation at s (the interval's start: its samples)
    fresh = True  # the rates at s and W are to be computed: a step retried with a shorter h reuses them
    fy0 = fw0 = j11 = j12 = j21 = j22 = 0.0
    while s < span:
        if steps >= allowance:
            return np.nan, np.nan, h, steps
        steps += 1
        h = min(h, span - s)
        if fresh:
            fy0, fw0, j11, j12, j21, j22 = _rates_jacobian(y, w, xs, xds, p)
            fresh = False
        i11, i12, i21, i22 = step_inverse(h, j11, j12, j21, j22)
        r1, r2 = h * fy0, h * fw0
        k1y, k1w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        x, xd = hermite_excitation((s + C2 * h) / span, span, x0, v0, v1, a0, a1)
        fy, fw = rates_at(y + A21 * k1y, w + A21 * k1w, x, xd, p)
        gy, gw = G21 * k1y, G21 * k1w
        r1, r2 = h * (fy + j11 * gy + j12 * gw), h * (fw + j21 * gy + j22 * gw)
        k2y, k2w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        x, xd = hermite_excitation((s + C3 * h) / span, span, x0, v0, v1, a0, a1)
        fy, fw = rates_at(y + A31 * k1y + A32 * k2y, w + A31 * k1w + A32 * k2w, x, xd, p)
        gy, gw = G31 * k1y + G32 * k2y, G31 * k1w + G32 * k2w
        r1, r2 = h * (fy + j11 * gy + j12 * gw), h * (fw + j21 * gy + j22 * gw)
        k3y, k3w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        xe, xde = hermite_excitation((s + h) / span, span, x0, v0, v1, a0, a1)
        fy, fw = rates_at(y + k3y, w + k3w, xe, xde, p)
        gy, gw = G41 * k1y + G42 * k2y + G43 * k3y, G41 * k1w + G42 * k2w + G43 * k3w
        r1, r2 = h * (fy + j11 * gy + j12 * gw), h * (fw + j21 * gy + j22 * gw)
        k4y, k4w = i11 * r1 + i12 * r2, i21 * r1 + i22 * r2
        y_new = y + B1 * k1y + B2 * k2y + B3 * k3y + B4 * k4y
        w_new = w + B1 * k1w + B2 * k2w + B3 * k3w + B4 * k4w
        ey = E1 * k1y + E2 * k2y + E3 * k3y + E4 * k4y
        ew = E1 * k1w + E2 * k2w + E3 * k3w + E4 * k4w
        err = max(abs(ey) / (tol * y_scale), abs(ew) / (tol * max(1.0, abs(w_new))))
        if not np.isfinite(err) or not np.isfinite(w_new):
            if h <= 1e-14 * span:
                return np.nan, np.nan, h, steps
            h *= 0.2
            continue
        if err <= 1.0:
            s += h
            y, w = y_new, w_new
            xs, xds = xe, xde  # the next step starts where this one's last stage was: s + h
            fresh = True
        h *= step_factor(err)
    return y, w, h, steps


@numba.njit(cache=True, inline="always", error_model="numpy")
def step_inverse(h, j11, j12, j21, j22):
    """(I − h·γ·W)⁻¹ (2×2, row by row), once per step: every stage solves with it."""
    hg = h * _GAMMA
    m11, m12, m21, m22 = 1.0 - hg * j11, -hg * j12, -hg * j21, 1.0 - hg * j22
    inv_det = 1.0 / (m11 * m22 - m12 * m21)
    return m22 * inv_det, -m12 * inv_det, -m21 * inv_det, m11 * inv_det


# The step-size factor 0.9·err^(−1/3) (the error estimate is O(h³)) is clipped to [0.2, 5]: outside
# err ∈ [(0.9/5)³, (0.9/0.2)³] the clip decides, and the cube root (a pow) is not taken. Most steps end
# at a sample (h cut to what is left of the interval) with an error far below the tolerance.
_ERR_GROW, _ERR_SHRINK = (0.9 / 5.0) ** 3, (0.9 / 0.2) ** 3


@numba.njit(cache=True, inline="always", error_model="numpy")
def step_factor(err):
    if err <= _ERR_GROW:
        return 5.0
    if err >= _ERR_SHRINK:
        return 0.2
    return min(5.0, max(0.2, 0.9 * err ** (-1.0 / 3.0)))


@numba.njit(cache=True, error_model="numpy")
def _run(p, t, x, v, a, y, w, stop, out, used, start, total, tol, pace):
    """Integrate from (y, w) at sample 0 to sample ``stop``, writing ẏ into ``out`` when it is not
    empty; ``used`` steps taken so far, this run's first interval the simulation's ``start``-th of
    ``total`` steps' worth at ``pace`` steps per interval (``step_allowance``). Returns (y, w, steps used,
    status)."""
    if out.shape[0]:
        out[0], _ = rates_at(y, w, x[0], v[0], p)
    h = t[1] - t[0]
    y_scale = max(0.5 * (np.max(x) - np.min(x)), 1e-9)
    for k in range(stop):
        allowance = step_allowance(used, start + k, total, pace)
        y, w, h, steps = integrate_interval(
            y, w, t[k], t[k + 1], x[k], v[k], v[k + 1], a[k], a[k + 1], p, h, y_scale, allowance, tol
        )
        used += steps
        if not (np.isfinite(y) and np.isfinite(w)):
            return np.nan, np.nan, used, (STATUS_STEP_BUDGET if steps >= allowance else STATUS_BLOW_UP)
        if out.shape[0]:
            out[k + 1], _ = rates_at(y, w, x[k + 1], v[k + 1], p)
    return y, w, used, STATUS_OK


# The work a simulation may do: this many steps per sample interval on average, over the whole record
# (a pre-roll put before it included). At a fit's optimum the L-stable step takes 1.5–3.7 per interval (500 Hz–1 kHz
# records with a noisy velocity); a corner of the search box where the relative velocity hovers about
# 0 with η ≪ −1 takes hundreds per interval there (the branch flips with the velocity's noise), 25×
# the optimum's cost per simulation at 64 (the budget the explicit integrator had). Such a simulation
# stops and its loss is +inf, the reason counted (``STATUS_STEP_BUDGET``).
STEPS_PER_SAMPLE = 16
STATUS_OK, STATUS_BLOW_UP, STATUS_STEP_BUDGET = 0, 1, 2


@numba.njit(cache=True, inline="always", error_model="numpy")
def step_allowance(used, interval, total, pace):
    """Steps the ``interval``-th sample interval of a simulation may take once ``used`` are spent: the
    budget (``total`` = ``pace`` steps per interval, ``STEPS_PER_SAMPLE`` unless told) at that pace, from a
    head start of a quarter of it (a burst at the reversals, or the pre-roll's first reversal from rest, is spent from it).
    The whole budget only at the end: a simulation over budget everywhere (hundreds of steps per
    interval in a stiff corner of the box) stops after a quarter of the budget, not the whole, where
    it cost 10× the median simulation of a fit (a third of the sensitivity kernel's time in a fit of
    a 1,501-sample MR-damper test)."""
    return min(pace * (interval + 1) + total // 4, total) - used


@numba.njit(cache=True, error_model="numpy")
def _ydot_into(p, t, x, v, a, out, tol, pace):
    """ẏ (mm/s) at every sample into ``out``; the status (``STATUS_*``). ``pace``: the step budget, in
    steps per sample interval (``step_allowance``). The model starts at rest at the first sample (y = x,
    w = 0): what comes before a record (a pre-roll of its own motion) is put before it by the caller,
    the same for every model (``bwbench.models.start``)."""
    p = with_reciprocals(p)
    return _run(p, t, x, v, a, x[0], 0.0, x.shape[0] - 1, out, 0, 0, pace * (x.shape[0] - 1), tol, pace)[3]


def kernel_arrays(*arrays) -> list:
    """The arrays as the kernels take them: C-contiguous float64, read-only (views, no copy where they
    already are). One array type for every call, so each kernel is compiled once: a record's arrays
    are read-only, but a decimated copy (every k-th sample) or a velocity with its first sample set to
    0 is writable, and each mix was a new specialisation compiled at its first use (1–4 s inside the
    first fit of such a record: the 34× of a 1 kHz 0.5 Hz test in ``bench_real_fit``)."""
    out = []
    for arr in arrays:
        view = np.ascontiguousarray(arr, dtype=np.float64).view()
        view.flags.writeable = False
        out.append(view)
    return out


def ydot_batch(TH, t, x, v, a, tol=TOL, pace=STEPS_PER_SAMPLE):
    """(ẏ (mm/s) of each parameter row of TH (m, 6) at the samples: (m, L), +inf rows where the
    simulation did not finish; the status of each row (m,), ``STATUS_*``). ``tol``: the integration's
    tolerance per step (tests compare at a tighter one); ``pace``: the step budget per sample interval.

    On numba's threads only when there are enough rows for each thread (on a busy machine a parallel
    loop waits for a thread that has no core: tens of ms per call); the rows are independent, so the
    result is the same either way."""
    TH = np.ascontiguousarray(TH, dtype=np.float64)
    t, x, v, a = kernel_arrays(t, x, v, a)
    out = np.empty((TH.shape[0], x.shape[0]))
    status = np.zeros(TH.shape[0], dtype=np.int8)
    threads = numba.get_num_threads()
    if threads > 1 and TH.shape[0] >= 2 * threads:
        _ydot_parallel(TH, t, x, v, a, out, status, tol, int(pace))
    else:
        _ydot_serial(TH, t, x, v, a, out, status, tol, int(pace))
    return out, status


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _ydot_parallel(TH, t, x, v, a, out, status, tol, pace):
    for i in numba.prange(TH.shape[0]):
        status[i] = _ydot_into(TH[i], t, x, v, a, out[i], tol, pace)
        if status[i] != STATUS_OK:
            out[i, :] = np.inf


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _ydot_serial(TH, t, x, v, a, out, status, tol, pace):
    for i in range(TH.shape[0]):
        status[i] = _ydot_into(TH[i], t, x, v, a, out[i], tol, pace)
        if status[i] != STATUS_OK:
            out[i, :] = np.inf
