"""The switched Bouc-Wen kernel with forward sensitivities: z and ∂z/∂θ at the samples, for exact Jacobians.

The scalar kernel (``switched_kernel``) integrates dz/dx = g(z; H) with H = (A+, n+, β+, γ+, A−, n−,
β−, γ−) per displacement piece, by RK4 in a number of substeps set by the local stiffness, or by
backward Euler past ``RK4_MAX_SUBSTEPS``. Here the same steps carry S = ∂z/∂H (8 columns; 4 when
both branches share one set, as the classic model's):

    RK4:            S' = g_z·S + ∂g/∂H along each stage (the augmented system, the same stages),
    backward Euler: S₁ = (S₀ + h·∂g/∂H(z₁)) / (1 − h·g_z(z₁)),

which is the exact derivative of the discrete map the plain kernel applies (its substep counts are
integers, constant between the isolated parameter values where they change). z itself is computed by
the very same floating-point operations as ``kernel._hysteretic_into``, so it is
bit-identical to the plain kernel's (and the lockstep kernel's). With p = |z|ⁿ and c = β + γ loading
(sign(z·dx) > 0), β − γ unloading:

    g = A − c·p,  g_z = −c·n·p/z,  ∂g/∂A = 1,  ∂g/∂n = −c·p·ln|z|,  ∂g/∂β = −p,  ∂g/∂γ = ∓p,

all taken as 0 at z = 0 but ∂g/∂A (where S = 0: the record's start); ∂g/∂H is non-zero only in the
active branch's 4 columns. The searched parameters θ get ∂z/∂θ = ∂z/∂H·M once at the end, M = ∂H/∂θ
(8, d) given by the caller: the identity for the paper's parameters, the Jacobian of
``switched_identifiable.kernel_hysteretic`` for the identifiable ones (``identifiable_jacobian``),
both halves the same for the classic model. A trajectory that is not finite gives no sensitivities
(the caller takes differences).
"""

from __future__ import annotations

import numba
import numpy as np

from bwbench.models.power import exp, log
from bwbench.models.switched.kernel import (
    IMPLICIT_SUBSTEPS,
    RK4_MAX_SUBSTEPS,
    RK4_STIFFNESS_PER_SUBSTEP,
    backward_euler,
    branch_offset,
    loading_attractor,
    reversal_pieces,
    rk4_substeps,
    takes_implicit,
)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _rate_sens(z, p, log_z, direction, A, n, beta, gamma, S, s, col, out, o):
    """g(z) (``kernel._rate``, the same operations; p = |z|ⁿ and log_z = log|z| from
    ``_pow_log``, unused at z = 0) and into
    row ``o`` of ``out`` its total derivative g_z·S + ∂g/∂H at S's row ``s``, the branch's (A, n, β, γ)
    at columns ``col``..``col + 3``. (Rows of 2-D arrays, not views: a view costs two atomic reference
    counts, as much as the arithmetic here.)"""
    d = S.shape[1]
    if z == 0.0:
        for q in range(d):
            out[o, q] = 0.0
        out[o, col] = 1.0
        return A
    if (z > 0.0) == (direction > 0.0):
        c = beta + gamma
        g = A - (beta + gamma) * p
        g_gamma = -p
    else:
        c = beta - gamma
        g = A - (beta - gamma) * p
        g_gamma = p
    g_z = -c * n * p / z
    for q in range(d):
        out[o, q] = g_z * S[s, q]
    out[o, col] += 1.0
    out[o, col + 1] -= c * p * log_z
    out[o, col + 2] -= p
    out[o, col + 3] += g_gamma
    return g


@numba.njit(cache=True, error_model="numpy")
def _pow_log(z, n):
    """(|z|ⁿ, log|z|), (0, 0) at z = 0: the power by ``power``'s own operations, exp(n·log|z|), so it
    is bit-identical to the plain kernel's, and its log is the one ∂g/∂n needs (no second log)."""
    if z == 0.0:
        return 0.0, 0.0
    log_z = log(abs(z))
    return exp(n * log_z), log_z


