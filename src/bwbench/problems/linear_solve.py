"""The linear part of an identifiable formulation: one least-squares solve per trajectory.

A model with a linear part (``bwbench.models.base.LinearLayout``) writes its force as
F = Σ_j β_j·g_j, where the columns g_j are signals of the excitation (x, ẋ, ẍ, 1) or one column
w(θ) that depends on the searched parameters θ (the switched model's z/z_s, Spencer's ẏ). A
branched model (the switched Bouc-Wen) has a '+' copy of each column where ẋ ≥ 0 and a '−' copy
where ẋ < 0 (DESIGN.md §8):

    F = m·ẍ + c_b·ẋ + k_b·x + h_b·w + f_b

The design matrix is X = [G | W]: G holds the columns that do not depend on θ (ẍ when m is fitted,
and per branch the masked signals), W the masked w (one column per branch). G = Q·R_G is factorised
once (pivoted QR on unit-norm columns, so dependent columns are found and dropped) and
r0 = y − Q·Qᵀy kept; per trajectory only W is orthogonalised against Q (Gram-Schmidt with one
re-orthogonalisation, in a numba kernel of 2–3 passes over the row), then
X = [Q | Q_w]·[[R_G, QᵀW], [0, R_w]]: O(L·q) per row instead of a fresh O(L·p²) factorisation.
log|XᵀX| = 2·Σ log|R_ii| of that factor.

Inertia rule (``inertia_check``, models with an inertia coefficient), data only. σ̂ = robust force
noise from 4th differences of F (polynomial trends of degree < 4 cancel; Var Δ⁴ε = 70·σ²). With
m_ref = 1 N·s²/mm (the paper's implicit m, the value m is fixed at when not fitted):

- excited   ⇔ m_ref·‖ẍ_c‖ ≥ κ·σ̂, ẍ_c = ẍ minus what the offsets absorb: the inertia force of the
  reference mass stands out of the noise over the record (κ = 10);
- separable ⇔ m_ref·‖ẍ⊥‖ ≥ κ·σ̂ and ‖ẍ⊥‖ ≥ 10⁻³·‖ẍ_c‖, ẍ⊥ = ẍ orthogonal to the other fixed
  columns: the data pin m to ±m_ref/κ and the design is not near-singular. A pure sine has
  ẍ = −ω²x, so m is confounded with k_b however large the inertia force is.

m is fitted only when both hold; otherwise fixed at m_ref, and k_b absorbs any (m − m_ref)·ω².
"""

from __future__ import annotations

from dataclasses import dataclass, field
import numpy as np
import scipy.linalg

from bwbench.models.derivatives import robust_noise
from bwbench.problems.linear_solve_kernel import w_solve

M_REF = 1.0  # N·s²/mm = 1 t (1000 kg): the paper's F = ẍ + ... in the specimens' units
KAPPA = 10.0  # signal/noise (as norms over the record) needed to call a column excited
COLLINEAR = 1e-3  # ‖ẍ⊥‖/‖ẍ_c‖ below this: condition number > 1000, m and k_b not separable
RANK_TOL = 1e-9  # a unit-norm column this close to the span of the others is dependent


def force_noise(f) -> float:
    """Robust estimate of the force noise σ (N) from the 4th differences of the record.

    Median absolute deviation (×1.4826) of Δ⁴F over √70; reversals, where F jumps, are outliers
    the median ignores. Floored at 1e-12·max|F| so a noise-free record gives a tiny positive σ.
    """
    f = np.asarray(f, dtype=float)
    return float(max(robust_noise(f), 1e-12 * np.max(np.abs(f)), np.finfo(float).tiny))


@dataclass(frozen=True)
class InertiaCheck:
    """Whether the data excite the inertia term; forces are rms over the record (N)."""

    excited: bool
    separable: bool
    reason: str
    inertia_rms_N: float  # m_ref·ẍ_c
    orthogonal_rms_N: float  # m_ref·ẍ⊥
    noise_N: float  # σ̂

    @property
    def fit(self) -> bool:
        return self.excited and self.separable


def branch_masks(layout, v) -> dict:
    """{suffix: samples of that branch}: '+' (ẋ ≥ 0) and '−' for a branched layout, else one ''."""
    if not layout.branched:
        return {"": np.ones(len(v), dtype=bool)}
    plus = np.asarray(v) >= 0.0
    return {"+": plus, "-": ~plus}


