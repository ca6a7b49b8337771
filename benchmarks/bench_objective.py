"""Evaluations per second of our objective against a straightforward scipy solve_ivp model.

Run by hand (never by CI): `.venv/bin/python benchmarks/bench_objective.py`. Everything runs in
the same process on the same 1,921-sample synthetic specimen and parameter sets: half random
draws in the Table 5 box (the population an optimiser sees first), half points near the paper's
Table 6 fits (what it sees later), so the ratios are what to compare across machines; the
absolute rates depend on the machine and on its load. The identifiable formulation (7 searched
parameters, the 9 linear coefficients solved for every trajectory) is timed the same way on its
own population: half uniform in its data-scaled box, half the same points near Table 6 in its
coordinates; its lines give the share of the linear solve in an evaluation. Each rate is the best of ``--repeat`` runs,
and the lockstep and scalar kernels are timed alternately, so a change of load hits both. On a
shared machine ``--clock cpu`` times the one-core lines in process CPU time, which leaves out the
time slices of other processes (the threads line stays in wall time).

The scipy reference is timed the same way as bwbench: the best of ``--repeat`` runs over the first
``--scipy-evals`` (30) uniform draws. The ratios of the protocol before (one run over the first 10 draws
against bwbench's best of ``--repeat``: scipy's rate then moved 4.4–8.1/s between runs, and the ratios
with it) are printed beside, marked "old protocol".
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numba
import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

from bwbench.data.specimen import read_specimen
from bwbench.engine.objective import Objective
from bwbench.models.switched import simulation as model
from bwbench.models.switched.kernel import PARAM_NAMES
from bwbench.models.switched.model import MODEL
from bwbench.models.switched.parameters import LOWER, UPPER
from bwbench.problems.hysteresis.model_problem import DirectProblem, IdentifiableProblem

REPO = Path(__file__).resolve().parents[1]
SPECIMEN = REPO / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"
PAPER_FITS = REPO / "data" / "paper" / "identified_parameters.csv"


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


def rate(fn, n, repeat, clock=time.perf_counter):
    """Calls per second of fn() (each call evaluates n points): the best of ``repeat`` runs."""
    best = np.inf
    for _ in range(repeat):
        start = clock()
        fn()
        best = min(best, clock() - start)
    return n / best


def population(rng, size):
    """Half uniform in the Table 5 box, half within ±5 % of the box around the Table 6 fits (unit cube)."""
    fits = pd.read_csv(PAPER_FITS)
    table6 = fits.loc[fits["table"] == 6, list(PARAM_NAMES)].to_numpy(dtype=float)
    uniform = rng.random((size - size // 2, 14))
    centres = (table6 - LOWER) / (UPPER - LOWER)
    near = centres[rng.integers(len(centres), size=size // 2)] + rng.uniform(-0.05, 0.05, (size // 2, 14))
    return np.vstack([uniform, np.clip(near, 0.0, 1.0)])


def identifiable_population(problem, rng, P):
    """Half uniform in the identifiable box, half the paper rows P's second half (near Table 6) mapped
    to the identifiable coordinates (unit cube, clipped)."""
    from bwbench.models.switched import identifiable as fm

    half = len(P) // 2
    near = np.array([fm.from_paper(p, problem.state)[0] for p in P[len(P) - half :]])
    return np.vstack([rng.random((len(P) - half, problem.dim)), np.clip(problem.to_unit(near), 0.0, 1.0)])


def identifiable_rates(specimen, P, repeat, clock):
    """(one call per point, batched, linear solve per evaluation in s) of the identifiable formulation."""
    problem = IdentifiableProblem(MODEL, specimen)
    U = identifiable_population(problem, np.random.default_rng(1), P)
    Objective(problem, 4).batch(U[:2])  # compile outside the timing
    Objective(problem, 4)(U[0])
    single = rate(lambda: [Objective(problem, 1)(u) for u in U], len(U), repeat, clock)
    batched = rate(lambda: Objective(problem, len(U)).batch(U), len(U), repeat, clock)
    Z = problem.model.trajectories(problem.from_unit(U), problem.signal, problem.state)
    solve = 1.0 / rate(lambda: problem.design.mse(Z), len(U), repeat, clock)
    return single, batched, solve


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--population", type=int, default=400)
    parser.add_argument("--scipy-evals", type=int, default=30, help="uniform draws scipy simulates per run")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall", help="clock of the one-core lines")
    args = parser.parse_args()
    clock = time.perf_counter if args.clock == "wall" else time.process_time

    problem = DirectProblem(MODEL, read_specimen(SPECIMEN))
    s = problem.signal
    U = population(np.random.default_rng(0), args.population)
    P = problem.from_unit(U)
    problem.loss_batch(P[:2])  # compile (or load the cache) outside the timing
    for kernel in ("scalar", "lockstep"):
        model.mse_batch(P[:2], s.t, s.x, s.v, s.a, problem.specimen.f, kernel=kernel)

    numba.set_num_threads(1)
    single = rate(lambda: [Objective(problem, 1)(u) for u in U], len(U), args.repeat, clock)
    batched = rate(lambda: Objective(problem, len(U)).batch(U), len(U), args.repeat, clock)
    kernels = {"scalar": 0.0, "lockstep": 0.0}
    for _ in range(args.repeat):
        for kernel in kernels:
            run = rate(
                lambda kernel=kernel: model.mse_batch(P, s.t, s.x, s.v, s.a, problem.specimen.f, kernel=kernel),
                len(P),
                1,
                clock,
            )
            kernels[kernel] = max(kernels[kernel], run)
    id_single, id_batched, id_solve = identifiable_rates(problem.specimen, P, args.repeat, clock)
    k = args.scipy_evals  # before the threads line: numba's idle pool threads may still spin after it
    # scipy timed as bwbench is: the best of ``repeat`` runs, each over the first k draws; the first 10 of
    # each run timed apart, so the protocol before (one run of 10) and the best of runs of those same 10
    # come from the same runs.
    first10, whole = [], []
    for _ in range(args.repeat):
        start = clock()
        for i, p in enumerate(P[:k]):
            scipy_mse(p, s, problem.specimen.f)
            if i == min(k, 10) - 1:
                first10.append(clock() - start)
        whole.append(clock() - start)
    reference_old = min(k, 10) / first10[0]
    reference_10 = min(k, 10) / min(first10)
    reference = k / min(whole)
    # The first k points are uniform draws, which cost scipy ~7x more than points near the fits (bwbench
    # ~2x): the same mix as our rates' population, km of each half, is the like-for-like reference.
    km = max(1, k // 3)
    mix = np.vstack([P[:km], P[len(P) // 2 : len(P) // 2 + km]])
    reference_mix = rate(lambda: [scipy_mse(p, s, problem.specimen.f) for p in mix], len(mix), args.repeat, clock)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    batched_all = rate(lambda: Objective(problem, len(U)).batch(U), len(U), args.repeat)

    print(
        f"specimen: {SPECIMEN.name} ({problem.specimen.n_samples} samples, synthetic); "
        f"{len(U)} points, half uniform in Table 5, half near the Table 6 fits; {args.clock} clock"
    )
    print(f"bwbench, one core, one call per point : {single:9.0f} evaluations/s")
    print(f"bwbench, one core, batched            : {batched:9.0f} evaluations/s")
    print(f"bwbench, {numba.config.NUMBA_NUM_THREADS} threads, batched           : {batched_all:9.0f} evaluations/s")
    print(
        f"scipy solve_ivp (RK45), one core      : {reference:9.2f} evaluations/s (best of {args.repeat} runs of {k} "
        f"uniform draws; of their first 10: {reference_10:.2f}; old protocol, one run of those 10: {reference_old:.2f})"
    )
    print(
        f"ratio one core (single / scipy)       : {single / reference:9.0f}x (old protocol {single / reference_old:.0f}x)"
    )
    print(
        f"ratio one core (batched / scipy)      : {batched / reference:9.0f}x (first 10 draws "
        f"{batched / reference_10:.0f}x; old protocol {batched / reference_old:.0f}x)"
    )
    print(
        f"scipy on the population's mix ({km} uniform + {km} near the fits): {reference_mix:.2f} evaluations/s; "
        f"ratio batched / that : {batched / reference_mix:.0f}x"
    )
    print(
        f"kernels, one core: lockstep {kernels['lockstep']:.0f}/s, scalar {kernels['scalar']:.0f}/s, "
        f"ratio (lockstep / scalar) : {kernels['lockstep'] / kernels['scalar']:.2f}x"
    )
    print(
        f"identifiable, one core, one call per point : {id_single:9.0f} evaluations/s "
        f"({id_single / reference:.0f}x scipy; old protocol {id_single / reference_old:.0f}x)"
    )
    print(
        f"identifiable, one core, batched            : {id_batched:9.0f} evaluations/s "
        f"({id_batched / reference:.0f}x scipy; first 10 draws {id_batched / reference_10:.0f}x; old protocol "
        f"{id_batched / reference_old:.0f}x); linear solve "
        f"{1e6 * id_solve:.1f} us of {1e6 / id_batched:.1f} us per evaluation"
    )
    print("targets: >= 3,000 evaluations/s on one core, >= 600x scipy batched; lockstep >= 2x scalar")


if __name__ == "__main__":
    main()
