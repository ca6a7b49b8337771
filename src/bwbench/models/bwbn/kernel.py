"""The degrading, pinching Bouc-Wen (BWBN) model's numba kernel: w and, on request, ∂w/∂θ at the samples.

In the identifiable coordinates (``bwbench.models.bwbn.model``) the state is w = z/z_u0 (–, z over its
initial ultimate value) and the hysteretic energy e = ∫w·dx (mm); along a displacement piece of
direction s = sign(dx):

    dw/dx = h(w, e)·Φ(w, e) / (η_d(e)·x_y),        de/dx = w,
    Φ   = 1 − ν(e)·c·|w|ⁿ,          c = 1 loading (w·s > 0), η unloading,
    ν   = 1 + δν·e,  η_d = 1 + δη·e (strength and stiffness degradation),
    h   = 1 − ζ₁·exp(−((w·sign(ẋ) − q·w_u)/ζ₂)²)  (Foliente's pinching), w_u = ν^(−1/n),
    ζ₁  = ζ_s·(1 − exp(−p·e)),  ζ₂ = (ψ + δψ·e)·(λ + ζ₁).

θ = (x_y, n, η, δν, δη, ζ_s, p, q, ψ, δψ, λ). The model is rate-independent, so it is integrated in
displacement: each sample interval is one piece (two when the recorded velocity changes sign inside
it: the reversal located as the switched kernel does, ``switched.kernel.reversal_pieces``), by RK4
in as many substeps as the local stiffness ∂(dw/dx)/∂w needs (work ≤ ``_WORK_PER_SUBSTEP`` each).
The sensitivities S = ∂(w, e)/∂θ are RK4 on the variational equations along the same stages, the
exact derivative of the discrete map (substep counts are integers, constant between the isolated
parameter values where they change). A piece that would need more than ``_MAX_SUBSTEPS`` substeps
(a stiff corner of the box) or a state that is not finite stops the simulation: the loss is +inf.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from bwbench.models.switched.kernel import reversal_pieces

N_THETA = 11
_XY, _N, _ETA, _DNU, _DETA, _ZS, _P, _Q, _PSI, _DPSI, _LAM = range(N_THETA)
# RK4 damps a transient at h·λ = 0.5 by 0.607 where the exact factor is 0.607 (to 3 digits): the
# force then agrees with solve_ivp (DOP853, rtol 1e-10) to ~1e-5 of its range (tests/models/bwbn/test_bwbn.py).
_WORK_PER_SUBSTEP = 0.5
_MAX_SUBSTEPS = 20000


@numba.njit(cache=True, error_model="numpy")
def _rhs(y, s, sp, th, out, d):
    """dy/dx of y = (w, e, ∂w/∂θ (d), ∂e/∂θ (d)) into ``out`` (d = 0: w and e only) along a piece of
    direction s = sign(dx), the pinching centred for the direction of motion sp (``_advance``)."""
    w, e = y[0], y[1]
    xy, n, eta = th[_XY], th[_N], th[_ETA]
    dnu, deta, zs, p, q = th[_DNU], th[_DETA], th[_ZS], th[_P], th[_Q]
    psi, dpsi, lam = th[_PSI], th[_DPSI], th[_LAM]
    nu = 1.0 + dnu * e
    eta_d = 1.0 + deta * e
    loading = (w > 0.0) == (s > 0.0)
    c = 1.0 if loading else eta
    aw = abs(w)
    P = math.exp(n * math.log(aw)) if aw > 0.0 else 0.0
    phi = 1.0 - nu * c * P
    wu = math.exp(-math.log(nu) / n)
    ex = math.exp(-p * e)
    z1 = zs * (1.0 - ex)
    width = psi + dpsi * e
    z2 = width * (lam + z1)
    u = (w * sp - q * wu) / z2
    G = math.exp(-u * u)
    hp = 1.0 - z1 * G
    D = eta_d * xy
    g = hp * phi / D
    out[0] = g
    out[1] = w
    if d == 0:
        return
    # Partial derivatives of g: in w, in e, and in each θ_j (hp_j = −ζ₁_j·G + 2ζ₁·G·u·u_j with
    # u_j = −q·w_u_j/ζ₂ − u·ζ₂_j/ζ₂ for everything reaching the pinching).
    two_gu = 2.0 * z1 * G * u
    phi_w = -nu * c * n * P / w if aw > 0.0 else 0.0
    hp_w = two_gu * sp / z2
    g_w = (hp_w * phi + hp * phi_w) / D
    z1_e = zs * p * ex
    z2_e = dpsi * (lam + z1) + width * z1_e
    wu_e = -wu * dnu / (n * nu)
    u_e = -q * wu_e / z2 - u * z2_e / z2
    hp_e = -z1_e * G + two_gu * u_e
    phi_e = -dnu * c * P
    g_e = (hp_e * phi + hp * phi_e) / D - g * deta / eta_d
    log_w = math.log(aw) if aw > 0.0 else 0.0
    Sw = y[2 : 2 + d]
    Se = y[2 + d : 2 + 2 * d]
    for j in range(d):
        out[2 + j] = g_w * Sw[j] + g_e * Se[j]
        out[2 + d + j] = Sw[j]
    # x_y and δη: g ∝ 1/(η_d·x_y)
    out[2 + _XY] += -g / xy
    out[2 + _DETA] += -g * e / eta_d
    # n: Φ and w_u
    wu_n = wu * math.log(nu) / (n * n)
    out[2 + _N] += (two_gu * (-q * wu_n / z2) * phi + hp * (-nu * c * P * log_w)) / D
    # η: Φ on unloading only
    if not loading:
        out[2 + _ETA] += hp * (-nu * P) / D
    # δν: Φ and w_u
    wu_dnu = -wu * e / (n * nu)
    out[2 + _DNU] += (two_gu * (-q * wu_dnu / z2) * phi + hp * (-e * c * P)) / D
    # ζ_s and p: through ζ₁ (into ζ₂ too)
    for j, z1_j in ((_ZS, 1.0 - ex), (_P, zs * e * ex)):
        z2_j = width * z1_j
        out[2 + j] += (-z1_j * G + two_gu * (-u * z2_j / z2)) * phi / D
    # q
    out[2 + _Q] += two_gu * (-wu / z2) * phi / D
    # ψ, δψ, λ: through ζ₂ only
    for j, z2_j in ((_PSI, lam + z1), (_DPSI, e * (lam + z1)), (_LAM, width)):
        out[2 + j] += two_gu * (-u * z2_j / z2) * phi / D


@numba.njit(cache=True, error_model="numpy")
def _work(w, e, dx, th):
    """RK4 work of the piece dx from (w, e): |dx| times a bound on the yield term's stiffness
    n·ν·c·|w|^(n−1)/(η_d·x_y) (|w| at least 1, where w saturates), plus the pinching's: |∂h/∂w| ≤
    0.86·ζ₁/ζ₂ (≤ 0.86/ψ, as ζ₁/(λ + ζ₁) < 1) times the w the piece can travel (at most its whole range),
    so that a substep moves w by a fraction of the pinching band's width."""
    xy, n, eta = th[_XY], th[_N], th[_ETA]
    nu = 1.0 + th[_DNU] * e
    D = (1.0 + th[_DETA] * e) * xy
    c = max(1.0, abs(eta))
    aw = max(1.0, abs(w))
    P = math.exp((n - 1.0) * math.log(aw))
    z1 = th[_ZS] * (1.0 - math.exp(-th[_P] * e))
    z2 = (th[_PSI] + th[_DPSI] * e) * (th[_LAM] + z1)
    travel = min(abs(dx) * (1.0 + nu * c * P * aw) / D, 2.0 * (1.0 + aw))
    return abs(dx) * n * nu * c * P / D + 0.86 * z1 / z2 * travel


