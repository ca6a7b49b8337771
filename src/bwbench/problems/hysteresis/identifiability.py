"""``bwbench identifiability``: which parameters of the switched model one specimen cannot pin down.

The generic tools (Jacobian, SVD, free ranges, profiles) are ``bwbench.analysis.identifiability``;
this module applies them to the 14 paper parameters at a fit and writes the result as text or JSON.
"""

from __future__ import annotations

import math

import numpy as np

from bwbench.analysis.identifiability import (
    POOR_SE,
    PROFILE_MAXITER,
    STEP,
    ZERO_RATIO,
    describe_direction,
    follow_invariance,
    profile,
    sensitivity,
)
from bwbench.errors import UserError


def _finite(x):
    return float(x) if math.isfinite(x) else None  # JSON has no infinity: null = not determined at all


def analyse(
    specimen_path,
    params,
    state: str = "shared",
    excitation: str = "measured",
    *,
    formulation: str = "paper",
    bounds: dict | None = None,
    profile_names=(),
    profile_widest: int = 0,
    grid: int = 9,
    maxiter: int = PROFILE_MAXITER,
    step: float = STEP,
    weakest: int = 3,
    model: str | None = None,
    progress=None,
) -> dict:
    """Identifiability of the parameters ``params`` (physical units, the formulation's coordinates)
    on one specimen.

    Returns a JSON-ready dict: fit quality, singular values (absolute, N per unit range, and
    relative), condition number, the ``weakest`` directions with parameter names, the exact
    symmetries of the model (``symmetries``: named, checked along a finite orbit) and the other
    numerically zero directions classified by following them over a finite path
    (``null_directions``: invariant to round-off, or only weakly determined), the number of
    undetermined directions, per parameter the free range (physical units and fraction of the
    search range) and standard error, the poorly determined parameters, and a profile (unit grid of
    ``grid`` points over the range, MSE in N²) for each name in ``profile_names`` and for the
    ``profile_widest`` parameters with the widest free ranges. ``progress(done, total)`` is called
    after each profile point.
    Raises ``UserError`` for parameters outside the search box or a model that blows up there.
    """
    from bwbench.data.specimen import read_specimen
    from bwbench.problems.hysteresis.formulations import make_problem

    settings = {"state": state, "excitation": excitation, "formulation": formulation, "bounds": bounds or {}}
    if model is not None:
        settings["model"] = model
    problem = make_problem(read_specimen(specimen_path), settings)
    names = list(problem.param_names)
    known = {p.name: p.label or p.name for p in problem.parameter_list}
    labels = [known.get(n) or label(n) for n in names]
    params = np.asarray(params, dtype=float)
    u = problem.to_unit(params)
    outside = [n for n, x in zip(names, u) if not -1e-9 <= x <= 1 + 1e-9]
    if outside:
        raise UserError(f"parameter(s) outside the search box: {', '.join(outside)} (widen it with --bounds)")
    u = np.clip(u, 0.0, 1.0)
    unknown = [n for n in profile_names if n not in names]
    if unknown:
        raise UserError(f"unknown parameter {unknown[0]!r} to profile; names: {' '.join(names)}")

    def residual(v):
        return problem.residual_batch(problem.from_unit(v)[None, :])[0]

    try:
        sens = sensitivity(residual, u, names, labels, step)
    except ValueError:
        raise UserError("the model blows up at (or next to) these parameters: nothing to analyse") from None
    se = sens.standard_errors()
    free = sens.free_ranges()
    span = problem.upper - problem.lower
    mse = sens.residual_norm2 / sens.n_data
    params = problem.from_unit(u)
    out = {
        "specimen": problem.specimen.name,
        "model": problem.model.name,
        "state": problem.state,
        "excitation": excitation,
        "formulation": problem.formulation,
        "n_data": sens.n_data,
        "mse": mse,
        "rmse_N": math.sqrt(mse),
        "params": dict(zip(names, map(float, params))),
        "step_unit": step,
        "names": names,
        "labels": dict(zip(names, labels)),
        "units": {p.name: p.unit for p in problem.parameter_list},
        "singular_values": [float(s) for s in sens.singular_values],
        "relative_singular_values": [float(r) for r in sens.ratios],
        "condition_number": _finite(sens.condition_number),
        "numerically_zero": int(np.sum(sens.ratios < ZERO_RATIO)),
        "noise_rmse_N": math.sqrt(sens.noise_variance),
        "undetermined_directions": int(sens.undetermined().sum()),
        "weakest": sens.weakest(weakest),
        **classify_null_space(problem, params, sens, residual, step),
        "free_range_unit": {n: float(hi - lo) for n, (lo, hi) in zip(names, free)},
        "free_range": {
            n: [float(problem.from_unit(_at(u, i, lo))[i]), float(problem.from_unit(_at(u, i, hi))[i])]
            for i, (n, (lo, hi)) in enumerate(zip(names, free))
        },
        "standard_error_unit": {n: float(x) for n, x in zip(names, se)},
        "standard_error": {n: float(x * w) for n, x, w in zip(names, se, span)},
        "poor_threshold_unit": POOR_SE,
        "poorly_determined": sens.poorly_determined(),
        "profiles": {},
    }
    widest = sorted(names, key=lambda n: -out["free_range_unit"][n])[:profile_widest]
    profiled = list(dict.fromkeys([*profile_names, *widest]))
    grids = {n: np.unique(np.append(np.linspace(0.0, 1.0, grid), u[names.index(n)])) for n in profiled}
    total, done = sum(len(g) for g in grids.values()), 0

    def point():  # progress(done, total) after each profile point, for a progress bar
        nonlocal done
        done += 1
        progress(done, total)

    for name in profiled:
        i = names.index(name)
        frame = profile(
            lambda U: problem.loss_batch(problem.from_unit(U)),
            u,
            i,
            grids[name],
            maxiter=maxiter,
            step=step,
            on_point=point if progress is not None else None,
        )
        frame["value"] = [problem.from_unit(_at(u, i, x))[i] for x in frame["unit"]]
        out["profiles"][name] = [
            {
                "value": float(r.value),
                "unit": float(r.unit),
                "mse": _finite(r.loss),
                "converged": bool(r.converged),
                "iterations": int(r.iterations),
                "evaluations": int(r.evaluations),
            }
            for r in frame.itertuples()
        ]
    out["profile_maxiter"] = maxiter
    return out


