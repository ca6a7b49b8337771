"""What one call of the objective costs beyond its simulations, and what a point of the search box costs.

Run by hand (never by CI): `.venv/bin/python benchmarks/bench_call_cost.py`. For each model and
formulation on one file, the same random points of the default search box (fixed seed) are run
three ways in the same process: one point per ``Objective.batch`` call, all points in one call, and
the model's bare simulation of all points (no loss, no linear solve). The ratios are what to compare
across machines and runs:

- ``per call ÷ simulation``: the time of a one-point call over the bare simulation of that point
  (1.0 = no fixed cost per call);
- ``batched ÷ simulation``: the same for the batched call (what the loss adds per point);
- the slowest point's time and the median, in ms: what a stiff corner of the box costs;
- for a model with sensitivities (every built-in one), what one simulation with them costs in plain
  simulations of the same points, one point at a time (the model's trajectory, or its force in the
  direct formulation): the price ``sensitivity_cost`` charges an exact Jacobian against the budget.
  Also per point of a d-row batch (what a Jacobian by differences simulates) and, with ``--optimum``,
  the same at the best point of a short lsq-trf fit (where the simulations of a fit's end are).

``--threads`` sets numba's threads (default: numba's own default, one per core, where a fixed cost
of a parallel loop shows on a busy machine).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numba
import numpy as np

from bwbench.data.specimen import read_specimen
from bwbench.engine.objective import Objective
from bwbench.models.base import Model
from bwbench.problems.hysteresis.formulations import make_problem

REPO = Path(__file__).resolve().parents[1]
CASES = (
    ("switched-bouc-wen", "identifiable", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
    ("switched-bouc-wen", "paper", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
    ("spencer", "identifiable", REPO / "data" / "mr_damper" / "mr_25mm_1Hz_0V.csv"),
    ("spencer", "direct", REPO / "data" / "mr_damper" / "mr_25mm_1Hz_0V.csv"),
    ("bouc-wen", "identifiable", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
    ("bouc-wen", "direct", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
    ("switched-bouc-wen", "identifiable", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv", "split"),
    ("bwbn", "identifiable", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
    ("bwbn", "direct", REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"),
)


def simulate(problem, P):
    """The bare simulation of rows P: the model's θ-dependent column, or its force (direct)."""
    if hasattr(problem, "design"):
        return problem.model.trajectories(P, problem.signal, problem.state)
    return problem.model.force_batch(P, problem.signal, problem.state)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=40, help="random points of the box per case")
    parser.add_argument("--threads", type=int, default=0, help="numba threads (0: numba's default)")
    parser.add_argument(
        "--optimum",
        type=int,
        default=0,
        metavar="BUDGET",
        help="also price the sensitivities at the end of an lsq-trf fit of this budget",
    )
    parser.add_argument("--only", default="", help="run only the cases of this model")
    args = parser.parse_args()
    if args.threads:
        numba.set_num_threads(args.threads)
    print(f"numba threads: {numba.get_num_threads()}; {args.points} random points of the default box per case")
    print(
        f"{'model':<18} {'formulation':<12} {'samples':>7} {'sim ms/pt':>9} {'median ms':>9} {'max ms':>8} "
        f"{'per call/sim':>12} {'batched/sim':>11}"
    )
    for name, formulation, path, *state in CASES:
        if args.only and name != args.only:
            continue
        settings = {"model": name, "formulation": formulation, **({"state": state[0]} if state else {})}
        problem = make_problem(read_specimen(path), settings)
        U = np.random.default_rng(0).random((args.points, problem.dim))
        P = problem.from_unit(U)
        for rows in (1, 2):  # compile (or load the cache) of the one-row and the batched paths outside the timing
            Objective(problem, 2).batch(U[:rows])
            simulate(problem, P[:rows])
        each = []
        for p in P:
            start = time.perf_counter()
            simulate(problem, p[None, :])
            each.append(time.perf_counter() - start)
        sim = sum(each)
        objective = Objective(problem, 10 * args.points)
        start = time.perf_counter()
        for u in U:
            objective.batch(u[None, :])
        per_call = time.perf_counter() - start
        start = time.perf_counter()
        objective.batch(U)
        batched = time.perf_counter() - start
        label = f"{formulation} {state[0]}" if state else formulation
        print(
            f"{name:<18} {label:<12} {problem.n_data:>7} {1e3 * sim / len(P):>9.2f} "
            f"{1e3 * np.median(each):>9.2f} {1e3 * max(each):>8.1f} {per_call / sim:>12.2f} {batched / sim:>11.2f}"
        )
        if has_sensitivities(problem):
            sensitivity_price(problem, P, "random points")
            if args.optimum:
                from bwbench.engine import fitting

                best = fitting.run(problem, "lsq-trf", args.optimum, 0)
                p = np.array([best.params[n] for n in problem.param_names])
                sensitivity_price(problem, np.repeat(p[None, :], 10, axis=0), "optimum")


def has_sensitivities(problem) -> bool:
    if hasattr(problem, "design"):
        return type(problem.model).trajectory_sensitivities is not Model.trajectory_sensitivities
    return hasattr(problem.model, "force_sensitivities")


def sensitivities(problem, p):
    """The model's simulation of one point with its sensitivities (None: none here)."""
    if hasattr(problem, "design"):
        return problem.model.trajectory_sensitivities(p, problem.signal, problem.state)
    if hasattr(problem.model, "force_sensitivities"):
        return problem.model.force_sensitivities(p, problem.signal, problem.state)
    return None


REPEAT = 5


def sensitivity_price(problem, P, where):
    """Time of the simulations with sensitivities ÷ time of the plain ones at the same points, one at
    a time; and ÷ the time per point of plain batches of d points. Each the best of ``REPEAT``."""
    sensitivities(problem, P[0])  # compile outside the timing
    simulate(problem, P[:1])
    d = problem.dim
    plain = with_sens = batched = 0.0
    failed = 0
    for p in P:
        # Each the best of REPEAT runs, alternating: a shared machine's load would otherwise decide.
        times = np.full(3, np.inf)
        for _ in range(REPEAT):
            for i in range(3):
                start = time.perf_counter()
                if i == 0:
                    found = simulate(problem, p[None, :])
                elif i == 1:
                    found = sensitivities(problem, p)
                else:
                    found = simulate(problem, np.repeat(p[None, :], d, axis=0))
                times[i] = min(times[i], time.perf_counter() - start)
                if i == 1:
                    none = found is None
        failed += none
        plain += times[0]
        with_sens += times[1]
        batched += times[2] / d
    print(
        f"{'':<18} {'':<12} sensitivities at {len(P)} {where}: {with_sens / plain:.2f} one-point plain simulations "
        f"({with_sens / batched:.2f} per point of {d}-point batches; {failed} without); charged "
        f"{problem.model.sensitivity_cost}"
    )


if __name__ == "__main__":
    main()
