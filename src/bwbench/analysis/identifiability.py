"""Can the data pin the parameters down? Local sensitivity (Jacobian SVD), profiles, posterior correlation.

The generic part works on any residual function r(u) → vector (``sensitivity``, ``profile``), so
it can be checked on toy models with known invariances; ``analyse`` applies it to the switched
Bouc-Wen model on one specimen, with the residual = model force − measured force (N) and u the
unit-scaled parameters (u = 0 and 1 are the Table 5 bounds).

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
- a profile fixes one parameter on a grid and re-optimises the others: a flat profile means the
  others compensate (the parameter is not identifiable), a sharp minimum that it is.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.optimize import minimize

from bwbench.errors import UserError

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
                res = linprog(sign * null[i], A_ub=A, b_ub=np.maximum(b, 0.0), bounds=[(None, None)] * null.shape[1],
                              method="highs")
                if res.status == 0:
                    out[i, j] = self.u[i] + null[i] @ res.x
        return out

    def weakest(self, k: int = 3) -> list[dict]:
        """The ``k`` weakest directions, weakest first, sign fixed so the largest weight is positive."""
        out = []
        for j in range(len(self.singular_values) - 1, max(len(self.singular_values) - 1 - k, -1), -1):
            v = self.directions[j]
            v = v if v[np.argmax(np.abs(v))] > 0 else -v
            out.append({"sigma": float(self.singular_values[j]), "ratio": float(self.ratios[j]),
                        "weights": {n: float(w) for n, w in zip(self.names, v)},
                        "text": describe_direction(v, self.labels)})
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


def profile(loss_batch, u_best, index: int, grid, maxiter: int = 15, step: float = STEP) -> pd.DataFrame:
    """Profile of the loss along coordinate ``index``: at each grid value (unit coordinates) the
    other coordinates are re-optimised by scipy's L-BFGS-B on [0, 1], and the lowest loss found
    is kept.

    Each point is searched twice, ``maxiter`` iterations each: warm-started from the neighbouring
    grid point (walking outwards from ``u_best``) and from ``u_best`` itself. L-BFGS-B minimises
    log(loss), whose scale is uniform over the decades a profile spans, with the gradient by
    central differences of step ``step`` computed in one ``loss_batch`` call. ``loss_batch(U)``
    takes (m, d) unit points and returns m losses (inf where the model blows up). Returns columns
    ``unit``, ``loss`` and ``evaluations`` (loss evaluations spent on the point), sorted by ``unit``.
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
            grad = (logs[1:1 + free.size] - logs[1 + free.size:]) / np.diag(hi - lo)
            return float(logs[0]), np.where(np.isfinite(grad), grad, 0.0)

        minimize(fun, start, jac=True, method="L-BFGS-B", bounds=[(0.0, 1.0)] * free.size,
                 options={"maxiter": maxiter})
        return best[0], best[1], count

    rows = []
    centre = u_best[index]
    for side in (grid[grid >= centre], grid[grid < centre][::-1]):
        warm = u_best[free]
        for value in side:
            results = [search(value, warm), search(value, u_best[free])]
            loss, x, _ = min(results, key=lambda r: r[0])
            warm = x
            rows.append({"unit": float(value), "loss": loss, "evaluations": sum(r[2] for r in results)})
    return pd.DataFrame(rows).sort_values("unit").reset_index(drop=True)


def posterior_correlation(samples, names) -> pd.DataFrame:
    """Pearson correlation matrix of samples (n, d) as a DataFrame indexed by ``names``."""
    return pd.DataFrame(np.corrcoef(np.asarray(samples, dtype=float), rowvar=False), index=names, columns=names)


def strongest_pairs(corr: pd.DataFrame, k: int = 4) -> list[tuple[str, str, float]]:
    """The ``k`` most correlated pairs (by |r|), as (name, name, r)."""
    names = list(corr.index)
    values = corr.to_numpy()
    pairs = [(names[i], names[j], float(values[i, j])) for i in range(len(names)) for j in range(i + 1, len(names))
             if np.isfinite(values[i, j])]
    return sorted(pairs, key=lambda p: -abs(p[2]))[:k]


# ------------------------------------------------------------------------------ the Bouc-Wen case

def _finite(x):
    return float(x) if math.isfinite(x) else None  # JSON has no infinity: null = not determined at all