def _at(u, i, value):
    v = np.array(u, dtype=float)
    v[i] = value
    return v


def label(name: str) -> str:
    from bwbench.models.switched.identifiable import LABELS as IDENTIFIABLE
    from bwbench.models.switched.parameters import LABELS

    return LABELS.get(name) or IDENTIFIABLE.get(name, name)


def classify_null_space(problem, params, sens, residual, step) -> dict:
    """The numerically zero directions at ``params``: first the model's exact symmetries in its direct
    formulation (``Model.symmetries``; the switched model's z → s·z, one scale for the shared state,
    one per branch for the split), each checked along a finite orbit s ∈ [0.8, 1.25] and measured
    against the numerical null space; then what is left of the null space, followed over a finite
    path (``follow_invariance``): invariant to round-off there, or only a flat spot (weakly determined)."""
    zero = sens.ratios < ZERO_RATIO
    null = sens.directions[zero]  # orthonormal rows
    scale = float(np.linalg.norm(problem.specimen.f))
    symmetries, tangents = [], []
    model = getattr(problem, "model", None)
    if model is not None and getattr(problem, "formulation", "") == model.direct_name:
        orbits = model.symmetries(params, problem.state)
        f0 = problem.simulate(params)
        for name, orbit in orbits:
            eps = 1e-6
            tangent = (problem.to_unit(orbit(1 + eps)) - problem.to_unit(orbit(1 - eps))) / (2 * eps)
            tangent /= np.linalg.norm(tangent)
            change = max(float(np.max(np.abs(problem.simulate(orbit(s)) - f0))) for s in (0.8, 0.9, 1.1, 1.25))
            symmetries.append(
                {
                    "name": name,
                    "max_force_change_N": change,
                    "in_null_space": float(np.linalg.norm(null @ tangent)) if len(null) else 0.0,
                    "direction": describe_direction(tangent, sens.labels),
                }
            )
            tangents.append(tangent)
    others = []
    if len(null) > len(tangents):
        rest = null
        if tangents:  # what of the null space the symmetries do not explain
            basis = np.linalg.qr(np.array(tangents).T)[0]
            rest = null - (null @ basis) @ basis.T
            _, s, vt = np.linalg.svd(rest, full_matrices=False)
            rest = vt[s > 1e-3]
        for v in rest[:4]:
            path = follow_invariance(residual, sens.u, v, scale, step=step)
            others.append({"direction": describe_direction(v, sens.labels), **path})
    return {"symmetries": symmetries, "null_directions": others}


