"""Evaluations per second of the Bouc-Wen benchmark objective on one training period, one core.

Run by hand (never by CI): `.venv/bin/python benchmarks/bench_boucwen_objective.py [--data DIR]`.
Target: >= 200 evaluations/s, batched and one by one. One evaluation is a periodic steady-state
simulation of one parameter set (2,048 warm-up + 8,192 compared samples of 750 Hz, RK4 at the
module's rate) and its MSE. The population is drawn around the truth, as an optimiser sees it
once it is close (every ν ≠ 1, so |z|^ν costs a ``pow``); a second population is uniform in the
box, where some sets run away early (cheap) and some are stiff (substeps, dear).

Rates are CPU time (``time.process_time``) and wall time: on a shared machine the wall rate
depends on the load, the CPU rate much less. Also printed: e_RMS of the true parameters at the
chosen integration rate on test_multisine (the benchmark's figure is 2e-7 m at 15 kHz).
"""

from __future__ import annotations

import argparse
import time

import numba
import numpy as np

from bwbench.engine.objective import Objective
from bwbench.problems.noel_schoukens.problem import (
    STEPS_PER_SAMPLE,
    TRUE_PARAMS,
    BoucWenBenchmarkProblem,
    default_data_dir,
)


def rates(fn, n):
    cpu, wall = time.process_time(), time.perf_counter()
    fn()
    return n / (time.process_time() - cpu), n / (time.perf_counter() - wall)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", default=str(default_data_dir()), help="folder of the benchmark CSV files")
    parser.add_argument("--population", type=int, default=200)
    parser.add_argument("--steps-per-sample", type=int, default=STEPS_PER_SAMPLE)
    args = parser.parse_args()

    problem = BoucWenBenchmarkProblem(args.data, steps_per_sample=args.steps_per_sample)
    rng = np.random.default_rng(0)
    near = TRUE_PARAMS * np.exp(0.05 * rng.standard_normal((args.population, 8)))
    near[:, 6] = TRUE_PARAMS[6] + 0.05 * rng.standard_normal(args.population)
    U_near = np.clip(problem.to_unit(near), 0.0, 1.0)
    U_box = rng.random((args.population, 8))
    problem.loss_batch(near[:2])  # compile (or load the cache) outside the timing

    numba.set_num_threads(1)
    n = len(U_near)
    single = rates(lambda: [Objective(problem, 1)(u) for u in U_near], n)
    batched = rates(lambda: Objective(problem, n).batch(U_near), n)
    box = rates(lambda: Objective(problem, n).batch(U_box), n)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    batched_all = rates(lambda: Objective(problem, n).batch(U_near), n)

    rate_hz = 750 * problem.steps_per_sample
    print(
        f"integration: RK4 at {rate_hz:g} Hz, warm-up {problem.warmup_samples} samples, "
        f"{problem.n_data} compared samples"
    )
    print(f"e_RMS of the truth on test_multisine : {problem.test_error(TRUE_PARAMS):.3g} m")
    print(f"RMS residual of the truth (train)    : {np.sqrt(problem.loss_batch(TRUE_PARAMS[None])[0]):.3g} m")
    print("                                         CPU rate   wall rate  (evaluations/s)")
    print(f"one core, one call per point (near)  : {single[0]:9.0f}  {single[1]:9.0f}")
    print(f"one core, batched (near the truth)   : {batched[0]:9.0f}  {batched[1]:9.0f}")
    print(f"one core, batched (uniform in box)   : {box[0]:9.0f}  {box[1]:9.0f}")
    print(
        f"{numba.config.NUMBA_NUM_THREADS} threads, batched (near the truth)  : "
        f"{batched_all[0]:9.0f}  {batched_all[1]:9.0f}"
    )
    print("target: >= 200 evaluations/s on one core")


if __name__ == "__main__":
    main()