@numba.njit(cache=True, error_model="numpy")
def _advance(y, dx, th, d, K, Y, v):
    """Integrate y over the monotone piece dx in place; False when it is not finite or too stiff. The
    pinching's sign(ẋ) is that of the velocity ``v`` (of dx where v = 0): on a quasi-static record the
    direction of motion with its dead band, so that digitising jitter does not flip the pinching."""
    if dx == 0.0:
        return True
    s = 1.0 if dx > 0.0 else -1.0
    sp = 1.0 if v > 0.0 else -1.0 if v < 0.0 else s
    work = _work(y[0], y[1], dx, th)
    if not work < _WORK_PER_SUBSTEP * _MAX_SUBSTEPS:
        return False
    m = int(math.ceil(work / _WORK_PER_SUBSTEP)) if work > _WORK_PER_SUBSTEP else 1
    h = dx / m
    size = 2 + 2 * d
    for _ in range(m):
        _rhs(y, s, sp, th, K[0], d)
        for i in range(size):
            Y[i] = y[i] + 0.5 * h * K[0, i]
        _rhs(Y, s, sp, th, K[1], d)
        for i in range(size):
            Y[i] = y[i] + 0.5 * h * K[1, i]
        _rhs(Y, s, sp, th, K[2], d)
        for i in range(size):
            Y[i] = y[i] + h * K[2, i]
        _rhs(Y, s, sp, th, K[3], d)
        for i in range(size):
            y[i] = y[i] + h * (K[0, i] + 2.0 * K[1, i] + 2.0 * K[2, i] + K[3, i]) / 6.0
        if not (np.isfinite(y[0]) and np.isfinite(y[1])):
            return False
    return True


