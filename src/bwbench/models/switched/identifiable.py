"""The identifiable formulation: symmetry-free hysteretic parameters + linearly solved coefficients.

Symmetry. In the paper model (docs/design.md#the-model), z → s·z, A → s·A, β → s^(1−n)·β, γ → s^(1−n)·γ maps
dz = (A − (β + γ·sign(z·dx))·|z|^n)·dx onto itself, and the force is unchanged if the coefficient
h = (1 − α)·ωn² of z becomes h/s (ωn² = k + h/s, α = k/ωn², ξ = c/(2ωn) with k = α·ωn², c = 2ξ·ωn
kept). Shared state: one s for both branches; split: one s per branch. The invariants per branch
(A > 0, β + γ > 0) are

    z_s = (A/(β+γ))^(1/n) (→ s·z_s),  x_y = z_s/A (mm),  n,  η = (β−γ)/(β+γ),

and with the shared state also ρ = z_s₋/z_s₊. So 7 hysteretic numbers (shared) or 6 (split) plus
the 9 linear ones (``bwbench.problems.hysteresis.linear.solve``): 16/15, of which the paper's 14 fix m = 1 and f± = 0 —
13 identifiable combinations (shared), 12 (split), as 14 minus the gauge(s).

w-dynamics. With w = z/z_s₊ (shared; split: w_b = z_b/z_s_b, i.e. ρ = 1 below) and, since
A/z_s^n = β + γ, dz/dx = A·(1 − c·|z/z_s|^n) with c = 1 loading (sign(z·dx) > 0), η unloading:

    '+':  dw/dx = (1/x_y₊)·(1 − c·|w|^n₊)
    '−':  dw/dx = (A₋/z_s₊)·(1 − c·|w/ρ|^n₋) = (1/x_y₋)·(ρ − ρ^(1−n₋)·c·|w|^n₋).

These are the paper's equation with A' = 1/x_y₊, β' + γ' = 1/x_y₊ ('+') and A' = ρ/x_y₋,
β' + γ' = ρ^(1−n₋)/x_y₋ ('−'), β' = (β'+γ')(1+η)/2, γ' = (β'+γ')(1−η)/2: the existing kernel
integrates w. The force is F = m·ẍ + c_b·ẋ + k_b·x + h_b·w + f_b.

Maps. paper → identifiable: the invariants above, c_b = 2ξ_b·ωn_b, k_b = α_b·ωn_b²,
h_b = (1 − α_b)·ωn_b²·z_s₊ (split: ·z_s_b), m = 1, f = 0. identifiable → paper: choose the gauge
z_s₊ = s (split: z_s₊ and z_s₋), then A_b = z_s_b/x_y_b, β_b + γ_b = A_b·z_s_b^(−n_b),
ωn_b² = k_b + h_b/s > 0. Gauge rule: the s minimising Σ(u_i − ½)² over the paper parameters
that depend on it (u = Table 5 unit coordinates), a 1-D search in log s (grid, then Brent) over
the interval where every ωn_b² > 0; split: one independent search per branch. m ≠ 1 or f ≠ 0
has no paper equivalent: ``to_paper`` then returns params None and the reason.

Bounds (``scaled_bounds``), amplitude a = ½·ptp(x) (docs/models.md, "The identifiable box"):
- x_y log-uniform in [1e-4, 50]·a. Lower end: an MR damper yields within ~1e-3·a (Spencer et al. 1997:
  x_y ≈ 0.02 mm at ±25 mm, where fits reached the 1e-3·a edge); below 1e-4·a w is a sign function at
  any sampling of a test. Upper end, the cap (``XY_CAP``): Tables 6–8 reach x_y₊ ≈ 22·a; from w = 0 a
  branch at x_y = 50·a moves w by at most 2a/x_y = 0.04 over a whole stroke, so for n ≥ 1 its rate
  changes by less than 4 %: it is linear, "no yield within the stroke", and its n and η mean nothing.
  Beyond the cap only h/x_y (a stiffness) would change, so the search stops there instead of
  wandering to 100·a and more. Whether a fitted branch is linear is decided on its trajectory
  (``fit_checks.linear_branches``: the rate varies by < 5 % over the branch's samples), not on x_y
  alone: in the shared state a branch can start far from w = 0 (where the other branch left it) and
  be strongly non-linear even at a large x_y, and with n < 1 |w|^n is not small at small w.
- n log-uniform in [0.2, 10.75] (Table 5's union).
- η in [−2, 1]: η ≤ 1 (γ ≥ 0) is needed, else unloading from saturation runs away (η·|w|^n > 1 at
  |w| = 1), and η < −1 (β < 0 < β + γ) is stable and means unloading from saturation up to 3×
  stiffer than at w = 0 (Table 5: at most 2×; the truths have η₋ ≈ −0.99, so −1 must not be an edge).
- ρ log-uniform in [1e-2, 1e2], symmetric under exchanging the branches (truths: 0.5–4.5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from bwbench.models.switched.parameters import LOWER, UPPER

# The 9 coefficients the switched model's force is linear in (``bwbench.models.switched.model.LAYOUT``).
LINEAR_NAMES = ("m", "c+", "k+", "h+", "f+", "c-", "k-", "h-", "f-")
HYSTERETIC_NAMES = {
    "shared": ("xy+", "n+", "eta+", "xy-", "n-", "eta-", "rho"),
    "split": ("xy+", "n+", "eta+", "xy-", "n-", "eta-"),
}
HYSTERETIC_UNITS = {"xy+": "mm", "n+": "-", "eta+": "-", "xy-": "mm", "n-": "-", "eta-": "-", "rho": "-"}
XY_CAP = 50.0  # × displacement amplitude: above it a branch started at w = 0 is linear (module docstring)
XY_RANGE = (1e-4, XY_CAP)  # × displacement amplitude
N_RANGE = (0.2, 10.75)
ETA_RANGE = (-2.0, 1.0)
RHO_RANGE = (1e-2, 1e2)
GAUGE_HALF_WIDTH = 25.0  # the gauge search spans log s₀ ± 25 (s₀: A at the centre of Table 5)


def hysteretic_names(state: str) -> tuple:
    if state not in HYSTERETIC_NAMES:
        raise ValueError(f"state must be one of {tuple(HYSTERETIC_NAMES)}, got {state!r}")
    return HYSTERETIC_NAMES[state]


LABELS = {"xy+": "x_y₊", "n+": "n₊", "eta+": "η₊", "xy-": "x_y₋", "n-": "n₋", "eta-": "η₋", "rho": "ρ"}


def scale_paper(params, s_plus: float, s_minus: float) -> np.ndarray:
    """The paper 14-vector moved along the exact symmetry: z₊ → s₊·z₊ and z₋ → s₋·z₋ (shared state:
    s₊ = s₋), i.e. A → s·A, β, γ → s^(1−n)·β, s^(1−n)·γ, and h = (1−α)·ωn² → h/s with k = α·ωn² and
    c = 2ξ·ωn kept (ωn² = k + h/s, α = k/ωn², ξ = c/(2ωn)). The force is unchanged."""
    p = np.array(params, dtype=float)
    for i, s in enumerate((s_plus, s_minus)):
        A, n, alpha, beta, gamma, xi, wn = p[7 * i : 7 * i + 7]
        k, h, c = alpha * wn**2, (1 - alpha) * wn**2 / s, 2 * xi * wn
        wn2 = np.sqrt(k + h)
        p[7 * i : 7 * i + 7] = [A * s, n, k / wn2**2, beta * s ** (1 - n), gamma * s ** (1 - n), c / (2 * wn2), wn2]
    return p


def kernel_hysteretic(theta, state: str = "shared") -> np.ndarray:
    """Kernel parameters H = (A+, n+, β+, γ+, A−, n−, β−, γ−) of the w-dynamics, shape (m, 8).

    ``theta`` (m, 7) shared or (m, 6) split, ordered as ``hysteretic_names(state)``; A in 1/mm,
    β and γ in 1/mm (w has no unit).
    """
    theta = np.atleast_2d(np.asarray(theta, dtype=float))
    if theta.shape[1] != len(hysteretic_names(state)):
        raise ValueError(f"theta must have {len(HYSTERETIC_NAMES[state])} columns for state {state!r}")
    xp, n_p, ep, xm, n_m, em = theta[:, :6].T
    rho = theta[:, 6] if state == "shared" else np.ones(len(theta))
    s_p = 1.0 / xp  # β' + γ' on '+'
    s_m = rho ** (1.0 - n_m) / xm  # β' + γ' on '−'
    return np.column_stack(
        [1.0 / xp, n_p, s_p * (1 + ep) / 2, s_p * (1 - ep) / 2, rho / xm, n_m, s_m * (1 + em) / 2, s_m * (1 - em) / 2]
    )


@dataclass(frozen=True, eq=False)
class Bounds:
    """Search box of the hysteretic parameters; ``log`` flags log-uniform ones. Physical units."""

    names: tuple
    lower: np.ndarray
    upper: np.ndarray
    log: np.ndarray
    amplitude_mm: float
    peak_force_N: float  # recorded only: every force-scaled coefficient is solved, not searched

    def from_unit(self, U) -> np.ndarray:
        lo, hi = self._ends()
        q = lo + np.asarray(U, dtype=float) * (hi - lo)
        return np.where(self.log, np.exp(np.where(self.log, q, 0.0)), q)

    def to_unit(self, P) -> np.ndarray:
        P = np.asarray(P, dtype=float)
        lo, hi = self._ends()
        with np.errstate(divide="ignore", invalid="ignore"):  # P ≤ 0 on a log scale: NaN
            q = np.where(self.log, np.log(np.where(self.log, P, 1.0)), P)
        return (q - lo) / (hi - lo)

    def _ends(self):
        """Box ends in search coordinates (log of the log-scaled ones)."""
        return (
            np.where(self.log, np.log(np.where(self.log, self.lower, 1.0)), self.lower),
            np.where(self.log, np.log(np.where(self.log, self.upper, 1.0)), self.upper),
        )


def scaled_bounds(x, f, state: str = "shared") -> Bounds:
    """The box of the module docstring for displacement x (mm) and force f (N) of a specimen."""
    names = hysteretic_names(state)
    amplitude = 0.5 * float(np.ptp(np.asarray(x, dtype=float)))
    if not amplitude > 0:
        raise ValueError("the displacement does not move: no scale for x_y")
    box = {
        "xy": (XY_RANGE[0] * amplitude, XY_RANGE[1] * amplitude, True),
        "n": (*N_RANGE, True),
        "eta": (*ETA_RANGE, False),
        "rho": (*RHO_RANGE, True),
    }
    rows = [box[name.rstrip("+-")] for name in names]
    return Bounds(
        names,
        np.array([r[0] for r in rows]),
        np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]),
        amplitude,
        float(np.max(np.abs(f))),
    )


def _branch_invariants(A, n, beta, gamma):
    if not (A > 0 and beta + gamma > 0 and n > 0):
        raise ValueError(f"no saturation: needs A > 0, β + γ > 0, n > 0 (got A={A}, β+γ={beta + gamma}, n={n})")
    z_s = (A / (beta + gamma)) ** (1.0 / n)
    return z_s, z_s / A, (beta - gamma) / (beta + gamma)


def from_paper(params, state: str = "shared"):
    """Paper 14-vector → (theta (7|6,), linear (9,) in ``LINEAR_NAMES`` order, m = 1, f = 0)."""
    p = np.asarray(params, dtype=float)
    hysteretic_names(state)
    z_s, theta, linear = [], [], np.zeros(len(LINEAR_NAMES))
    for i, b in enumerate("+-"):
        A, n, alpha, beta, gamma, xi, wn = p[7 * i : 7 * i + 7]
        zs, xy, eta = _branch_invariants(A, n, beta, gamma)
        z_s.append(zs)
        theta += [xy, n, eta]
        linear[LINEAR_NAMES.index(f"c{b}")] = 2 * xi * wn
        linear[LINEAR_NAMES.index(f"k{b}")] = alpha * wn**2
        linear[LINEAR_NAMES.index(f"h{b}")] = (1 - alpha) * wn**2 * (z_s[0] if state == "shared" else zs)
    linear[0] = 1.0
    if state == "shared":
        theta.append(z_s[1] / z_s[0])
    return np.array(theta), linear


def _branch_paper(z_s, s_h, xy, n, eta, c, k, h):
    """One branch's (A, n, α, β, γ, ξ, ωn) for saturation z_s (mm) and h's unit s_h (mm); arrays."""
    A = z_s / xy
    with np.errstate(over="ignore", invalid="ignore"):
        S = np.exp(np.log(A) - n * np.log(z_s))
        w2 = k + h / s_h
        wn = np.sqrt(np.where(w2 > 0, w2, np.nan))
        return np.stack(
            [A, np.full_like(A, n), k / wn**2, S * (1 + eta) / 2, S * (1 - eta) / 2, c / (2 * wn), wn], axis=-1
        )


def _omega_interval(k, h):
    """log s for which ωn² = k + h/s > 0, as (lo, hi) (may be empty: lo ≥ hi)."""
    if h > 0:
        return (-np.inf, np.log(h / -k)) if k < 0 else (-np.inf, np.inf)
    if h < 0:
        return (np.log(-h / k), np.inf) if k > 0 else (np.inf, -np.inf)
    return (-np.inf, np.inf) if k > 0 else (np.inf, -np.inf)


def _gauge_search(paper_of_log_s, index, lo, hi, center):
    """argmin over log s ∈ (lo, hi) of Σ(u − ½)² on the paper parameters ``index``."""
    width = (UPPER - LOWER)[index]

    def dist(log_s):
        with np.errstate(over="ignore", invalid="ignore"):
            u = (paper_of_log_s(np.atleast_1d(log_s))[..., index] - LOWER[index]) / width
            d = np.sum((u - 0.5) ** 2, axis=-1)
        return np.where(np.isfinite(d), d, np.inf)

    # Search a window of ±GAUGE_HALF_WIDTH around the centre guess, moved inside (lo, hi).
    start = min(max(center - GAUGE_HALF_WIDTH, lo), hi - 2 * GAUGE_HALF_WIDTH)
    lo, hi = max(lo, start), min(hi, start + 2 * GAUGE_HALF_WIDTH)
    margin = 1e-9 * max(1.0, abs(lo), abs(hi))
    grid = np.linspace(lo + margin, hi - margin, 501)
    d = dist(grid)
    j = int(np.argmin(d))
    a, b = grid[max(j - 1, 0)], grid[min(j + 1, len(grid) - 1)]
    res = minimize_scalar(lambda q: float(dist(q)[0]), bounds=(a, b), method="bounded", options={"xatol": 1e-12})
    return float(res.x) if res.fun <= d[j] else float(grid[j])


@dataclass(frozen=True, eq=False)
class PaperMap:
    """Result of ``to_paper``: the 14-vector (None when inexpressible), why, and the gauge used."""

    params: np.ndarray | None
    reason: str
    z_s: tuple  # (z_s₊, z_s₋) in mm, the chosen gauge (NaN when none)


def to_paper(theta, linear, state: str = "shared", tol: float = 1e-9) -> PaperMap:
    """Identifiable (theta, linear 9-vector) → paper 14-vector, gauge by the rule of the docstring.

    Needs |m − 1| ≤ tol and |f±| ≤ tol (N): the paper has no other inertia and no offsets.
    """
    theta = np.asarray(theta, dtype=float)
    lin = dict(zip(LINEAR_NAMES, np.asarray(linear, dtype=float)))
    hysteretic_names(state)
    nan2 = (np.nan, np.nan)
    if not abs(lin["m"] - 1.0) <= tol:
        return PaperMap(None, f"m = {lin['m']:.6g} N·s²/mm: the paper fixes m = 1", nan2)
    for b in "+-":
        if not abs(lin[f"f{b}"]) <= tol:
            return PaperMap(None, f"f{b} = {lin[f'f{b}']:.6g} N: the paper has no force offsets", nan2)
    xy = {"+": theta[0], "-": theta[3]}
    n = {"+": theta[1], "-": theta[4]}
    eta = {"+": theta[2], "-": theta[5]}
    intervals = {b: _omega_interval(lin[f"k{b}"], lin[f"h{b}"]) for b in "+-"}
    centre_A = 0.5 * (LOWER + UPPER)[[0, 7]]

    def branch(b, z_s, s_h):
        return _branch_paper(z_s, s_h, xy[b], n[b], eta[b], lin[f"c{b}"], lin[f"k{b}"], lin[f"h{b}"])

    if state == "shared":
        rho = theta[6]
        lo = max(intervals["+"][0], intervals["-"][0])
        hi = min(intervals["+"][1], intervals["-"][1])
        if not lo < hi:
            return PaperMap(None, "no gauge z_s₊ makes both ωn² = k + h/z_s₊ positive", nan2)

        def paper(log_s):
            s = np.exp(log_s)
            return np.concatenate([branch("+", s, s), branch("-", rho * s, s)], axis=-1)

        log_s = _gauge_search(paper, np.arange(14), lo, hi, np.log(centre_A[0] * xy["+"]))
        params = paper(np.array([log_s]))[0]
        z_s: tuple = (float(np.exp(log_s)), float(rho * np.exp(log_s)))
    else:
        parts, scales = [], []
        for i, b in enumerate("+-"):
            lo, hi = intervals[b]
            if not lo < hi:
                return PaperMap(None, f"no gauge z_s{b} makes ωn{b}² = k{b} + h{b}/z_s{b} positive", nan2)

            def branch_paper(log_s, b=b):
                s = np.exp(log_s)
                return branch(b, s, s)

            log_s = _gauge_search(branch_paper, np.arange(7), lo, hi, np.log(centre_A[i] * xy[b]))
            parts.append(branch_paper(np.array([log_s]))[0])
            scales.append(float(np.exp(log_s)))
        params, z_s = np.concatenate(parts), tuple(scales)
    if not np.all(np.isfinite(params)):
        return PaperMap(None, "the paper vector is not finite at the chosen gauge", z_s)
    return PaperMap(params, "exact: m = 1, f = 0; gauge z_s₊ = %.6g mm nearest Table 5's centre" % z_s[0], z_s)