def analyse(specimen_path, params, state: str = "shared", excitation: str = "measured", *,
            profile_names=(), profile_widest: int = 0, grid: int = 9, maxiter: int = 15, step: float = STEP,
            weakest: int = 3) -> dict:
    """Identifiability of the 14 parameters ``params`` (physical units) on one specimen.

    Returns a JSON-ready dict: fit quality, singular values (absolute, N per unit range, and
    relative), condition number, the ``weakest`` directions with parameter names, the number of
    undetermined directions, per parameter the free range (physical units and fraction of the
    Table 5 range) and standard error, the poorly determined parameters, and a profile (unit grid
    of ``grid`` points over the range, MSE in N²) for each name in ``profile_names`` and for the
    ``profile_widest`` parameters with the widest free ranges.
    Raises ``UserError`` for parameters outside Table 5 or a model that blows up there.
    """
    from bwbench.models.switched_bouc_wen import PARAM_NAMES
    from bwbench.data.parameters import LABELS
    from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem
    from bwbench.data.specimen import read_specimen

    problem = SwitchedBoucWenProblem(read_specimen(specimen_path), state, excitation)
    params = np.asarray(params, dtype=float)
    u = problem.to_unit(params)
    outside = [n for n, x in zip(PARAM_NAMES, u) if not -1e-9 <= x <= 1 + 1e-9]
    if outside:
        raise UserError(f"parameter(s) outside the Table 5 search range: {', '.join(outside)}")
    u = np.clip(u, 0.0, 1.0)
    unknown = [n for n in profile_names if n not in PARAM_NAMES]
    if unknown:
        raise UserError(f"unknown parameter {unknown[0]!r} to profile; names: {' '.join(PARAM_NAMES)}")
    measured = problem.specimen.f

    def residual(v):
        return problem.simulate(problem.from_unit(v)) - measured

    try:
        sens = sensitivity(residual, u, PARAM_NAMES, [LABELS[n] for n in PARAM_NAMES], step)
    except ValueError:
        raise UserError("the model blows up at (or next to) these parameters: nothing to analyse") from None
    se = sens.standard_errors()
    free = sens.free_ranges()
    span = problem.upper - problem.lower
    mse = sens.residual_norm2 / sens.n_data
    out = {
        "specimen": problem.specimen.name, "state": state, "excitation": excitation, "n_data": sens.n_data,
        "mse": mse, "rmse_N": math.sqrt(mse), "params": dict(zip(PARAM_NAMES, map(float, params))),
        "step_unit": step, "names": list(PARAM_NAMES),
        "singular_values": [float(s) for s in sens.singular_values],
        "relative_singular_values": [float(r) for r in sens.ratios],
        "condition_number": _finite(sens.condition_number),
        "numerically_zero": int(np.sum(sens.ratios < ZERO_RATIO)),
        "noise_rmse_N": math.sqrt(sens.noise_variance),
        "undetermined_directions": int(sens.undetermined().sum()),
        "weakest": sens.weakest(weakest),
        "free_range_unit": {n: float(hi - lo) for n, (lo, hi) in zip(PARAM_NAMES, free)},
        "free_range": {n: [float(problem.lower[i] + lo * span[i]), float(problem.lower[i] + hi * span[i])]
                       for i, (n, (lo, hi)) in enumerate(zip(PARAM_NAMES, free))},
        "standard_error_unit": {n: float(x) for n, x in zip(PARAM_NAMES, se)},
        "standard_error": {n: float(x * w) for n, x, w in zip(PARAM_NAMES, se, span)},
        "poor_threshold_unit": POOR_SE,
        "poorly_determined": sens.poorly_determined(),
        "profiles": {},
    }
    widest = sorted(PARAM_NAMES, key=lambda n: -out["free_range_unit"][n])[:profile_widest]
    for name in dict.fromkeys([*profile_names, *widest]):
        i = PARAM_NAMES.index(name)
        frame = profile(lambda U: problem.loss_batch(problem.from_unit(U)), u, i,
                        np.append(np.linspace(0.0, 1.0, grid), u[i]), maxiter=maxiter, step=step)
        frame["value"] = problem.lower[i] + frame["unit"] * (problem.upper[i] - problem.lower[i])
        out["profiles"][name] = [{"value": float(r.value), "unit": float(r.unit), "mse": _finite(r.loss),
                                  "evaluations": int(r.evaluations)} for r in frame.itertuples()]
    return out


