"""Time per sample of the velocity estimate (``derivatives.estimate``) and of its error estimate
(``derivatives.velocity_error``), as ``bwbench data check`` and ``fit`` run them on a record without a
velocity column, from 10⁴ to 10⁷ samples: linear in the length means a flat time per sample.

The record: a 1 kHz test of ±5 mm sines at 0.5–3 Hz with 1 µm encoder noise, rounded to 10 nm as the
files print it. Printed per length: seconds and µs per sample of each step, and the ratio of the time
per sample to that of the shortest record, measured in the same run.

Run: `nice .venv/bin/python benchmarks/bench_signal_speed.py [--max 1e6]`.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bwbench.models import derivatives


def record(n: int, rng) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(n) * 1e-3
    frequency = 0.5 + 2.5 * (0.5 + 0.5 * np.sin(2 * np.pi * t / 997.0))  # slowly swept: no two cycles alike
    x = 5.0 * np.sin(2 * np.pi * np.cumsum(frequency) * 1e-3) + rng.normal(0.0, 1e-3, n)
    return t, np.round(x / 1e-5) * 1e-5


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max", type=float, default=1e7, help="the longest record (samples, default 1e7)")
    args = parser.parse_args()
    derivatives.estimate(*record(100, np.random.default_rng(0)))  # imports and caches out of the timing
    lengths = [n for n in (10**4, 10**5, 10**6, 10**7) if n <= args.max]
    print(
        f"{'samples':>9} {'estimate s':>10} {'µs/sample':>9} {'ratio':>6} {'error s':>8} {'µs/sample':>9} {'ratio':>6}"
    )
    reference = None
    for n in lengths:
        t, x = record(n, np.random.default_rng(1))
        started = time.perf_counter()
        e = derivatives.estimate(t, x)
        estimate_s = time.perf_counter() - started
        started = time.perf_counter()
        derivatives.velocity_error(t, x, e)
        error_s = time.perf_counter() - started
        per = (1e6 * estimate_s / n, 1e6 * error_s / n)
        reference = reference or per
        print(
            f"{n:>9.0e} {estimate_s:>10.3f} {per[0]:>9.2f} {per[0] / reference[0]:>6.2f} {error_s:>8.3f} "
            f"{per[1]:>9.2f} {per[1] / reference[1]:>6.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