@numba.njit(cache=True, error_model="numpy")
def _slopes(z, direction, n, beta, gamma):
    """(g_z, g_n, g_β, g_γ) of ``_rate_sens`` at z (0 at z = 0), for the backward-Euler step."""
    if z == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    p, log_z = _pow_log(z, n)
    loading = (z > 0.0) == (direction > 0.0)
    c = beta + gamma if loading else beta - gamma
    return -c * n * p / z, -c * p * log_z, -p, -p if loading else p


@numba.njit(cache=True, error_model="numpy")
def _advance_z_sens(z, S, slot, dx, A, n, beta, gamma, z_s, attractor_rate, col, K):
    """``kernel._advance_z`` (the same operations on z) with row ``slot`` of S = ∂z/∂H updated
    in place, the branch's (A, n, β, γ) at columns ``col``..``col + 3``; K (5, d): work space (the four
    stages' derivatives, a stage's S in row 4)."""
    if dx == 0.0 or not np.isfinite(z):
        return z
    d = S.shape[1]
    direction = 1.0 if dx > 0.0 else -1.0
    stiffness = attractor_rate
    p, log_z = _pow_log(z, n)
    if z != 0.0:
        c = (beta + gamma) if (z > 0.0) == (direction > 0.0) else (beta - gamma)
        local = n * abs(c) * p / abs(z)
        if (n >= 1.0 or abs(z) > z_s) and local > stiffness:
            stiffness = local
    work = stiffness * abs(dx)
    if takes_implicit(work, z, direction, z_s):
        h = dx / IMPLICIT_SUBSTEPS
        z_att = direction * z_s
        done = 0
        fixed = False  # z on a fixed point of the step: the plain kernel stops, S still moves
        g_z = g_n = g_beta = g_gamma = 0.0
        while done < IMPLICIT_SUBSTEPS:
            if not fixed:
                z_new = backward_euler(z, h, A, n, beta, gamma, z_att)
                if np.isnan(z_new):
                    break
                fixed = z_new == z and z != 0.0
                z = z_new
                # z₁ = z₀ + h·g(z₁; H) differentiated: (1 − h·g_z)·S₁ = S₀ + h·∂g/∂H.
                g_z, g_n, g_beta, g_gamma = _slopes(z, direction, n, beta, gamma)
            scale = 1.0 / (1.0 - h * g_z)
            S[slot, col] += h
            S[slot, col + 1] += h * g_n
            S[slot, col + 2] += h * g_beta
            S[slot, col + 3] += h * g_gamma
            for q in range(d):
                S[slot, q] *= scale
            done += 1
        if done == IMPLICIT_SUBSTEPS:
            return z
        dx = h * (IMPLICIT_SUBSTEPS - done)
        work = RK4_STIFFNESS_PER_SUBSTEP * RK4_MAX_SUBSTEPS
        p, log_z = _pow_log(z, n)
    m = rk4_substeps(work)
    h = dx / m
    for i in range(m):
        if i > 0:
            p, log_z = _pow_log(z, n)
        # k1 is the plain kernel's (inline at i = 0, _rate after): the same operations on the same p.
        k1 = _rate_sens(z, p, log_z, direction, A, n, beta, gamma, S, slot, col, K, 0)
        for q in range(d):
            K[4, q] = S[slot, q] + 0.5 * h * K[0, q]
        z2 = z + 0.5 * h * k1
        p, log_z = _pow_log(z2, n)
        k2 = _rate_sens(z2, p, log_z, direction, A, n, beta, gamma, K, 4, col, K, 1)
        for q in range(d):
            K[4, q] = S[slot, q] + 0.5 * h * K[1, q]
        z3 = z + 0.5 * h * k2
        p, log_z = _pow_log(z3, n)
        k3 = _rate_sens(z3, p, log_z, direction, A, n, beta, gamma, K, 4, col, K, 2)
        for q in range(d):
            K[4, q] = S[slot, q] + h * K[2, q]
        z4 = z + h * k3
        p, log_z = _pow_log(z4, n)
        k4 = _rate_sens(z4, p, log_z, direction, A, n, beta, gamma, K, 4, col, K, 3)
        z = z + h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        for q in range(d):
            S[slot, q] = S[slot, q] + h * (K[0, q] + 2.0 * K[1, q] + 2.0 * K[2, q] + K[3, q]) / 6.0
        if not np.isfinite(z):
            return z
    return z