def format_text(result: dict) -> str:
    """The plain-text report of ``analyse`` (what ``bwbench identifiability`` prints)."""
    from bwbench.data.parameters import LABELS

    names = result["names"]
    lines = [
        f"identifiability of {result['specimen']} ({result['state']} state, {result['excitation']} excitation): "
        f"MSE {result['mse']:.4g} N² (RMSE {result['rmse_N']:.3g} N) on {result['n_data']} samples",
        f"Jacobian of the force residual (N) with respect to the unit-scaled parameters "
        f"(u = 0..1 spans Table 5; central differences, step {result['step_unit']:g})",
        "",
        "singular values (N per unit range), largest first, and relative to the largest:",
    ]
    for k, (s, r) in enumerate(zip(result["singular_values"], result["relative_singular_values"]), 1):
        lines.append(f"  {k:2d}  {s:11.4g}  {r:9.2e}")
    cond = result["condition_number"]
    lines.append(f"condition number: {cond:.3g}" if cond is not None else "condition number: infinite")
    if result["numerically_zero"]:
        lines.append(f"{result['numerically_zero']} singular value(s) below {ZERO_RATIO:g} of the largest: "
                     "combinations the force does not see at all")
    lines += ["", "weakest directions (a unit step along them changes the force least):"]
    for w in result["weakest"]:
        lines.append(f"  σ/σmax = {w['ratio']:.2e}:  {w['text']}")
    lines += ["", f"{result['undetermined_directions']} direction(s) undetermined: a step across the whole "
                  f"range changes the force by less than the noise ({result['noise_rmse_N']:.3g} N RMSE)",
              "per parameter, as a fraction of its Table 5 range: free range along those directions "
              "(linearised, inside the box) and standard error:"]
    for n in names:
        flag = "  poorly determined" if n in result["poorly_determined"] else ""
        lo, hi = result["free_range"][n]
        lines.append(f"  {LABELS[n]:<4} free {result['free_range_unit'][n]:6.1%} [{lo:9.4g} – {hi:9.4g}]"
                     f"   s.e. {_se_text(result['standard_error_unit'][n]):>8}{flag}")
    poor = result["poorly_determined"]
    threshold = f"{result['poor_threshold_unit']:.0%}"
    if poor:
        lines.append(f"poorly determined (free range or standard error > {threshold} of the range): "
                     + ", ".join(LABELS[n] for n in poor))
    else:
        lines.append(f"every parameter is determined to better than {threshold} of its range")
    for name, points in result["profiles"].items():
        lines += ["", f"profile of {LABELS[name]} (others re-optimised, L-BFGS-B): value -> MSE (N²)"]
        lines += [f"  {p['value']:12.5g}  {p['mse'] if p['mse'] is not None else math.inf:12.5g}" for p in points]
    return "\n".join(lines)


def _se_text(x: float) -> str:
    return "> 100 %" if x > 1 else f"{x:.1%}"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("specimen", help="specimen CSV")
    parser.add_argument("--params", required=True, help="parameters JSON (the 14 names, or a fit result)")
    parser.add_argument("--state", choices=["shared", "split"], default="shared",
                        help="hysteretic state convention (default: shared)")
    parser.add_argument("--excitation", choices=["measured", "sine"], default="measured",
                        help="measured (default) or sine")
    parser.add_argument("--profile", action="append", default=[], metavar="NAME",
                        help="also profile this parameter (repeatable; e.g. wn-)")
    parser.add_argument("--grid", type=int, default=9, help="profile grid points over the range (default 9)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")


def cli_main(args) -> int:
    """``bwbench identifiability S.csv --params P.json [--json]``; raises ``UserError`` for bad input."""
    from bwbench.data.parameters import read_json

    if args.grid < 2:
        raise UserError(f"--grid must be at least 2, got {args.grid}")
    params = read_json(args.params)
    result = analyse(args.specimen, params, args.state, args.excitation, profile_names=args.profile, grid=args.grid)
    if args.json:
        json.dump(result, sys.stdout, indent=2, allow_nan=False)
        sys.stdout.write("\n")
    else:
        print(format_text(result))
    return 0
