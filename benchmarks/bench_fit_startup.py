"""What estimating the velocity costs a whole `bwbench fit` process.

Runs `bwbench fit S.csv --optimizer paper-ga --budget 4100` as a subprocess on a synthetic specimen
with its logged velocity column (the reference) and on the same file without it (the velocity then
estimated: scipy.interpolate imported, the spline fitted, and the estimate's error bootstrapped for
the fit's report), alternating, and prints the median wall times and their ratio.
Run: `.venv/bin/python benchmarks/bench_fit_startup.py [--repeat 5]`.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SPECIMEN = Path(__file__).resolve().parents[1] / "data" / "specimens" / "pom-mt24u01_0.01MPa_r1.csv"


def wall(path: Path, out: Path) -> float:
    started = time.perf_counter()
    subprocess.run(
        [
            sys.executable,
            "-m",
            "bwbench.cli",
            "fit",
            str(path),
            "--optimizer",
            "paper-ga",
            "--budget",
            "4100",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - started


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    repeat = parser.parse_args().repeat
    with tempfile.TemporaryDirectory() as folder:
        lines = SPECIMEN.read_text().splitlines()
        header = lines[0].split(",")
        keep = [header.index(c) for c in ("time_s", "displacement_mm", "force_N")]
        stripped = Path(folder) / "no_velocity.csv"
        stripped.write_text("\n".join(",".join(np.array(line.split(","))[keep]) for line in lines) + "\n")
        out = Path(folder) / "r.json"
        wall(SPECIMEN, out)  # warm the numba cache and the file system
        recorded, estimated = [], []
        for _ in range(repeat):
            recorded.append(wall(SPECIMEN, out))
            estimated.append(wall(stripped, out))
    a, b = np.median(recorded), np.median(estimated)
    print(f"bwbench fit, paper-ga, 4,100 evaluations, whole process (median of {repeat}):")
    print(f"  velocity recorded in the file:      {a:.2f} s")
    print(f"  velocity estimated from the file:   {b:.2f} s  ({b / a:.2f}× the recorded, +{b - a:.2f} s)")


if __name__ == "__main__":
    main()