@numba.njit(cache=True, error_model="numpy")
def _hysteretic_sens_into(H, cols, t, x, v, split, z, dZ):
    """``kernel._hysteretic_into`` with the sensitivities: z of the active branch into ``z``
    (L,) and ∂z/∂H into ``dZ`` (L, d), branch b's (A, n, β, γ) at columns ``cols[b]``..``cols[b] + 3``
    (d = 8, cols (0, 4); or d = 4, cols (0, 0) for one set shared by both branches). False as soon as
    z is not finite (``hysteretic_sensitivity`` checks ∂z/∂θ)."""
    n_samples = x.shape[0]
    d = dZ.shape[1]
    z_s = np.empty(2)
    rate = np.empty(2)
    for i in range(2):
        z_s[i], rate[i] = loading_attractor(H, i)
    z_plus = 0.0
    z_minus = 0.0
    S = np.zeros((2, d))  # ∂z₊/∂H, ∂z₋/∂H (split; shared: row 0 only)
    K = np.empty((5, d))
    z[0] = z_plus
    dZ[0, :] = 0.0
    for k in range(n_samples - 1):
        b0 = branch_offset(v[k]) // 7
        b1 = branch_offset(v[k + 1]) // 7
        if b0 == b1:
            pieces_dx0 = x[k + 1] - x[k]
            pieces_dx1 = 0.0
        else:
            pieces_dx0, pieces_dx1 = reversal_pieces(t[k], t[k + 1], x[k], x[k + 1], v[k], v[k + 1])
        for piece in range(2):
            b = b0 if piece == 0 else b1
            dx = pieces_dx0 if piece == 0 else pieces_dx1
            if piece == 1 and dx == 0.0:
                break
            r = 4 * b
            minus = split and b == 1
            zz = z_minus if minus else z_plus
            zz = _advance_z_sens(
                zz, S, 1 if minus else 0, dx, H[r], H[r + 1], H[r + 2], H[r + 3], z_s[b], rate[b], cols[b], K
            )
            if minus:
                z_minus = zz
            else:
                z_plus = zz
        minus = split and b1 == 1
        z_active = z_minus if minus else z_plus
        if not np.isfinite(z_active):
            return False
        z[k + 1] = z_active
        slot = 1 if minus else 0
        for q in range(d):
            dZ[k + 1, q] = S[slot, q]
    return True


@numba.njit(cache=True, nogil=True, error_model="numpy")  # nogil: files of a joint fit run on threads
def _hysteretic_sens(H, cols, t, x, v, split, z, dZ):
    return _hysteretic_sens_into(H, cols, t, x, v, split, z, dZ)


def hysteretic_sensitivity(H, M, t, x, v, state: str = "shared"):
    """(z (L,), ∂z/∂θ (L, d)) of one kernel row H (8,) whose Jacobian by the d searched parameters is
    M = ∂H/∂θ (8, d); None where z or its sensitivities are not finite (a blow-up)."""
    from bwbench.models.switched.simulation import as_excitation, check_state

    split = check_state(state)
    H = np.ascontiguousarray(np.asarray(H, dtype=float))
    M = np.ascontiguousarray(np.asarray(M, dtype=float))
    if H.shape != (8,) or M.ndim != 2 or M.shape[0] != 8:
        raise ValueError(f"H must have shape (8,) and M (8, d), got {H.shape} and {M.shape}")
    t, x, v, _ = as_excitation(t, x, v, v)
    # ∂z/∂H in the kernel, then ∂z/∂θ = ∂z/∂H·M once: the stages then carry the 4 sources of the active
    # branch instead of 4·d products. One set for both branches (M's rows equal by halves): 4 columns.
    one_set = np.array_equal(M[:4], M[4:]) and np.array_equal(H[:4], H[4:])
    z = np.empty(x.shape[0])
    dZ_H = np.empty((x.shape[0], 4 if one_set else 8))
    cols = np.array([0, 0] if one_set else [0, 4], dtype=np.int64)
    if not _hysteretic_sens(H, cols, t, x, v, split, z, dZ_H):
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        dZ = dZ_H @ (M[:4] if one_set else M)
    if not np.all(np.isfinite(dZ)):
        return None
    return z, dZ


