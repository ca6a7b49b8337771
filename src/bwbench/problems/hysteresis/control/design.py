"""The linear solve of an identifiable formulation whose solved coefficients may follow laws of the control.

A coefficient β of a column g (F = ... + β·g + ...) that follows a law linear in its coefficients,
β(u) = Σ_k β_k·ℓ_k(u) (``laws``), is the columns ℓ_k(u)·g, each with its own coefficient β_k: a law on a
solved coefficient stays in the linear solve. The θ-dependent column w (one per branch) is expanded the
same way. The fixed columns are factorised once, X = [G | W(θ)], G = Q·R_G; per trajectory only W is
orthogonalised against Q. Bounds: the coefficient's bound holds at each node of its law (for a linear
law, over the whole range); a row that breaks one is re-solved by bounded least squares on its p × p
triangular system (scipy ``lsq_linear``). The decisions of the plain solve (an inertia the data do not
excite, offsets, dropped branches, physical bounds) are taken from a ``LinearDesign`` of the same data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bwbench.problems.hysteresis.inertia_rule import pivoted_qr
from bwbench.problems.hysteresis.linear.columns import fixed_columns


@dataclass(eq=False)
class Expansion:
    """How one base coefficient (``name``) is split: its law's coefficient ``names`` and their basis
    values at each sample, (L, k)."""

    name: str
    names: list
    basis: np.ndarray


class ControlDesign:
    """See the module docstring. ``plain``: the ``LinearDesign`` of the same stacked data (its decisions);
    ``expansions``: {base coefficient name: ``Expansion``} for the coefficients with a law."""

    def __init__(self, plain, expansions: dict):
        self.plain = plain
        layout = plain.layout
        self.L = plain.L
        self.notes = list(plain.notes)
        sw = plain.sw if plain.sw is not None else np.ones(self.L)
        self.sw = sw
        names, cols = fixed_columns(plain.signal, layout, plain.masks, plain.offsets)
        if plain.mass is None:
            names, cols = [layout.mass] + names, [np.asarray(plain.signal.a, dtype=float)] + cols
        keep = set(plain.g_names)  # what the plain solve kept (dependent columns dropped there)
        base = [(n, c) for n, c in zip(names, cols) if n in keep]
        g_names, g_cols = self._expand(base, expansions)
        self.y = plain.y if plain.sw is not None else plain.y.copy()
        Q, R, perm, rank, scale = pivoted_qr([c * sw for c in g_cols])
        for j in perm[rank:]:
            self.notes.append(f"{g_names[j]} not separable from the other columns on these data: set to 0")
        kept = perm[:rank]
        self.g_names = [g_names[j] for j in kept]
        self.G = np.column_stack([g_cols[j] * sw for j in kept])
        self.Q = Q
        self.RG = R * scale[kept]
        self.Qty = Q.T @ self.y
        self.r0 = self.y - Q @ self.Qty
        # the w-columns: per present branch, its mask times the law's basis of the branch's coefficient
        self.w_base = [f"{layout.varying}{b}" for b, mask in plain.masks.items() if mask.any()]
        self.w_names, self.w_weights = [], []
        for b, mask in plain.masks.items():
            if not mask.any():
                continue
            name = f"{layout.varying}{b}"
            if name in expansions:
                e = expansions[name]
                for k, n in enumerate(e.names):
                    self.w_names.append(n)
                    self.w_weights.append(np.where(mask, e.basis[:, k], 0.0) * sw)
            else:
                self.w_names.append(name)
                self.w_weights.append(mask * sw)
        self.S = np.column_stack(self.w_weights)  # (L, nw): W = S·w
        self.free_names = tuple(self.g_names) + tuple(self.w_names)
        self.lower, self.upper = self._bounds(plain.bounds or {}, expansions)
        self.bounded = bool(np.any(np.isfinite(self.lower)) or np.any(np.isfinite(self.upper)))
        # the reported names: every coefficient of the expanded layout (fixed, held and dropped included)
        self.expansions = expansions
        self.held = {}  # a mass the data do not excite: fixed, not solved
        if layout.mass and plain.mass is not None:
            self.held[layout.mass] = float(plain.mass)
        self.tied = dict(plain.tied)

    @staticmethod
    def _expand(base, expansions):
        names, cols = [], []
        for n, c in base:
            if n in expansions:
                e = expansions[n]
                for k, name in enumerate(e.names):
                    names.append(name)
                    cols.append(c * e.basis[:, k])
            else:
                names.append(n)
                cols.append(c)
        return names, cols

    def _bounds(self, bounds: dict, expansions: dict):
        lower = np.full(len(self.free_names), -np.inf)
        upper = np.full(len(self.free_names), np.inf)
        owner = {n: base for base, e in expansions.items() for n in e.names}
        for j, name in enumerate(self.free_names):
            lo, hi = bounds.get(name, bounds.get(owner.get(name, ""), (-np.inf, np.inf)))
            lower[j], upper[j] = lo, hi
        return lower, upper

    # -- the solve ----------------------------------------------------------------------------------------
    def solve(self, Z):
        """(coefficients (m, p) in ``free_names`` order, RSS (m,) N² weighted) of each trajectory row of
        Z (m, L); NaN and +inf where the trajectory is not finite."""
        Z = np.atleast_2d(np.asarray(Z, dtype=float))
        m, p = len(Z), len(self.free_names)
        coef = np.full((m, p), np.nan)
        rss = np.full(m, np.inf)
        for i in range(m):
            found = self._solve_row(Z[i])
            if found is not None:
                coef[i], rss[i] = found
        return coef, rss

    def _factor(self, z):
        """(W, C = QᵀW, Q_w, R_w) of one trajectory; None where it is not finite."""
        if not np.all(np.isfinite(z)):
            return None
        W = self.S * z[:, None]
        C = self.Q.T @ W
        Wp = W - self.Q @ C
        Qw, Rw = np.linalg.qr(Wp)
        return W, C, Qw, Rw

    def _solve_row(self, z):
        found = self._factor(z)
        if found is None:
            return None
        W, C, Qw, Rw = found
        q = self.Q.shape[1]
        p = q + W.shape[1]
        R = np.zeros((p, p))
        R[:q, :q], R[:q, q:], R[q:, q:] = self.RG, C, Rw
        b = np.concatenate([self.Qty, Qw.T @ self.r0])
        base_rss = float(self.r0 @ self.r0 - b[q:] @ b[q:])
        try:  # numpy's solve: scipy's solve_triangular costs ~0.3 ms a call on these p × p systems
            beta = np.linalg.solve(R, b)
        except (np.linalg.LinAlgError, ValueError):
            beta = np.linalg.lstsq(R, b, rcond=None)[0]
        if not np.all(np.isfinite(beta)):
            beta = np.linalg.lstsq(R, b, rcond=None)[0]
        rss = base_rss + float(np.sum((R @ beta - b) ** 2))
        if self.bounded and (np.any(beta < self.lower) or np.any(beta > self.upper)):
            from scipy.optimize import lsq_linear

            found = lsq_linear(R, b, bounds=(self.lower, self.upper), method="bvls")
            beta = found.x
            rss = base_rss + float(np.sum((R @ beta - b) ** 2))
        if not (np.all(np.isfinite(beta)) and np.isfinite(rss)):
            return None
        return beta, max(rss, 0.0)

    def residual(self, z, beta) -> np.ndarray:
        """The weighted residual X·β − y (L,) of one trajectory and its coefficients."""
        q = self.Q.shape[1]
        return self.G @ beta[: len(self.g_names)] + (self.S * z[:, None]) @ beta[q:] - self.y

    def residual_jacobian(self, z, dZ):
        """(weighted residual (L,), its Jacobian (L, d)) of one trajectory z whose derivatives by the d
        searched coefficients are dZ (L, d), through the solve (variable projection, Golub & Pereyra:
        ∂r/∂c = P⊥·(∂X/∂c)·β̂ − X_F·(X_FᵀX_F)⁻¹·(∂X_F/∂c)ᵀ·r over the free columns X_F, those held on a
        bound constants of the active set); None where the solve has none."""
        found = self._solve_row(z)
        if found is None or not np.all(np.isfinite(dZ)):
            return None
        beta, _ = found
        r = self.residual(z, beta)
        q = len(self.g_names)
        X = np.column_stack([self.G, self.S * z[:, None]])
        free = ~((beta <= self.lower) | (beta >= self.upper)) if self.bounded else np.ones(len(beta), bool)
        XF = X[:, free]
        QF, RF = np.linalg.qr(XF)
        h = self.S @ beta[q:]  # ∂(W·β_w)/∂w at each sample
        A = h[:, None] * dZ
        A = A - QF @ (QF.T @ A)
        M = np.zeros((len(beta), dZ.shape[1]))
        M[q:] = (self.S * r[:, None]).T @ dZ  # (∂W_k/∂c)ᵀ·r
        try:
            B = np.linalg.solve(RF.T, M[free])
        except (np.linalg.LinAlgError, ValueError):
            return None
        J = A - QF @ B
        return r, J

    def full_jacobian(self, z, dZ, beta):
        """∂r/∂(searched, solved) (L, d + p) at fixed coefficients: (∂X/∂c)·β for the searched, X for the
        solved: the covariance of both at once (variable projection's)."""
        q = len(self.g_names)
        h = self.S @ beta[q:]
        X = np.column_stack([self.G, self.S * z[:, None]])
        return np.column_stack([h[:, None] * dZ, X])