def coefficient_names(layout) -> tuple:
    """Every coefficient of ``layout``, the mass first, then per branch in the layout's order."""
    suffixes = ("+", "-") if layout.branched else ("",)
    return tuple(n for n in layout.names if n == layout.mass) + tuple(
        f"{n}{b}" for b in suffixes for n in layout.names if n != layout.mass)


def coefficient_units(layout) -> dict:
    names = coefficient_names(layout)
    return {n: layout.units[n.rstrip("+-") if layout.branched else n] for n in names}


def _signal_column(signal, name, mask):
    if name == "1":
        return mask.astype(float)
    return np.where(mask, np.asarray(getattr(signal, name), dtype=float), 0.0)


def _fixed_columns(signal, layout, masks, offsets):
    """Names and columns (L,) of the w-independent per-branch columns of present branches."""
    names, cols = [], []
    for b, mask in masks.items():
        if not mask.any():
            continue
        for name, source in layout.fixed:
            if source == "1" and not offsets:
                continue
            names.append(f"{name}{b}")
            cols.append(_signal_column(signal, source, mask))
    return names, cols


def _pivoted_qr(cols):
    """Pivoted QR of the columns scaled to unit norm: Q (L, r), R (r, r) with G[:, perm[:r]]·diag(1/scale)
    = Q·R, perm, scale; r = numerical rank (RANK_TOL)."""
    G = np.column_stack(cols)
    scale = np.linalg.norm(G, axis=0)
    scale[scale == 0] = 1.0
    Q, R, perm = scipy.linalg.qr(G / scale, mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(R)) > RANK_TOL * max(abs(R[0, 0]), 1e-300)))
    return Q[:, :rank], R[:rank, :rank], perm, rank, scale


def inertia_check(signal, f, layout, offsets: bool = True, m_ref: float = M_REF, kappa: float = KAPPA) -> InertiaCheck:
    """Apply the inertia rule of the module docstring to an excitation (t, x, v, a) and force f (N)."""
    masks = branch_masks(layout, signal.v)
    sigma = force_noise(f)
    L = len(signal.a)
    base = ([m.astype(float) for m in masks.values() if m.any()]
            if offsets and any(source == "1" for _, source in layout.fixed) else [])
    a = np.asarray(signal.a, dtype=float)
    a_c = a - (Q := _pivoted_qr(base)[0]) @ (Q.T @ a) if base else a.copy()
    Q = _pivoted_qr(_fixed_columns(signal, layout, masks, offsets)[1])[0]
    a_o = a - Q @ (Q.T @ a)
    a_o -= Q @ (Q.T @ a_o)  # second pass: ẍ⊥ may be 1e-6 of ẍ (a sine)
    n_c, n_o = np.linalg.norm(a_c), np.linalg.norm(a_o)
    excited = m_ref * n_c >= kappa * sigma
    separable = m_ref * n_o >= kappa * sigma and n_o >= COLLINEAR * n_c
    rms = 1.0 / np.sqrt(L)
    head = (f"inertia force at m = {m_ref:g} N·s²/mm (= {m_ref:g} t): {m_ref * n_c * rms:.3g} N rms, "
            f"{m_ref * n_o * rms:.3g} N rms outside the span of the other fixed columns; force noise {sigma:.3g} N")
    if not excited:
        reason = f"inertia not excited ({head}): m fixed at {m_ref:g}"
    elif not separable:
        reason = (f"inertia excited but not separable from the stiffness ({head}; "
                  f"ẍ⊥/ẍ = {n_o / max(n_c, 1e-300):.2g}, as for a sine where ẍ = −ω²x): "
                  f"m fixed at {m_ref:g}, k absorbs (m − {m_ref:g})·ω²")
    else:
        reason = f"inertia excited and separable ({head}): m fitted"
    return InertiaCheck(bool(excited), bool(separable), reason, m_ref * n_c * rms, m_ref * n_o * rms, sigma)