def identifiable_jacobian(theta, state: str = "shared") -> np.ndarray:
    """∂H/∂θ (8, d) of ``switched_identifiable.kernel_hysteretic`` at one θ (d = 7 shared, 6 split):
    H = (1/x_y₊, n₊, s₊(1+η₊)/2, s₊(1−η₊)/2, ρ/x_y₋, n₋, s₋(1+η₋)/2, s₋(1−η₋)/2) with s₊ = 1/x_y₊
    and s₋ = ρ^(1−n₋)/x_y₋ (ρ = 1 split)."""
    theta = np.asarray(theta, dtype=float)
    xp, _, ep, xm, n_m, em = theta[:6]
    shared = state == "shared"
    rho = theta[6] if shared else 1.0
    s_p = 1.0 / xp
    s_m = rho ** (1.0 - n_m) / xm
    M = np.zeros((8, 7 if shared else 6))
    M[0, 0] = -1.0 / xp**2
    M[1, 1] = 1.0
    M[2, 0], M[2, 2] = -s_p * (1 + ep) / (2 * xp), s_p / 2
    M[3, 0], M[3, 2] = -s_p * (1 - ep) / (2 * xp), -s_p / 2
    M[4, 3] = -rho / xm**2
    M[5, 4] = 1.0
    for row, sign in ((6, 1.0), (7, -1.0)):
        half = (1 + sign * em) / 2
        M[row, 3] = -s_m / xm * half
        M[row, 4] = -np.log(rho) * s_m * half
        M[row, 5] = sign * s_m / 2
    if shared:
        M[4, 6] = 1.0 / xm
        for row, sign in ((6, 1.0), (7, -1.0)):
            M[row, 6] = (1.0 - n_m) * s_m / rho * (1 + sign * em) / 2
    return M


def force_sensitivities(P, signal, state: str = "shared"):
    """(force (L,) N, ∂F/∂P (L, 14)) of one paper 14-vector P: F = ẍ + 2ξ_b·ωn_b·ẋ + α_b·ωn_b²·x
    + (1 − α_b)·ωn_b²·z on each branch b, z and ∂z/∂H from ``hysteretic_sensitivity``; None on a
    blow-up. The force is computed as ``SwitchedBoucWen.force_batch`` computes it."""
    from bwbench.models.switched.kernel import HYSTERETIC_INDEX

    P = np.asarray(P, dtype=float)
    index = list(HYSTERETIC_INDEX)
    return branch_force(P[:7], P[7:], P[index], np.eye(8), index, signal, state, 14)


def branch_force(plus, minus, H, M, columns, signal, state, width):
    """(F (L,), ∂F/∂P (L, width)) for branch sets ``plus``/``minus`` = (A, n, α, β, γ, ξ, ωn), kernel row
    H with ∂H/∂P = M (8, d) whose d columns are the P indices ``columns``; the explicit α, ξ, ωn of
    each branch at P indices 2, 5, 6 (+7 for '−' when width is 14, the same for the classic model)."""
    s = signal
    found = hysteretic_sensitivity(H, M, s.t, s.x, s.v, state)
    if found is None:
        return None
    z, dZ = found
    x, v, a = (np.asarray(getattr(s, k), dtype=float) for k in "xva")
    is_plus = v >= 0.0
    # Per sample the active branch's α, ξ, ωn: the force by force_batch's operations, element by element.
    alpha, xi, wn = (np.where(is_plus, plus[i], minus[i]) for i in (2, 5, 6))
    dF = np.zeros((len(x), width))
    with np.errstate(invalid="ignore", over="ignore"):
        F = a + 2.0 * xi * wn * v + alpha * wn * wn * x + (1.0 - alpha) * wn * wn * z
        dF[:, columns] = ((1.0 - alpha) * wn * wn)[:, None] * dZ
        explicit = (wn * wn * (x - z), 2.0 * wn * v, 2.0 * xi * v + 2.0 * alpha * wn * x + 2.0 * (1.0 - alpha) * wn * z)
    for mask, offset in ((is_plus, 0), (~is_plus, 7 if width == 14 else 0)):
        for column, values in zip((2, 5, 6), explicit):
            dF[mask, offset + column] = values[mask]
    if not (np.all(np.isfinite(F)) and np.all(np.isfinite(dF))):
        return None
    return F, dF
