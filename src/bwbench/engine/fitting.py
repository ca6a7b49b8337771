"""Run one backend on one problem with an exact budget: the thin composer of docs/design.md#objective-and-budget."""

from __future__ import annotations

import numbers
import time

import numpy as np

from bwbench.engine import registry
from bwbench.engine.objective import Objective
from bwbench.engine.result import Result
from bwbench.errors import BudgetExhausted, UserError


def run(problem, optimizer: str, budget: int, seed, options: dict | None = None) -> Result:
    """Minimise the problem's loss with backend ``optimizer`` on exactly ``budget`` evaluations.

    ``seed`` is a non-negative int or a ``numpy.random.SeedSequence``; the backend gets a
    ``Generator`` made from it, so the same seed gives the same run. ``options`` are checked by
    ``registry.resolve_options`` (defaults merged in) before anything is evaluated; a bad one, like a
    bad seed, raises ``UserError``.
    """
    backend = registry.get(optimizer)
    opts = registry.resolve_options(optimizer, options)
    if not isinstance(seed, np.random.SeedSequence) and (
        isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0
    ):
        raise UserError(f"the seed must be a non-negative integer, got {seed!r}")
    seed_seq = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(int(seed))
    rng = np.random.default_rng(seed_seq)
    objective = Objective(problem, budget)
    model = getattr(problem, "model", None)
    stops_before = getattr(model, "step_budget_stops", 0)
    started = time.perf_counter()
    extras: dict = {}
    try:
        extras = backend.minimize(objective, rng=rng, **opts) or {}
        message = extras.pop("message", "stopped before the budget was spent")
    except BudgetExhausted:
        message = "budget exhausted"
    wall = time.perf_counter() - started
    stops = getattr(model, "step_budget_stops", 0) - stops_before
    if stops:  # say why those evaluations read +inf: stiff corners of the box, not a failure of the fit
        extras["step_budget_stops"] = int(stops)
    if objective.best_u is None:
        params = {name: float("nan") for name in problem.param_names}
    elif hasattr(problem, "parameters"):  # a problem may report more than its search coordinates
        params = problem.parameters(objective.best_params)
    else:
        params = {name: float(v) for name, v in zip(problem.param_names, objective.best_params)}
    seed_value = seed if not isinstance(seed, np.random.SeedSequence) else int(seed.generate_state(1)[0])
    return Result(
        optimizer=optimizer,
        seed=int(seed_value),
        budget=int(budget),
        nfev=objective.nfev,
        params=params,
        mse=float(objective.best_mse),
        success=bool(np.isfinite(objective.best_mse)),
        message=message,
        wall_s=wall,
        options=opts,
        trace_nfev=tuple(objective.trace_nfev),
        trace_mse=tuple(objective.trace_mse),
        problem=dict(problem.info),
        extras=extras,
        units=problem.units(params) if hasattr(problem, "units") else {},
        at_bound=on_box_edge(problem, objective.best_params) if objective.best_u is not None else {},
    )


# A searched parameter within this fraction of its range (in the box's own, possibly log, coordinates)
# of a bound ended on it: the optimum may lie beyond the box.
EDGE_TOLERANCE = 1e-3


def on_box_edge(problem, params) -> dict:
    """{name: "lower" | "upper"} for each searched parameter of ``params`` (problem coordinates) that
    lies on an edge of the problem's box (``EDGE_TOLERANCE``); {} when none does."""
    u = np.asarray(problem.to_unit(np.asarray(params, dtype=float)), dtype=float)
    out = {}
    for name, ui in zip(problem.param_names, u):
        if ui <= EDGE_TOLERANCE:
            out[name] = "lower"
        elif ui >= 1.0 - EDGE_TOLERANCE:
            out[name] = "upper"
    return out


def edge_warnings(problem, result, explained=()) -> list[str]:
    """One sentence per parameter of ``result.at_bound`` not in ``explained`` (names another check
    accounts for, e.g. x_y on its cap of a linear branch)."""
    out = []
    for name, side in result.at_bound.items():
        if name in explained:
            continue
        i = list(problem.param_names).index(name)
        unit = result.units.get(name, "")
        unit = "" if unit in ("", "-") else f" {unit}"
        out.append(
            f"{name} = {result.params[name]:.6g}{unit} ended on the {side} edge of its search box "
            f"[{problem.lower[i]:.6g}, {problem.upper[i]:.6g}]: the best fit may lie beyond it "
            "(widen it with --bounds, or see docs/models.md on the box)"
        )
    return out
