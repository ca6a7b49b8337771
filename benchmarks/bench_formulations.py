"""Backends × formulations on the quick study's specimens: how often does a run reach the noise floor?

    python benchmarks/bench_formulations.py                      # 5 seeds, 4,100 evaluations
    python benchmarks/bench_formulations.py --seeds 2 --backends lsq-trf,cmaes --budget 1500

Every backend runs on the 3 specimens of studies/quick.toml (POM MT24u01 at 0.01/0.05/0.09 MPa,
repeat 1; shared state, measured excitation) under both formulations (``paper``:
``DirectProblem``, ``identifiable``: ``IdentifiableProblem``, of the switched model) with the same seeds. The
noise floor of a specimen is the MSE of its generating parameters (data/specimens/manifest.json)
under the paper problem's ``loss_batch``; a run "hits" when its final MSE is within 2 % of it
(the identifiable formulation has 2 more linear coefficients, m and an offset per branch, so it
may go slightly below the floor). The table gives, per backend and formulation, the fraction of
runs that hit, the median final MSE, the median MSE / floor, the median number of evaluations
after which the runs that hit first did, and the median wall time of a run.

Runs go to a pool of ``--workers`` processes (default 2), each single-threaded
(``numba.set_num_threads(1)``, one BLAS thread): wall times are per run on one core, comparable between backends.
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SPECIMENS = [ROOT / "data" / "specimens" / f"pom-mt24u01_{p}MPa_r1.csv" for p in ("0.01", "0.05", "0.09")]
BACKENDS = ("lsq-trf", "cmaes", "anneal", "nlopt-bobyqa", "de", "paper-ga", "random")
FORMULATIONS = ("paper", "identifiable")
HIT = 1.02  # final MSE ≤ 1.02 × the truth's MSE
SEED = 20261121  # the quick study's seed


_LIMITS = []


def _init_worker():
    # One thread per worker, numba's and BLAS's, as the study runner does (study/tasks.py).
    import numba
    from threadpoolctl import threadpool_limits

    numba.set_num_threads(1)
    _LIMITS.append(threadpool_limits(limits=1))


@functools.lru_cache(maxsize=None)
def _problem(path: str, formulation: str):
    from bwbench.data.specimen import read_specimen
    from bwbench.models.switched.model import MODEL
    from bwbench.problems.hysteresis.model_problem import DirectProblem, IdentifiableProblem

    specimen = read_specimen(path)
    make = IdentifiableProblem if formulation == "identifiable" else DirectProblem
    return make(MODEL, specimen, state="shared", excitation="measured")


def noise_floor(path: str) -> float:
    """MSE (N²) of the specimen's generating parameters under the paper problem."""
    from bwbench.models.switched.parameters import truth_params

    truth = truth_params(path)
    if truth is None:
        raise SystemExit(f"{path}: no truth in the manifest")
    return float(_problem(path, "paper").loss_batch(truth[None, :])[0])


def run_one(path: str, formulation: str, backend: str, replicate: int, budget: int) -> dict:
    from bwbench.engine import fitting

    problem = _problem(path, formulation)
    # One seed per (specimen, replicate), shared by every backend and both formulations.
    seed = np.random.SeedSequence([SEED, SPECIMENS.index(Path(path)), replicate])
    started = time.perf_counter()
    result = fitting.run(problem, backend, budget, seed)
    floor = noise_floor(path)
    hits = [n for n, mse in zip(result.trace_nfev, result.trace_mse) if mse <= HIT * floor]
    return {
        "specimen": Path(path).stem,
        "formulation": formulation,
        "backend": backend,
        "replicate": replicate,
        "mse": result.mse,
        "nfev": result.nfev,
        "nfev_to_hit": hits[0] if hits else None,
        "wall_s": time.perf_counter() - started,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=5, help="replicates per specimen (default 5)")
    parser.add_argument("--backends", default=",".join(BACKENDS), help="comma-separated backend names")
    parser.add_argument("--budget", type=int, default=4100, help="evaluations per run (default 4,100)")
    parser.add_argument("--formulations", default=",".join(FORMULATIONS), help="paper,identifiable")
    parser.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    args = parser.parse_args(argv)
    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    formulations = [f.strip() for f in args.formulations.split(",") if f.strip()]
    unknown = set(formulations) - set(FORMULATIONS)
    if unknown:
        parser.error(f"unknown formulation(s) {', '.join(sorted(unknown))}")
    from bwbench.engine import registry

    for b in backends:
        registry.get(b)  # unknown names fail here, before any work
    floors = {Path(p).stem: noise_floor(str(p)) for p in SPECIMENS}
    print(
        f"budget {args.budget} evaluations, {args.seeds} seeds x {len(SPECIMENS)} specimens per cell; "
        f"hit = final MSE <= {HIT:g} x truth MSE",
        flush=True,
    )
    for name, floor in floors.items():
        print(f"  truth MSE {name}: {floor:.4f} N^2", flush=True)

    tasks = [
        (str(p), f, b, r, args.budget)
        for f in formulations
        for b in backends
        for p in SPECIMENS
        for r in range(args.seeds)
    ]
    rows = []
    started = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers, initializer=_init_worker) as pool:
        futures = [pool.submit(run_one, *t) for t in tasks]
        for i, future in enumerate(as_completed(futures), 1):
            row = future.result()
            rows.append(row)
            print(
                f"[{i}/{len(tasks)} {time.perf_counter() - started:.0f}s] {row['backend']} "
                f"[{row['formulation']}] {row['specimen']} #{row['replicate']}: "
                f"MSE/truth {row['mse'] / floors[row['specimen']]:.4f}, {row['wall_s']:.1f}s",
                file=sys.stderr,
                flush=True,
            )

    print(
        f"\n{'backend':<14} {'formulation':<13} {'hit':>11} {'median MSE':>11} {'median MSE/truth':>17} "
        f"{'median nfev to hit':>19} {'median wall':>12}"
    )
    for f in formulations:
        for b in backends:
            cell = [r for r in rows if r["backend"] == b and r["formulation"] == f]
            ratio = np.array([r["mse"] / floors[r["specimen"]] for r in cell])
            hits = int(np.sum(ratio <= HIT))
            to_hit = [r["nfev_to_hit"] for r in cell if r["nfev_to_hit"] is not None]
            to_hit = f"{np.median(to_hit):.0f}" if to_hit else "-"
            print(
                f"{b:<14} {f:<13} {hits:>2}/{len(cell):<2} {hits / len(cell):>5.0%} "
                f"{np.median([r['mse'] for r in cell]):>11.4g} {np.median(ratio):>17.4f} "
                f"{to_hit:>19} {np.median([r['wall_s'] for r in cell]):>11.1f}s"
            )
    print(f"\ntotal {time.perf_counter() - started:.0f}s on {args.workers} workers (cpu count {os.cpu_count()})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
