"""A whole ``bwbench fit`` process against one scipy LSODA simulation of the same test, and what of the
process is the libraries' start-up.

    .venv/bin/python benchmarks/bench_fit_process.py               # six rig-sized tests, ~1-2 min
    .venv/bin/python benchmarks/bench_fit_process.py --files DIR   # your own CSVs (with a velocity column)

The files (unless ``--files``): six MR-damper rig tests the size of the measured ones the speed issue
names (4,800–12,000 samples, 200 Hz–1 kHz, a velocity channel), from ``measured_like_mr.py``'s
generator (Spencer et al. 1997's published model integrated by scipy's LSODA, not by bwbench).

For each file: the fastest of ``--repeat`` whole processes ``bwbench fit FILE --model spencer
--optimizer lsq-trf --out F.json`` run from a scratch folder (start-up, reading, the fit, its checks,
writing: what a user waits for), and the fastest of three LSODA simulations of the same file at the
fitted parameters (``bench_real_fit.lsoda_force``: solve_ivp with default tolerances). Also the
start-up floor: the fastest of ``--repeat`` processes that only import what a fit imports (numpy,
numba, scipy.optimize, bwbench's fit) and make numba's first call of a cached kernel — what every
process pays before it reads a file (numba's first call installs its typing and target registries,
~0.4 s, even when the kernel is cached). Prints both ratios (process ÷ LSODA; process minus the floor
÷ LSODA) and their medians; then all the files in one ``bwbench fit --each`` process (the floor paid
once) against one LSODA simulation of each.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_real_fit  # noqa: E402  (its LSODA reference)
import measured_like_mr  # noqa: E402  (its generator)

# name, amplitude mm, frequency Hz, voltage V, sampling Hz, steady cycles, tared load cell: the speed
# issue's measured tests' sizes (4,500–12,000 samples at 200 Hz–1 kHz)
RIG_TESTS = (
    ("rig_a25_f1_v2.25_200Hz", 25.0, 1.0, 2.25, 200.0, 23, False),  # 5,000 samples
    ("rig_a20_f0.5_v1.5_200Hz", 20.0, 0.5, 1.5, 200.0, 10, True),  # 4,800
    ("rig_a10_f2_v1_500Hz", 10.0, 2.0, 1.0, 500.0, 18, True),  # 5,000
    ("rig_a15_f2.5_v2.25_1kHz", 15.0, 2.5, 2.25, 1000.0, 10, False),  # 4,800
    ("rig_a5_f4_v0.5_1kHz", 5.0, 4.0, 0.5, 1000.0, 18, True),  # 5,000
    ("rig_a25_f0.5_v1_1kHz", 25.0, 0.5, 1.0, 1000.0, 4, True),  # 12,000
)
IMPORTS = """
import numpy as np, numba, scipy.optimize
import bwbench.commands.fit, bwbench.commands.simulate
from bwbench.models.spencer import kernel as spencer_kernel
"""
FLOOR = (
    IMPORTS
    + """
t = np.linspace(0.0, 1.0, 64)
spencer_kernel.ydot_batch(np.array([[0.1, 2.0, 0.0, 10.0, 0.1, 1.0]]), t, np.sin(6 * t), 6 * np.cos(6 * t), -36 * np.sin(6 * t))
"""
)


def fastest_process(command: list[str], cwd: Path, repeat: int) -> float:
    """The fastest wall time of ``repeat`` runs of ``command`` (each must succeed)."""
    walls = []
    for _ in range(max(1, repeat)):
        started = time.perf_counter()
        subprocess.run(command, cwd=cwd, check=True, capture_output=True)
        walls.append(time.perf_counter() - started)
    return min(walls)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--files", type=Path, help="a folder of CSV files with a velocity column (default: the rig tests)"
    )
    parser.add_argument("--repeat", type=int, default=2, help="processes per file; the fastest counts")
    args = parser.parse_args()
    bwbench = [sys.executable, "-m", "bwbench.cli"]
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        if args.files is None:
            made = measured_like_mr.write_tests(scratch / "tests", RIG_TESTS)
            files = [path for path, _, _ in made.values()]
        else:
            files = sorted(args.files.resolve().glob("*.csv"))
        # compile (or load) every kernel once, outside the timing, as an installed bwbench has
        subprocess.run(
            [*bwbench, "fit", str(files[0]), "--model", "spencer", "--out", "warm.json"],
            cwd=scratch,
            check=True,
            capture_output=True,
        )
        imports = fastest_process([sys.executable, "-c", IMPORTS], scratch, args.repeat + 1)
        floor = fastest_process([sys.executable, "-c", FLOOR], scratch, args.repeat + 1)
        print(
            f"start-up floor: {floor:.2f} s (imports of numpy, numba, scipy.optimize, bwbench: {imports:.2f} s; numba's first cached call: {floor - imports:.2f} s)\n"
        )
        print(
            f"{'file':<26} {'samples':>7} {'process s':>9} {'LSODA s':>8} {'ratio':>6} {'less floor':>10} {'NRMSE':>7}"
        )
        ratios, net, references = [], [], []
        for path in files:
            command = [*bwbench, "fit", str(path), "--model", "spencer", "--optimizer", "lsq-trf", "--out", "fit.json"]
            seconds = fastest_process(command, scratch, args.repeat)
            fit = json.loads((scratch / "fit.json").read_text())
            reference = bench_real_fit.simulation_time(path, {k: fit["params"][k] for k in bench_real_fit.DIRECT}, 3)
            references.append(reference)
            ratios.append(seconds / reference)
            net.append((seconds - floor) / reference)
            print(
                f"{path.stem:<26} {fit['files'][0]['n']:>7} {seconds:>9.2f} {reference:>8.3f} {ratios[-1]:>6.1f} {net[-1]:>10.1f} "
                f"{fit['files'][0]['nrmse']:>7.4f}",
                flush=True,
            )
        print(
            f"\nmedian process ÷ LSODA: {np.median(ratios):.1f} (target ≤ 5); less the start-up floor: {np.median(net):.1f}"
        )
        each = [
            *bwbench,
            "fit",
            *map(str, files),
            "--each",
            "--model",
            "spencer",
            "--optimizer",
            "lsq-trf",
            "--out",
            "fits",
        ]
        seconds = fastest_process(each, scratch, args.repeat)
        print(
            f"all {len(files)} in one `fit --each` process: {seconds:.2f} s ({seconds / len(files):.2f} s a file), "
            f"{seconds / sum(references):.1f}× one LSODA simulation of each"
        )


if __name__ == "__main__":
    main()