def format_text(result: dict) -> str:
    """The plain-text report of ``analyse`` (what ``bwbench identifiability`` prints)."""
    names = result["names"]
    paper = result["formulation"] == "paper" and result.get("model", "switched-bouc-wen") == "switched-bouc-wen"
    box = "Table 5" if paper else "the search box"
    state = f", {result['state']} state" if result.get("state") else ""
    lines = [
        f"identifiability of {result['specimen']} ({result.get('model', 'switched-bouc-wen')}, "
        f"{result['formulation']} formulation{state}, "
        f"{result['excitation']} excitation): MSE {result['mse']:.4g} N² (RMSE {result['rmse_N']:.3g} N) on "
        f"{result['n_data']} samples",
        f"Jacobian of the force residual (N) with respect to the unit-scaled parameters "
        f"(u = 0..1 spans {box}; central differences, step {result['step_unit']:g})",
        "",
        "singular values (N per unit range), largest first, and relative to the largest:",
    ]
    for k, (s, r) in enumerate(zip(result["singular_values"], result["relative_singular_values"]), 1):
        lines.append(f"  {k:2d}  {s:11.4g}  {r:9.2e}")
    cond = result["condition_number"]
    lines.append(f"condition number: {cond:.3g}" if cond is not None else "condition number: infinite")
    if result["numerically_zero"]:
        lines.append(
            f"{result['numerically_zero']} singular value(s) below {ZERO_RATIO:g} of the largest: "
            "combinations the force does not see at all"
        )
    lines += ["", "weakest directions (a unit step along them changes the force least):"]
    for w in result["weakest"]:
        lines.append(f"  σ/σmax = {w['ratio']:.2e}:  {w['text']}")
    for s in result["symmetries"]:
        lines.append(
            f"exact symmetry {s['name']}: the force changes by at most {s['max_force_change_N']:.2g} N "
            f"along s ∈ [0.8, 1.25]; {s['in_null_space']:.0%} of its tangent ({s['direction']}) lies in the "
            "numerically zero directions above"
        )
    for d in result["null_directions"]:
        kind = (
            "invariant to round-off along a finite path (an exact invariance at this point, not a symmetry of "
            "the model everywhere)"
            if d["exact"]
            else "zero here only: weakly determined, not invariant"
        )
        lines.append(
            f"other numerically zero direction {d['direction']}: {kind} (largest σ/σmax along "
            f"{d['length']:.2g} of the unit range: {d['max_ratio']:.1e}; force change {d['change']:.1e} of "
            "its size)"
        )
    lines += [
        "",
        f"{result['undetermined_directions']} direction(s) undetermined: a step across the whole "
        f"range changes the force by less than the noise ({result['noise_rmse_N']:.3g} N RMSE)",
        f"per parameter, as a fraction of its range in {box}: free range along those directions "
        "(linearised, inside the box) and standard error:",
    ]
    for n in names:
        flag = "  poorly determined" if n in result["poorly_determined"] else ""
        lo, hi = result["free_range"][n]
        lines.append(
            f"  {result.get('labels', {}).get(n) or label(n):<4} free {result['free_range_unit'][n]:6.1%} "
            f"[{lo:9.4g} – {hi:9.4g}]"
            f"   s.e. {_se_text(result['standard_error_unit'][n]):>8}{flag}"
        )
    poor = result["poorly_determined"]
    threshold = f"{result['poor_threshold_unit']:.0%}"
    if poor:
        lines.append(
            f"poorly determined (free range or standard error > {threshold} of the range): "
            + ", ".join(result.get("labels", {}).get(n) or label(n) for n in poor)
        )
    else:
        lines.append(f"every parameter is determined to better than {threshold} of its range")
    for name, points in result["profiles"].items():
        lines += [
            "",
            f"profile of {result.get('labels', {}).get(name) or label(name)} (others re-optimised, L-BFGS-B up to {result['profile_maxiter']} "
            "iterations): value -> MSE (N²), converged?",
        ]
        lines += [
            f"  {p['value']:12.5g}  {p['mse'] if p['mse'] is not None else math.inf:12.5g}  "
            f"{'converged' if p.get('converged') else 'NOT converged (an upper bound)'}"
            for p in points
        ]
    return "\n".join(lines)


def _se_text(x: float) -> str:
    return "> 100 %" if x > 1 else f"{x:.1%}"
