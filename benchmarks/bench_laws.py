"""What laws of the control cost: a fit with laws against one without, on the same data, in the same run.

Run by hand (never by CI): `.venv/bin/python benchmarks/bench_laws.py`. The data: a damper of
``bwbench.problems.hysteresis.control.generator`` (Spencer's model, v_y and c₁ linear in the voltage) at four voltages, two
sine tests each (2 N force noise). The same 8 files are fitted three ways with lsq-trf, seed 0, the same
budget, CPU time measured in this process:

- ``joint, constants``: the plain joint fit (``JointProblem``, one parameter set for all files);
- ``laws, none``: the same fit through ``ControlledProblem`` with no law (its own overhead: the linear
  solve in numpy instead of the compiled kernel);
- ``laws, v_y and c₁ linear``: one model with the two laws (2 more coefficients, one searched, one solved).

Printed per way: the CPU time of one loss evaluation, of one exact Jacobian, of the whole fit, its
evaluations and MSE, and the ratios against the joint fit.
"""

from __future__ import annotations

import time

import numpy as np

from bwbench.problems.hysteresis.control import generator as controlled
from bwbench.problems.hysteresis.control.problem import build
from bwbench.problems.hysteresis.fit_result import run_fit
from bwbench.problems.hysteresis.formulations import make_problem

TESTS = [
    controlled.Test(f"t{level}_{k}", a, f, level)
    for level in (0.0, 0.75, 1.5, 2.25)
    for k, (a, f) in enumerate([(20, 1.0), (10, 2.0)])
]
BUDGET = 1500
REPEATS = 20


def cpu(fn, repeats: int = REPEATS) -> float:
    fn()
    start = time.process_time()
    for _ in range(repeats):
        fn()
    return (time.process_time() - start) / repeats


def main() -> None:
    specimens = controlled.simulate(controlled.SPENCER_LAWS, TESTS, noise_N=2.0, seed=3)
    ways = {
        "joint, constants": make_problem(specimens, {"model": "spencer"}),
        "laws, none": build(specimens, {"model": "spencer"}, {}),
        "laws, v_y and c1 linear": build(specimens, {"model": "spencer"}, {"vy": "linear", "c1": "linear"}),
    }
    for problem in ways.values():  # every kernel compiled (numba's first calls) before anything is timed
        run_fit(problem, "lsq-trf", 60, 1, stop="budget")
    rows = {}
    for name, problem in ways.items():
        point = problem.from_unit(np.full(problem.dim, 0.5))[None, :]
        loss = cpu(lambda p=problem, x=point: p.loss_batch(x))
        jac = cpu(lambda p=problem, x=point: p.residual_jacobian(x[0]), 5)
        start = time.process_time()
        fit = run_fit(problem, "lsq-trf", BUDGET, 0, stop="agreed")
        rows[name] = (loss, jac, time.process_time() - start, fit.result.nfev, fit.result.mse, problem.dim)
    ref = rows["joint, constants"]
    print(f"{len(specimens)} files, {sum(s.n_samples for s in specimens)} samples, lsq-trf, budget {BUDGET}, seed 0")
    print("way | searched | loss ms (×) | Jacobian ms (×) | fit CPU s (×) | evaluations | MSE N²")
    for name, (loss, jac, fit_s, nfev, mse, dim) in rows.items():
        print(
            f"{name} | {dim} | {loss * 1e3:.2f} ({loss / ref[0]:.2f}) | {jac * 1e3:.1f} ({jac / ref[1]:.2f}) | "
            f"{fit_s:.2f} ({fit_s / ref[2]:.2f}) | {nfev} | {mse:.4g}"
        )


if __name__ == "__main__":
    main()
