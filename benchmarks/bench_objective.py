"""Evaluations per second of our objective against a straightforward scipy solve_ivp model.

Run by hand (never by CI): `.venv/bin/python benchmarks/bench_objective.py`. Both run in the
same process on the same 1,921-sample synthetic specimen and parameter sets (random draws in
the Table 5 box, the population an optimiser sees first), so the ratio is what to compare
across machines; the absolute rates depend on the machine and on its load.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numba
import numpy as np
from scipy.integrate import solve_ivp

from bwbench.optimize.objective import Objective
from bwbench.data.parameters import LOWER, UPPER
from bwbench.problems.switched_vpp.problem import SwitchedBoucWenProblem
from bwbench.data.specimen import read_specimen

SPECIMEN = Path(__file__).resolve().parents[1] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"


def scipy_mse(params, signal, f_meas):
    """The model as one would first write it: solve_ivp (RK45, default tolerances) in time."""
    t, x, v, a = signal.t, signal.x, signal.v, signal.a

    def rhs(tt, z):
        xdot = np.interp(tt, t, v)
        s = params[:7] if xdot >= 0 else params[7:]
        A, n, _, beta, gamma, _, _ = s
        zz = z[0]
        return [xdot * (A - (beta + gamma * np.sign(zz * xdot)) * abs(zz) ** n)]

    with np.errstate(all="ignore"):
        sol = solve_ivp(rhs, (t[0], t[-1]), [0.0], t_eval=t)
    if not sol.success or sol.y.shape[1] != len(t):
        return np.inf
    z = sol.y[0]
    minus = v < 0
    A, n, alpha, beta, gamma, xi, wn = (np.where(minus, params[7 + i], params[i]) for i in range(7))
    force = a + 2 * xi * wn * v + alpha * wn**2 * x + (1 - alpha) * wn**2 * z
    mse = np.mean((force - f_meas) ** 2)
    return mse if np.isfinite(mse) else np.inf


def rate(fn, n):
    start = time.perf_counter()
    fn()
    return n / (time.perf_counter() - start)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--population", type=int, default=400)
    parser.add_argument("--scipy-evals", type=int, default=10)
    args = parser.parse_args()

    problem = SwitchedBoucWenProblem(read_specimen(SPECIMEN))
    rng = np.random.default_rng(0)
    U = rng.random((args.population, 14))
    P = LOWER + U * (UPPER - LOWER)
    problem.loss_batch(P[:2])  # compile (or load the cache) outside the timing

    numba.set_num_threads(1)
    single = rate(lambda: [Objective(problem, 1)(u) for u in U], len(U))
    batched = rate(lambda: Objective(problem, len(U)).batch(U), len(U))
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    batched_all = rate(lambda: Objective(problem, len(U)).batch(U), len(U))
    k = args.scipy_evals
    reference = rate(lambda: [scipy_mse(p, problem.signal, problem.specimen.f) for p in P[:k]], k)

    print(f"specimen: {SPECIMEN.name} ({problem.specimen.n_samples} samples, synthetic)")
    print(f"bwbench, one core, one call per point : {single:9.0f} evaluations/s")
    print(f"bwbench, one core, batched            : {batched:9.0f} evaluations/s")
    print(f"bwbench, {numba.config.NUMBA_NUM_THREADS} threads, batched           : {batched_all:9.0f} evaluations/s")
    print(f"scipy solve_ivp (RK45), one core      : {reference:9.2f} evaluations/s")
    print(f"ratio one core (single / scipy)       : {single / reference:9.0f}x")
    print(f"ratio one core (batched / scipy)      : {batched / reference:9.0f}x")
    print("targets: >= 3,000 evaluations/s on one core, >= 100x scipy")


if __name__ == "__main__":
    main()
