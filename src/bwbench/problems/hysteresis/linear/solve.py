"""The linear part of an identifiable formulation: one least-squares solve per trajectory.

A model with a linear part (``bwbench.models.base.LinearLayout``) writes its force as
F = Σ_j β_j·g_j, where the columns g_j are signals of the excitation (x, ẋ, ẍ, 1) or one column
w(θ) that depends on the searched parameters θ (the switched model's z/z_s, Spencer's ẏ). A
branched model (the switched Bouc-Wen) has a '+' copy of each column where ẋ ≥ 0 and a '−' copy
where ẋ < 0 (docs/design.md#formulations):

    F = m·ẍ + c_b·ẋ + k_b·x + h_b·w + f_b

The design matrix is X = [G | W]: G holds the columns that do not depend on θ (ẍ when m is fitted,
and per branch the masked signals), W the masked w (one column per branch). G = Q·R_G is factorised
once (pivoted QR on unit-norm columns, so dependent columns are found and dropped) and
r0 = y − Q·Qᵀy kept; per trajectory only W is orthogonalised against Q (Gram-Schmidt with one
re-orthogonalisation, in a numba kernel of 2–3 passes over the row), then
X = [Q | Q_w]·[[R_G, QᵀW], [0, R_w]]: O(L·q) per row instead of a fresh O(L·p²) factorisation.
log|XᵀX| = 2·Σ log|R_ii| of that factor.

Inertia rule (``inertia_rule``, models with an inertia coefficient): the data decide whether m is
fitted; a sine test never separates m from k. Bounds (``linear_bounds``): a row whose unbounded
solution breaks a bound on a coefficient is re-solved by bounded least squares on its small p × p
triangular system, so the fast unbounded path is all a row pays while no bound is active. Weights:
a design over several records (a joint fit) weights each sample so that the MSE is the weighted mean
of the records' own MSEs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from bwbench.problems.hysteresis.inertia_rule import (
    M_REF,
    M_UNFITTED,
    inertia_check,
    pivoted_qr,
)
from bwbench.problems.hysteresis.linear.columns import (
    branch_masks,
    coefficient_names,
    fixed_columns,
    offsets_mode,
    tied_offsets,
)
from bwbench.problems.hysteresis.linear.kernel import mse_rows, sum_squares, w_solve
from bwbench.problems.hysteresis.linear.projection import residual_jacobian


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
            self.mse[s],
            self.coef[s],
            self.coef_ls[s],
            self.rss_ls[s],
            self.R[s],
            self.logdet[s],
            self.full_rank[s],
            self.bound_active[s],
            self.free_names,
            self.free_index,
            self.n_data,
            None if self.residual is None else self.residual[s],
            self.names,
        )


@dataclass(eq=False)  # eq=False: comparing ndarray fields would raise
class LinearDesign:
    """Everything of the linear solve that does not depend on w, for one excitation and force.

    ``signal``: excitation with t (s), x (mm), v (mm/s), a (mm/s²), each (L,) (optionally
    ``segments``: slices of the records it stacks); ``f``: measured force (N), (L,); ``layout``: the
    model's ``LinearLayout``. ``fix_mass`` (layouts with a mass): "auto" (the inertia rule decides),
    None (fitted) or a value (N·s²/mm). ``offsets``: the constant force per branch (True or
    "branch"), one for both branches ("continuous": no jump at a reversal) or none (False, as in the
    paper). ``bounds``: {coefficient name: (lower, upper)} on the solved coefficients (±inf for an open
    side); None: only ``mass_min``, the lower bound on a fitted m (None: unbounded). ``weights``:
    (L,) sample weights (None: all 1); the MSE is Σ w·r²/L. ``notes`` says what was fixed or dropped
    and why.
    """

    signal: Any
    f: np.ndarray
    layout: Any  # a bwbench.models.base.LinearLayout
    fix_mass: Any = "auto"
    offsets: Any = True
    mass_min: float | None = 0.0
    m_ref: float = M_REF
    notes: list = field(default_factory=list)
    bounds: dict | None = None
    weights: np.ndarray | None = None

    def __post_init__(self):
        s = self.signal
        self.f = np.asarray(self.f, dtype=float)
        self.L = len(self.f)
        layout = self.layout
        self.offsets = offsets_mode(self.offsets)
        self.names = coefficient_names(layout)
        self.masks = branch_masks(layout, s.v)
        for b, mask in self.masks.items():
            if not mask.any():
                dropped = " ".join(f"{n}{b}" for n in layout.names if n != layout.mass)
                self.notes.append(f"branch {b} has no samples: {dropped} dropped (NaN)")
        self.tied = tied_offsets(layout, self.masks, self.offsets)
        if self.tied:
            self.notes.append(
                "offsets continuous across a reversal: " + ", ".join(f"{a} = {b}" for a, b in self.tied.items())
            )
        quasi_static = getattr(s, "rate_independent", False)  # no time: no rate (``fixed_columns``)
        if quasi_static:
            held = [n for n, source in layout.fixed if source in ("v", "a")] + ([layout.mass] if layout.mass else [])
            self.notes.append(
                f"quasi-static record (no time column): {', '.join(held)} held at 0 — no viscous or inertia force"
            )
        self.inertia = (
            inertia_check(s, self.f, layout, self.offsets, self.m_ref) if layout.mass and not quasi_static else None
        )
        if not layout.mass or quasi_static:
            self.mass = 0.0  # no inertia term in this model, or none on a quasi-static record
        elif isinstance(self.fix_mass, str):
            if self.fix_mass != "auto":
                raise ValueError(f"fix_mass must be 'auto', None or a number, got {self.fix_mass!r}")
            self.mass = None if self.inertia.fit else M_UNFITTED
            self.notes.append(self.inertia.reason)
        else:
            self.mass = None if self.fix_mass is None else float(self.fix_mass)
            self.notes.append(
                "m fitted (fix_mass=None)" if self.mass is None else f"m fixed at {self.mass:g} by the caller"
            )
        self.sw = None if self.weights is None else np.sqrt(np.asarray(self.weights, dtype=float))
        names, cols = fixed_columns(s, layout, self.masks, self.offsets)
        if self.mass is None:
            names, cols = [layout.mass] + names, [np.asarray(s.a, dtype=float)] + cols
            y = self.f.copy()
        else:
            y = self.f - self.mass * np.asarray(s.a, dtype=float) if layout.mass else self.f.copy()
        self.y = y if self.sw is None else y * self.sw
        self._factor(names, cols if self.sw is None else [c * self.sw for c in cols])
        self.w_names = tuple(f"{layout.varying}{b}" for b, mask in self.masks.items() if mask.any())
        self.free_names = tuple(self.g_names) + self.w_names
        self.free_index = np.array([self.names.index(n) for n in self.free_names], dtype=np.int64)
        # For each sample, the index of its w-column (its branch among the present ones).
        self._col = np.zeros(self.L, dtype=np.int64)
        if len(self.w_names) == 2:
            self._col[self.masks["-"]] = 1
        from bwbench.problems.hysteresis.linear.bounds import free_bounds

        if self.bounds is None:
            self.bounds = {layout.mass: (self.mass_min, np.inf)} if layout.mass and self.mass_min is not None else {}
        self.lower, self.upper = free_bounds(self)
        self._bounded = bool(np.any(np.isfinite(self.lower)) or np.any(np.isfinite(self.upper)))
        # A solved row's coefficients before its free values go in: 0 for the fixed and dropped ones of
        # the present branches, the mass where it is not fitted, NaN for an absent branch's.
        self._coef_template = np.full(len(self.names), np.nan)
        for b, mask in self.masks.items():
            if mask.any():
                self._coef_template[[self.names.index(f"{n}{b}") for n in layout.names if n != layout.mass]] = 0.0
        if layout.mass:
            self._coef_template[self.names.index(layout.mass)] = self.mass if self.mass is not None else 0.0

    def _factor(self, names, cols):
        Q, R, perm, rank, scale = pivoted_qr(cols)
        for j in perm[rank:]:
            self.notes.append(f"{names[j]} not separable from the other columns on these data: set to 0")
        keep = perm[:rank]
        self.g_names = [names[j] for j in keep]
        self.G = np.column_stack([cols[j] for j in keep])  # weighted, for residuals of bounded rows
        self.Q = np.ascontiguousarray(Q)
        self.QT = np.ascontiguousarray(Q.T)  # the kernel reads whole columns of Q
        self.RG = R * scale[keep]  # G[:, keep] = Q·RG
        self.Qty = self.Q.T @ self.y
        r0 = self.y - self.Q @ self.Qty
        self.r0 = r0 - self.Q @ (self.Q.T @ r0)
        self.r0_2 = sum_squares(self.r0)  # ‖r0‖², for mse_rows (w_solve takes it the same way)

    def _unbounded(self, Z, residual: bool):
        """The kernel's unbounded solve of the rows of Z: (Zg, good, fit residuals, C, Rw, qwy, h, rss,
        full, g), ``good`` cleared where the trajectory or the solve is not finite."""
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        good = np.all(np.isfinite(Z), axis=1)
        Zg = np.where(good[:, None], Z, 0.0)
        if self.sw is not None:
            Zg = Zg * self.sw
        fit_res = np.full((len(Z), self.L), -np.inf) if residual else np.empty((0, self.L))
        found = w_solve(Zg, good, self._col, self.QT, self.r0, len(self.w_names), residual, fit_res, self.RG, self.Qty)
        C, Rw, qwy, h, rss, full, g = found
        # A finite but huge trajectory (|w| ~ 1e300) can overflow the solve: a blow-up, not a crash.
        good &= np.isfinite(rss) & np.all(np.isfinite(h), axis=1) & np.all(np.isfinite(C), axis=(1, 2))
        return Zg, good, fit_res, C, Rw, qwy, h, rss, full, g

    def mse(self, Z) -> np.ndarray:
        """``solve(Z).mse`` (N²) without the rest of the solution: what a loss needs, at a few microseconds
        per call instead of ~50 for one row. A row whose unbounded coefficients break a bound takes the
        full solve; every row's number is the one ``solve`` gives."""
        Z = np.ascontiguousarray(np.atleast_2d(np.asarray(Z, dtype=float)))
        sw = np.empty(0) if self.sw is None else self.sw
        nw = len(self.w_names)
        rss, bad = mse_rows(
            Z, sw, self._col, self.QT, self.r0, self.r0_2, nw, self.RG, self.Qty, self.lower, self.upper, self._bounded
        )
        mse = rss / self.L
        if bad.any():
            mse[bad] = self.solve(Z[bad]).mse
        return mse

    def solve(self, Z, residual: bool = False) -> LinearSolution:
        """Solve the linear coefficients for each row of Z (m, L), w trajectories (+inf rows: blow-up)."""
        Zg, good, fit_res, C, Rw, qwy, h, rss, full, g = self._unbounded(Z, residual)
        m, q, nw = len(Zg), self.Q.shape[1], len(self.w_names)
        C, h = np.where(good[:, None, None], C, 0.0), np.where(good[:, None], h, 0.0)
        p = q + nw
        R = np.zeros((m, p, p))
        R[:, :q, :q] = self.RG
        R[:, :q, q:] = C
        R[:, q:, q:] = Rw
        diag = np.abs(np.diagonal(R, axis1=1, axis2=2))
        with np.errstate(divide="ignore"):
            logdet = np.where(full & good, 2.0 * np.sum(np.log(diag), axis=1), -np.inf)
        beta = np.concatenate([g, h], axis=1)
        coef = np.repeat(self._coef_template[None, :], m, axis=0)
        coef[:, self.free_index] = beta
        self._tie(coef)
        coef[~good] = np.nan
        rss = np.where(good, rss, np.inf)
        res = None
        if residual:
            res = -fit_res if self.sw is None else -fit_res / self.sw
        out = LinearSolution(
            rss / self.L,
            coef,
            np.where(good[:, None], beta, np.nan),
            rss,
            R,
            logdet,
            full,
            np.zeros(m, bool),
            self.free_names,
            self.free_index,
            self.L,
            res,
            self.names,
        )
        if self._bounded:
            from bwbench.problems.hysteresis.linear.bounds import apply_bounds

            apply_bounds(self, out, Zg, qwy, good)
        return out

    def residual_jacobian(self, z, dZ):
        """(residual (L,), its Jacobian (L, d)) of one trajectory z (L,) whose derivatives by the d
        searched parameters are dZ (L, d); None where the solve has no derivative to give (a dependent
        column, a trajectory that did not finish, a non-finite result).

        Variable projection (Golub & Pereyra 1973): with X = [G | W(θ)] (W: the masked w-columns),
        β̂ = X⁺y and r = Xβ̂ − y (weighted by √weights, like the solve),
        ∂r/∂θ_j = P⊥·(∂X/∂θ_j)·β̂ − X·(XᵀX)⁻¹·(∂X/∂θ_j)ᵀ·r, where ∂X/∂θ_j has only the w-columns.
        With bounds active (``linear_bounds``), the coefficients held on their bounds are constants of
        the active set, which is locally fixed: the solve is the unbounded one over the free columns
        X_F of y − X_H·β_H, so the same formula holds with X_F in place of X in the projector and in
        the second term, while (∂X/∂θ_j)·β̂ keeps every w-column, held ones with their bound value
        (their contribution X_H·β_H moves with θ and is projected like the rest). The residual is
        the one ``solve`` gives (model − data), weighted as there."""
        return residual_jacobian(self, z, dZ)

    def _tie(self, coef):
        for tied, source in self.tied.items():
            coef[:, self.names.index(tied)] = coef[:, self.names.index(source)]