@dataclass(eq=False)  # eq=False: comparing ndarray fields would raise
class LinearSolution:
    """Per-row results of the linear solve for a batch of m trajectories on L samples.

    ``coef`` (m, k) follows ``names`` (the design's ``names``: every coefficient of the layout);
    fixed coefficients carry their fixed value, those of a branch without samples NaN. ``mse`` (m,) N²; ``residual`` (m, L) F_model − F_measured (N),
    only when asked for. Rows with a non-finite trajectory have mse = +inf, coef NaN.
    The Gaussian-posterior quantities (unbounded flat prior on the p free coefficients, in the
    order ``free_names``): ``coef_ls`` (m, p), ``rss_ls`` (m,) N², ``R`` (m, p, p) with
    XᵀX = RᵀR, ``logdet`` (m,) = log|XᵀX|; ``full_rank`` False where a w-column lies in the
    span of the others (then its coefficient is set to 0 and logdet = −inf). They differ from
    ``coef``/``mse`` only where the bound m ≥ mass_min is active (``bound_active``).
    """

    mse: np.ndarray
    coef: np.ndarray
    coef_ls: np.ndarray
    rss_ls: np.ndarray
    R: np.ndarray
    logdet: np.ndarray
    full_rank: np.ndarray
    bound_active: np.ndarray
    free_names: tuple
    free_index: np.ndarray
    n_data: int
    residual: np.ndarray | None = None
    names: tuple = ()

    @property
    def n_free(self) -> int:
        return len(self.free_names)

    def row(self, i: int) -> "LinearSolution":
        """The results of row i as a one-row solution."""
        s = slice(i, i + 1)
        return LinearSolution(
            self.mse[s], self.coef[s], self.coef_ls[s], self.rss_ls[s], self.R[s], self.logdet[s],
            self.full_rank[s], self.bound_active[s], self.free_names, self.free_index, self.n_data,
            None if self.residual is None else self.residual[s], self.names)


