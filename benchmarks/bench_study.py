"""Study throughput: runs/s and evaluations/s with 1 and 2 local workers on the same small study.

    python benchmarks/bench_study.py [--runs-per-specimen 16] [--budget 4100] [--workers 1 2]

The study is 2 specimens × N seeds of ``random`` (default 32 runs of 4,100 evaluations), run by
the study's executor (``bwbench.study.execute_tasks``; no database). End to end includes starting
the worker processes (spawned: each imports numpy, scipy, numba and every backend); with 1 worker
the runs go in-process, with no start-up. Steady state leaves the start-up out.
Target: 2 workers ≥ 1.7× the throughput of 1 on a 2-core machine. Numbers from a machine shared
with other jobs mean little: the load average is printed before and after.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from bwbench.datasets.synthetic import SPECIMEN_DIR
from bwbench.study.config import load_study_config
from bwbench.study.execute import execute_tasks
from bwbench.study.tasks import plan_tasks

CONFIG = """
[study]
name = "bench"
seed = 1
budget = {budget}
seeds = {seeds}
data = "{data}"

[specimens]
material = ["POM MT24u01"]
underpressure_MPa = [0.01, 0.09]
repeat = [1]

[optimizers]
random = {{}}
"""


def measure(tasks, workers: int) -> tuple[float, float, int]:
    """(end-to-end seconds, steady-state runs/s, evaluations) of the tasks on ``workers`` workers.

    Steady state: runs finished after every worker delivered its first, over the time they took,
    (n - w) / (t_n - t_w), which leaves out the workers' start-up.
    """
    started = time.perf_counter()
    finished, evaluations = [], 0
    for outcome in execute_tasks(tasks, workers=workers):
        finished.append(time.perf_counter() - started)
        assert outcome["row"]["status"] == "ok", outcome
        evaluations += outcome["row"]["nfev"]
    w = min(workers, len(tasks))
    steady = (len(tasks) - w) / (finished[-1] - finished[w - 1]) if len(tasks) > w else float("nan")
    return finished[-1], steady, evaluations


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs-per-specimen", type=int, default=16)  # 32 runs: a study, not mostly worker start-up
    parser.add_argument("--budget", type=int, default=4100)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "bench.toml"
        path.write_text(CONFIG.format(budget=args.budget, seeds=args.runs_per_specimen, data=SPECIMEN_DIR.as_posix()))
        tasks = plan_tasks(load_study_config(path))
    measure(tasks[:1], 1)  # imports and numba's cache load happen here, not in the timed runs
    print(
        f"{len(tasks)} runs of random, {args.budget} evaluations each; cores: {os.cpu_count()}, "
        f"load average before: {os.getloadavg()[0]:.2f}"
    )
    print(f"{'workers':>7}  {'wall (s)':>8}  {'runs/s':>6}  {'evals/s':>8}  {'steady runs/s':>13}")
    rates, steady_rates = {}, {}
    for workers in args.workers:
        wall, steady, evaluations = measure(tasks, workers)
        rates[workers], steady_rates[workers] = len(tasks) / wall, steady
        print(f"{workers:>7}  {wall:>8.2f}  {len(tasks) / wall:>6.2f}  {evaluations / wall:>8.0f}  {steady:>13.2f}")
    first = args.workers[0]
    for workers in args.workers[1:]:
        print(
            f"speed-up {workers} vs {first} worker(s): {rates[workers] / rates[first]:.2f}x end to end, "
            f"{steady_rates[workers] / steady_rates[first]:.2f}x steady state; "
            f"load average after: {os.getloadavg()[0]:.2f}"
        )


if __name__ == "__main__":
    main()
