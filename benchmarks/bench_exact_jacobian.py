"""lsq-trf with exact Jacobians (forward sensitivities) against forward differences, same files, same seeds.

Run by hand (never by CI): `.venv/bin/python benchmarks/bench_exact_jacobian.py` (~3–5 min on a busy
core; `--seeds 1` for a first look). For each case (model, formulation, file) and seed, two whole
in-process fits with the study's settings (lsq-trf, budget 4,100, the whole budget spent: no early
stop), one with ``jacobian="auto"`` (exact, charged ``sensitivity_cost`` evaluations each) and one with
``jacobian="differences"`` (d evaluations each), alternating so a change of the machine's load hits
both; numba's compilation is done beforehand. It prints each fit's wall time and final MSE (N²), the
evaluations it took to come within 1 % of the case's best MSE (over all its fits; "-": never), and per
case the medians and the ratio of wall times (differences ÷ exact: > 1 means exact is faster).
With ``--stop agreed`` the fits stop as ``bwbench fit`` does by default (``stop_agree=3``: three
independent local searches ended at the best optimum): then the wall time is what a user waits for.
The lsq-trf runs use one numba thread (as a study's workers do). On a shared machine ``--clock cpu``
times the fits in process CPU time, which leaves out the time slices of other processes.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numba
import numpy as np

from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting
from bwbench.problems.hysteresis.formulations import make_problem

REPO = Path(__file__).resolve().parents[1]
SPECIMENS = REPO / "data" / "specimens"
CASES = (  # model, formulation, file
    ("switched-bouc-wen", "identifiable", SPECIMENS / "pom-mt24u01_0.05MPa_r1.csv"),
    ("switched-bouc-wen", "identifiable", SPECIMENS / "pc-abs-c12hf_0.03MPa_r2.csv"),
    ("switched-bouc-wen", "paper", SPECIMENS / "pom-mt24u01_0.05MPa_r1.csv"),
    ("bouc-wen", "identifiable", REPO / "data" / "mr_damper" / "mr_25mm_1Hz_0V.csv"),
    ("bouc-wen", "identifiable", SPECIMENS / "pom-mt24u01_0.05MPa_r1.csv"),
)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--budget", type=int, default=4100)
    parser.add_argument("--only", default="", help="run only the cases of this model")
    parser.add_argument("--clock", choices=("wall", "cpu"), default="wall")
    parser.add_argument(
        "--stop",
        choices=("budget", "agreed"),
        default="budget",
        help="spend the whole budget (a study) or stop once restarts agree (bwbench fit)",
    )
    args = parser.parse_args()
    numba.set_num_threads(1)
    clock = time.process_time if args.clock == "cpu" else time.perf_counter
    agree = 3 if args.stop == "agreed" else 0
    print(
        f"lsq-trf, budget {args.budget}, stop: {args.stop}, seeds 0..{args.seeds - 1}; per fit: {args.clock} s, MSE N², "
        f"evaluations used and to 1 % of the best"
    )
    print(
        f"{'model':<18} {'formulation':<12} {'file':<28} {'seed':>4} {'exact s':>8} {'MSE':>8} {'nfev':>5} "
        f"{'to 1%':>5} {'diff s':>8} {'MSE':>8} {'nfev':>5} {'to 1%':>5}"
    )
    for model, formulation, path in CASES:
        if args.only and model != args.only:
            continue
        problem = make_problem(read_specimen(path), {"model": model, "formulation": formulation})
        for jacobian in ("auto", "differences"):  # compile outside the timing
            fitting.run(problem, "lsq-trf", 30, 0, {"jacobian": jacobian})
        runs = []
        for seed in range(args.seeds):
            for jacobian in ("auto", "differences"):
                start = clock()
                result = fitting.run(problem, "lsq-trf", args.budget, seed, {"jacobian": jacobian, "stop_agree": agree})
                runs.append((clock() - start, result))
        target = 1.01 * min(r.mse for _, r in runs)
        rows = []
        for seed in range(args.seeds):
            row = []
            for wall, result in runs[2 * seed : 2 * seed + 2]:
                row += [wall, result.mse, result.nfev, to_target(result, target)]
            rows.append(row)
            cells = [
                f"{row[0]:>8.1f}",
                f"{row[1]:>8.4g}",
                f"{row[2]:>5d}",
                count(row[3]),
                f"{row[4]:>8.1f}",
                f"{row[5]:>8.4g}",
                f"{row[6]:>5d}",
                count(row[7]),
            ]
            print(f"{model:<18} {formulation:<12} {path.name:<28} {seed:>4} " + " ".join(cells), flush=True)
        med = np.median(np.array(rows, dtype=float), axis=0)
        cells = [
            f"{med[0]:>8.1f}",
            f"{med[1]:>8.4g}",
            f"{med[2]:>5.0f}",
            count(med[3]),
            f"{med[4]:>8.1f}",
            f"{med[5]:>8.4g}",
            f"{med[6]:>5.0f}",
            count(med[7]),
        ]
        print(
            f"{'':<18} {'':<12} {'median':<28} {'':>4} "
            + " ".join(cells)
            + f"   time differences ÷ exact {med[4] / med[0]:.2f}",
            flush=True,
        )


def to_target(result, target) -> float:
    """Evaluations after which the best MSE so far was within ``target`` (inf: never)."""
    for nfev, mse in zip(result.trace_nfev, result.trace_mse):
        if mse <= target:
            return float(nfev)
    return np.inf


def count(x) -> str:
    return f"{x:>5.0f}" if np.isfinite(x) else f"{'-':>5}"


if __name__ == "__main__":
    main()
