"""Can the data pin the parameters down? Local sensitivity (Jacobian SVD), profiles, posterior correlation.

The generic part works on any residual function r(u) → vector (``sensitivity``, ``profile``), so
it can be checked on toy models with known invariances; the problems apply it to their own
residuals (e.g. ``bwbench.problems.hysteresis.identifiability``: model force − measured force, N,
with u the unit-scaled parameters, u = 0 and 1 the Table 5 bounds).

Reading the results:

- singular values σ_k of the Jacobian J = ∂r/∂u (N per unit range): a step of length δ along the
  right-singular vector v_k changes the residual by about σ_k·δ (N, as a vector norm), so a small
  σ_k is a combination of parameters the force hardly sees;
- *undetermined* directions: those along which even a step across the whole box changes Σr²
  by less than the 95 % threshold 1.96²·s² (s² = Σr²/(L − d), the noise variance estimate), and
  the numerically zero ones. Moving along them inside the box gives each parameter a *free
  range* (two small linear programs per parameter);
- linearised standard errors: cov(u) ≈ s²·(JᵀJ)⁻¹ restricted to the determined directions;
- a parameter is *poorly determined* when its free range or its standard error exceeds
  ``POOR_SE`` (10 %) of its Table 5 range. All of this is linear: it describes the neighbourhood
  of the point analysed, not other minima;
- a profile fixes one parameter on a grid and re-optimises the others. The re-optimised loss is an
  upper bound of the true profile: a profile below the threshold shows the others compensate (the
  data do not pin the parameter down there); one above it shows a bound only where its points
  converged (``profile`` records it), and only for the minimum found.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import minimize

STEP = 1e-4  # finite-difference step, unit coordinates (1e-4 of the Table 5 range)
POOR_SE = 0.10  # free range or standard error above 10 % of the Table 5 range: poorly determined
ZERO_RATIO = 1e-6  # σ_k/σ_max below this: numerically an exact invariance


def jacobian(residual, u, step: float = STEP, bounds=(0.0, 1.0)) -> np.ndarray:
    """Central-difference Jacobian (len(r), len(u)) of ``residual`` at ``u``.

    The two points of each difference are clipped to ``bounds`` (a one-sided difference at a
    bound); ``bounds=None`` does not clip.
    """
    u = np.asarray(u, dtype=float)
    columns = []
    for i in range(u.size):
        hi, lo = u.copy(), u.copy()
        hi[i] += step
        lo[i] -= step
        if bounds is not None:
            hi[i] = min(hi[i], bounds[1])
            lo[i] = max(lo[i], bounds[0])
        # a blow-up on both sides gives inf − inf = NaN: the callers test the Jacobian for finiteness
        with np.errstate(invalid="ignore"):
            columns.append((np.asarray(residual(hi), float) - np.asarray(residual(lo), float)) / (hi[i] - lo[i]))
    return np.column_stack(columns)


def describe_direction(v, labels, min_weight: float = 0.1, max_terms: int = 5) -> str:
    """A unit direction as a readable combination, largest weights first: '0.71·ωn₋ − 0.70·α₋'."""
    v = np.asarray(v, dtype=float)
    order = [i for i in np.argsort(-np.abs(v), kind="stable") if abs(v[i]) >= min_weight][:max_terms]
    if not order:
        order = [int(np.argmax(np.abs(v)))]
    text = ""
    for k, i in enumerate(order):
        sign = "−" if v[i] < 0 else "+"
        term = f"{abs(v[i]):.2f}·{labels[i]}"
        text += (f"−{term}" if sign == "−" else term) if k == 0 else f" {sign} {term}"
    return text


@dataclass(frozen=True, eq=False)
class Sensitivity:
    """Local identifiability at one point. Vectors are ordered like ``names``; singular values
    and ``directions`` (rows: right-singular vectors) largest first."""

    names: tuple
    labels: tuple
    u: np.ndarray
    residual_norm2: float  # Σ r² at u
    n_data: int
    singular_values: np.ndarray
    directions: np.ndarray

    @property
    def ratios(self) -> np.ndarray:
        return self.singular_values / self.singular_values[0]

    @property
    def condition_number(self) -> float:
        smallest = self.singular_values[-1]
        return float(self.singular_values[0] / smallest) if smallest > 0 else math.inf

    @property
    def noise_variance(self) -> float:
        """s² = Σr²/(L − d), the residual variance (the fit's noise estimate)."""
        return self.residual_norm2 / max(self.n_data - len(self.names), 1)

    def undetermined(self) -> np.ndarray:
        """Mask of the directions the data do not determine inside the box: a step along v_k
        across the whole unit range changes Σr² by less than 1.96²·s² (the 95 % threshold of
        one parameter), i.e. σ_k ≤ 1.96·s; numerically zero ones (``ZERO_RATIO``) always count."""
        s = self.singular_values
        return s <= max(1.96 * math.sqrt(self.noise_variance), ZERO_RATIO * s[0])

    def standard_errors(self) -> np.ndarray:
        """Linearised standard error of each u (fraction of its range) within the determined
        directions (truncated SVD); the undetermined ones are measured by ``free_ranges``."""
        keep = ~self.undetermined()
        weights = self.directions[keep].T ** 2 / self.singular_values[keep] ** 2
        return np.sqrt(self.noise_variance * weights.sum(axis=1))

    def free_ranges(self, bounds=(0.0, 1.0)) -> np.ndarray:
        """(d, 2): lowest and highest value each u can take when moving from ``u`` along the
        undetermined directions only while staying inside the box (linearised: along them the
        force changes by less than the noise). Solved as two small linear programs per parameter."""
        from scipy.optimize import linprog

        null = self.directions[self.undetermined()].T  # (d, m)
        out = np.column_stack([self.u, self.u])
        if null.shape[1] == 0:
            return out
        lo, hi = bounds
        A = np.vstack([null, -null])
        b = np.concatenate([hi - self.u, self.u - lo])
        for i in range(self.u.size):
            for j, sign in ((0, 1.0), (1, -1.0)):
                res = linprog(
                    sign * null[i],
                    A_ub=A,
                    b_ub=np.maximum(b, 0.0),
                    bounds=[(None, None)] * null.shape[1],
                    method="highs",
                )
                if res.status == 0:
                    out[i, j] = self.u[i] + null[i] @ res.x
        return out

    def weakest(self, k: int = 3) -> list[dict]:
        """The ``k`` weakest directions, weakest first, sign fixed so the largest weight is positive."""
        out = []
        for j in range(len(self.singular_values) - 1, max(len(self.singular_values) - 1 - k, -1), -1):
            v = self.directions[j]
            v = v if v[np.argmax(np.abs(v))] > 0 else -v
            out.append(
                {
                    "sigma": float(self.singular_values[j]),
                    "ratio": float(self.ratios[j]),
                    "weights": {n: float(w) for n, w in zip(self.names, v)},
                    "text": describe_direction(v, self.labels),
                }
            )
        return out

    def poorly_determined(self, threshold: float = POOR_SE) -> list[str]:
        """Parameters left free over more than ``threshold`` of their range, by the undetermined
        directions (``free_ranges``) or by the noise (standard error)."""
        width = np.diff(self.free_ranges(), axis=1)[:, 0]
        se = self.standard_errors()
        return [n for n, w, e in zip(self.names, width, se) if w > threshold or e > threshold]


def sensitivity(residual, u, names, labels=None, step: float = STEP, bounds=(0.0, 1.0)) -> Sensitivity:
    """Jacobian of ``residual`` at ``u`` by central differences, and its SVD."""
    u = np.asarray(u, dtype=float)
    r0 = np.asarray(residual(u), dtype=float)
    J = jacobian(residual, u, step, bounds)
    if not np.all(np.isfinite(J)) or not np.all(np.isfinite(r0)):
        raise ValueError("the residual is not finite at or next to this point")
    _, s, vt = np.linalg.svd(J, full_matrices=False)
    names = tuple(names)
    return Sensitivity(names, tuple(labels or names), u, float(r0 @ r0), r0.size, s, vt)


def follow_invariance(
    residual, u, direction, scale: float, length: float = 0.1, steps: int = 5, step: float = STEP, bounds=(0.0, 1.0)
) -> dict:
    """Follow the near-null ``direction`` from ``u`` over a finite path and say whether it is an
    invariance of the model to round-off, not just a flat spot at one point.

    Predictor–corrector path following: a step of ``length/steps`` along the current direction, then
    Gauss–Newton corrections orthogonal to it back onto the level set r(u) = r(u₀), and the direction
    re-linearised (the near-null direction closest to the previous one), so a curved invariance such
    as a scaling symmetry is followed. It is *exact* when, at every point of the path, the relative
    singular value along it stays below ``ZERO_RATIO`` and, at the end, the residual differs from the
    start by less than ``ZERO_RATIO`` of ``scale`` (the size of the data, e.g. ‖measured force‖): the
    corrections cannot undo a change along the direction itself, so a flat spot (zero slope at one
    point only) fails. Returns ``exact``, ``max_ratio`` (largest relative singular value met),
    ``change`` (‖Δr‖/scale between the ends), ``length`` (unit length followed; shorter when a bound
    stops it).
    """
    u = np.array(u, dtype=float)
    v = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    v = v if v[np.argmax(np.abs(v))] > 0 else -v
    r0 = np.asarray(residual(u), dtype=float)
    travelled, max_ratio = 0.0, 0.0

    def finite_jacobian(at):
        J = jacobian(residual, at, step, bounds)
        return J if np.all(np.isfinite(J)) else None

    for _ in range(steps):
        target = u + (length / steps) * v
        if bounds is not None and (np.any(target < bounds[0]) or np.any(target > bounds[1])):
            break
        u, travelled = target, travelled + length / steps
        orthogonal = np.eye(u.size) - np.outer(v, v)
        for _ in range(2):  # corrector: back to the level set, without moving along v
            J = finite_jacobian(u)
            if J is None:
                return {"exact": False, "max_ratio": math.inf, "change": math.inf, "length": travelled}
            shift = np.linalg.lstsq(J @ orthogonal, np.asarray(residual(u), dtype=float) - r0, rcond=1e-9)[0]
            u = u - orthogonal @ shift
            if bounds is not None:
                u = np.clip(u, *bounds)
        J = finite_jacobian(u)
        if J is None:
            return {"exact": False, "max_ratio": math.inf, "change": math.inf, "length": travelled}
        _, s, vt = np.linalg.svd(J, full_matrices=False)
        near = vt[s <= 1e-3 * s[0]]
        near = near if len(near) else vt[-1:]
        projected = near.T @ (near @ v)  # the null-space direction closest to where we were going
        if np.linalg.norm(projected) < 0.9:  # the direction has left the null space: a flat spot
            max_ratio = max(max_ratio, float(np.linalg.norm(J @ v) / s[0]))
            break
        v = projected / np.linalg.norm(projected)
        max_ratio = max(max_ratio, float(np.linalg.norm(J @ v) / s[0]))
    change = float(np.linalg.norm(np.asarray(residual(u), dtype=float) - r0) / (scale or 1.0))
    exact = travelled > 0 and max_ratio < ZERO_RATIO and change < ZERO_RATIO
    return {"exact": bool(exact), "max_ratio": max_ratio, "change": change, "length": travelled}


PROFILE_MAXITER = 300  # L-BFGS-B iterations per start of a profile point: enough to converge here


def profile(
    loss_batch, u_best, index: int, grid, maxiter: int = PROFILE_MAXITER, step: float = STEP, on_point=None
) -> pd.DataFrame:
    """Profile of the loss along coordinate ``index``: at each grid value (unit coordinates) the
    other coordinates are re-optimised by scipy's L-BFGS-B on [0, 1], and the lowest loss found
    is kept.

    Each point is searched warm-started from the neighbouring grid point (walking outwards from
    ``u_best``); when that search does not converge, or ends where the model blows up, once more
    from ``u_best``. L-BFGS-B minimises log(loss), whose scale is uniform over the decades a
    profile spans, with the gradient by central differences of step ``step`` computed in one
    ``loss_batch`` call. ``loss_batch(U)`` takes (m, d) unit points and returns m losses (inf where
    the model blows up). A point is ``converged`` when the search that found its loss stopped on
    L-BFGS-B's own convergence tests (projected gradient ≤ pgtol or relative reduction of the log
    loss ≤ factr·eps) within ``maxiter`` iterations at a finite loss.

    What a profile can show: the re-optimised loss is an upper bound of the true profile (the
    search may stop early or in a local minimum), so a profile below a threshold shows the data do
    not pin the parameter down there; a profile above it shows a bound only where its points
    converged, and then only for the minimum the search found.

    Returns columns ``unit``, ``loss``, ``converged``, ``iterations`` and ``evaluations`` (loss
    evaluations spent on the point), sorted by ``unit``. ``on_point()`` is called after each grid
    point (a progress bar: a point costs about a second).
    """
    u_best = np.asarray(u_best, dtype=float)
    free = np.array([i for i in range(u_best.size) if i != index])
    eye = step * np.eye(free.size)
    grid = np.sort(np.unique(np.asarray(grid, dtype=float)))

    def search(value, start):
        count = 0
        best = (math.inf, np.asarray(start, dtype=float))

        def fun(x):
            nonlocal count, best
            hi, lo = np.clip(x + eye, 0.0, 1.0), np.clip(x - eye, 0.0, 1.0)
            points = np.tile(u_best, (1 + 2 * free.size, 1))
            points[:, index] = value
            points[:, free] = np.vstack([x, hi, lo])
            losses = np.asarray(loss_batch(points), dtype=float)
            count += len(points)
            if not np.isfinite(losses[0]):
                return 700.0, np.zeros(free.size)  # log of ~1e304: worse than any finite loss
            if losses[0] < best[0]:
                best = (float(losses[0]), x.copy())
            logs = np.log(np.maximum(losses, 1e-300))  # an exact fit (loss 0) must not give −inf
            grad = (logs[1 : 1 + free.size] - logs[1 + free.size :]) / np.diag(hi - lo)
            return float(logs[0]), np.where(np.isfinite(grad), grad, 0.0)

        res = minimize(
            fun, start, jac=True, method="L-BFGS-B", bounds=[(0.0, 1.0)] * free.size, options={"maxiter": maxiter}
        )
        converged = bool(res.success and res.nit < maxiter and np.isfinite(best[0]) and res.fun < 700.0)
        return best[0], best[1], converged, int(res.nit), count

    rows = []
    centre = u_best[index]
    for side in (grid[grid >= centre], grid[grid < centre][::-1]):
        warm = u_best[free]
        for value in side:
            results = [search(value, warm)]
            if not results[0][2]:
                results.append(search(value, u_best[free]))
            loss, x, converged, iterations, _ = min(results, key=lambda r: r[0])
            warm = x
            rows.append(
                {
                    "unit": float(value),
                    "loss": loss,
                    "converged": converged,
                    "iterations": iterations,
                    "evaluations": sum(r[4] for r in results),
                }
            )
            if on_point is not None:
                on_point()
    return pd.DataFrame(rows).sort_values("unit").reset_index(drop=True)


def posterior_correlation(samples, names) -> pd.DataFrame:
    """Pearson correlation matrix of samples (n, d) as a DataFrame indexed by ``names``."""
    return pd.DataFrame(np.corrcoef(np.asarray(samples, dtype=float), rowvar=False), index=names, columns=names)


def strongest_pairs(corr: pd.DataFrame, k: int = 4) -> list[tuple[str, str, float]]:
    """The ``k`` most correlated pairs (by |r|), as (name, name, r)."""
    names = list(corr.index)
    values = corr.to_numpy()
    pairs = [
        (names[i], names[j], float(values[i, j]))
        for i in range(len(names))
        for j in range(i + 1, len(names))
        if np.isfinite(values[i, j])
    ]
    return sorted(pairs, key=lambda p: -abs(p[2]))[:k]
