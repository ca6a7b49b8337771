"""``bwbench identifiability``: which parameters of the switched model one specimen cannot pin down.

The generic tools (Jacobian, SVD, free ranges, profiles) are ``bwbench.analysis.identifiability``;
this module applies them to the 14 paper parameters at a fit and writes the result as text or JSON.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

import numpy as np

from bwbench.analysis.identifiability import POOR_SE, STEP, ZERO_RATIO, profile, sensitivity
from bwbench.errors import UserError


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
    parser.set_defaults(func=cli_main)


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