@numba.njit(cache=True, error_model="numpy")
def trajectory_into(th, t, x, v, w, dW, d):
    """w at each sample into ``w`` (L,) and, for d = 11, ∂w/∂θ into ``dW`` (L, 11); the record starts at
    w = e = 0. Returns False where the simulation did not finish."""
    size = 2 + 2 * d
    y = np.zeros(size)
    Y = np.empty(size)
    K = np.empty((4, size))
    w[0] = 0.0
    for j in range(d):
        dW[0, j] = 0.0
    for k in range(x.shape[0] - 1):
        if (v[k] >= 0.0) == (v[k + 1] >= 0.0):
            ok = _advance(y, x[k + 1] - x[k], th, d, K, Y, v[k])
        else:
            dx0, dx1 = reversal_pieces(t[k], t[k + 1], x[k], x[k + 1], v[k], v[k + 1])
            ok = _advance(y, dx0, th, d, K, Y, v[k]) and _advance(y, dx1, th, d, K, Y, v[k + 1])
        if not ok:
            return False
        w[k + 1] = y[0]
        for j in range(d):
            dW[k + 1, j] = y[2 + j]
    return True


@numba.njit(cache=True, error_model="numpy")
def trajectories_into(Theta, t, x, v, W):
    """w of each θ row into the rows of W (m, L); rows of +inf where the simulation did not finish."""
    empty = np.empty((1, 0))
    for r in range(Theta.shape[0]):
        if not trajectory_into(Theta[r], t, x, v, W[r], empty, 0):
            W[r, :] = np.inf


def trajectories(Theta, t, x, v) -> np.ndarray:
    """w (m, L) of θ rows (m, 11): +inf rows where the simulation did not finish."""
    Theta = np.ascontiguousarray(np.atleast_2d(Theta), dtype=float)
    W = np.empty((Theta.shape[0], len(x)))
    t, x, v = (np.ascontiguousarray(a, dtype=float) for a in (t, x, v))
    trajectories_into(Theta, t, x, v, W)
    return W


def sensitivities(theta, t, x, v):
    """(w (L,), ∂w/∂θ (L, 11)) of one θ; (+inf w, None) where the simulation did not finish."""
    theta = np.ascontiguousarray(theta, dtype=float)
    w = np.empty(len(x))
    dW = np.empty((len(x), N_THETA))
    t, x, v = (np.ascontiguousarray(a, dtype=float) for a in (t, x, v))
    if not trajectory_into(theta, t, x, v, w, dW, N_THETA) or not np.all(np.isfinite(dW)):
        return np.full(len(x), np.inf), None
    return w, dW