@dataclass(eq=False)  # eq=False: comparing ndarray fields would raise
class LinearDesign:
    """Everything of the linear solve that does not depend on w, for one excitation and force.

    ``signal``: excitation with t (s), x (mm), v (mm/s), a (mm/s²), each (L,); ``f``: measured
    force (N), (L,); ``layout``: the model's ``LinearLayout``. ``fix_mass`` (layouts with a mass):
    "auto" (the inertia rule decides), None (fitted) or a value (N·s²/mm). ``offsets``: fit the
    constant-force columns (else they are 0, as in the paper). ``mass_min``: lower bound on a fitted
    m (None: unbounded). ``notes`` says what was fixed or dropped and why.
    """

    signal: object
    f: np.ndarray
    layout: object
    fix_mass: object = "auto"
    offsets: bool = True
    mass_min: float | None = 0.0
    m_ref: float = M_REF
    notes: list = field(default_factory=list)

    def __post_init__(self):
        s = self.signal
        self.f = np.asarray(self.f, dtype=float)
        self.L = len(self.f)
        layout = self.layout
        self.names = coefficient_names(layout)
        self.masks = branch_masks(layout, s.v)
        for b, mask in self.masks.items():
            if not mask.any():
                dropped = " ".join(f"{n}{b}" for n in layout.names if n != layout.mass)
                self.notes.append(f"branch {b} has no samples: {dropped} dropped (NaN)")
        self.inertia = inertia_check(s, self.f, layout, self.offsets, self.m_ref) if layout.mass else None
        if not layout.mass:
            self.mass = 0.0  # no inertia term in this model
        elif isinstance(self.fix_mass, str):
            if self.fix_mass != "auto":
                raise ValueError(f"fix_mass must be 'auto', None or a number, got {self.fix_mass!r}")
            self.mass = None if self.inertia.fit else self.m_ref
            self.notes.append(self.inertia.reason)
        else:
            self.mass = None if self.fix_mass is None else float(self.fix_mass)
            self.notes.append("m fitted (fix_mass=None)" if self.mass is None else f"m fixed at {self.mass:g} by the caller")
        names, cols = _fixed_columns(s, layout, self.masks, self.offsets)
        if self.mass is None:
            names, cols = [layout.mass] + names, [np.asarray(s.a, dtype=float)] + cols
            self.y = self.f.copy()
        else:
            self.y = self.f - self.mass * np.asarray(s.a, dtype=float) if layout.mass else self.f.copy()
        self._factor(names, cols)
        self.w_names = tuple(f"{layout.varying}{b}" for b, mask in self.masks.items() if mask.any())
        self.free_names = tuple(self.g_names) + self.w_names
        self.free_index = np.array([self.names.index(n) for n in self.free_names], dtype=np.int64)
        self._bound_design = None
        # For each sample, the index of its w-column (its branch among the present ones).
        self._col = np.zeros(self.L, dtype=np.int64)
        if len(self.w_names) == 2:
            self._col[self.masks["-"]] = 1

    def _factor(self, names, cols):
        Q, R, perm, rank, scale = _pivoted_qr(cols)
        for j in perm[rank:]:
            self.notes.append(f"{names[j]} not separable from the other columns on these data: set to 0")
        keep = perm[:rank]
        self.g_names = [names[j] for j in keep]
        self.Q = np.ascontiguousarray(Q)
        self.RG = R * scale[keep]  # G[:, keep] = Q·RG
        self.Qty = self.Q.T @ self.y
        r0 = self.y - self.Q @ self.Qty
        self.r0 = r0 - self.Q @ (self.Q.T @ r0)

    def solve(self, Z, residual: bool = False) -> LinearSolution:
        """Solve the linear coefficients for each row of Z (m, L), w trajectories (+inf rows: blow-up)."""
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        good = np.all(np.isfinite(Z), axis=1)
        Zg = np.where(good[:, None], Z, 0.0)
        m, q, nw = len(Z), self.Q.shape[1], len(self.w_names)
        fit_res = np.full((m, self.L), -np.inf) if residual else np.empty((0, self.L))
        C, Rw, qwy, h, rss, full = w_solve(Zg, good, self._col, self.Q, self.r0, nw, residual, fit_res)
        # A finite but huge trajectory (|w| ~ 1e300) can overflow the solve: a blow-up, not a crash.
        good &= np.isfinite(rss) & np.all(np.isfinite(h), axis=1) & np.all(np.isfinite(C), axis=(1, 2))
        C, h = np.where(good[:, None, None], C, 0.0), np.where(good[:, None], h, 0.0)
        g = scipy.linalg.solve_triangular(self.RG, (self.Qty[None, :] - np.einsum("mqk,mk->mq", C, h)).T).T
        p = q + nw
        R = np.zeros((m, p, p))
        R[:, :q, :q] = self.RG
        R[:, :q, q:] = C
        R[:, q:, q:] = Rw
        diag = np.abs(np.diagonal(R, axis1=1, axis2=2))
        with np.errstate(divide="ignore"):
            logdet = np.where(full & good, 2.0 * np.sum(np.log(diag), axis=1), -np.inf)
        beta = np.concatenate([g, h], axis=1)
        coef = np.full((m, len(self.names)), np.nan)
        for b, mask in self.masks.items():  # fixed and dropped coefficients of present branches
            if mask.any():
                coef[:, [self.names.index(f"{n}{b}") for n in self.layout.names if n != self.layout.mass]] = 0.0
        if self.layout.mass:
            coef[:, self.names.index(self.layout.mass)] = self.mass if self.mass is not None else 0.0
        coef[:, self.free_index] = beta
        coef[~good] = np.nan
        rss = np.where(good, rss, np.inf)
        out = LinearSolution(rss / self.L, coef, np.where(good[:, None], beta, np.nan), rss, R, logdet,
                             full, np.zeros(m, bool), self.free_names, self.free_index, self.L,
                             -fit_res if residual else None, self.names)
        if self.mass is None and self.mass_min is not None:
            self._apply_mass_bound(out, Z, residual)
        return out

    def _apply_mass_bound(self, out, Z, residual):
        """Rows with m < mass_min: the constrained optimum of a convex quadratic with one violated
        bound lies on that bound, so re-solve them with m fixed at mass_min."""
        bad = out.coef[:, self.names.index(self.layout.mass)] < self.mass_min
        if not bad.any():
            return
        if self._bound_design is None:
            self._bound_design = LinearDesign(self.signal, self.f, self.layout, self.mass_min, self.offsets, None,
                                              self.m_ref)
        sub = self._bound_design.solve(Z[bad], residual)
        out.mse[bad], out.coef[bad], out.bound_active[bad] = sub.mse, sub.coef, True
        if residual:
            out.residual[bad] = sub.residual
