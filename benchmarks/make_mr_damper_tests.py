"""Write a set of MR-damper sine tests (Spencer et al. 1997) that bwbench's own model did not make.

Frequencies 0.1, 1 and 5 Hz × voltages 0, 1 and 2.25 V, ±25 mm, 3 cycles after a warm-up, 500 Hz,
scaled to a 1.2 kN peak, with the default noise and +8 N load-cell offset; with ``--velocity`` also a
``velocity_mm_s`` column (the velocity channel measured tests carry, 0.5 mm/s noise). One seed per file,
spawned from SEED, so the files are the same bytes on every run. Prints, per file, Spencer's
unscaled peak force, the dissipated energy per cycle (noise-free, scaled) and the realised noise.
Run: `.venv/bin/python benchmarks/make_mr_damper_tests.py --out /tmp/mr`.
"""

import argparse
from pathlib import Path

import numpy as np

from bwbench.datasets import mr_damper

SEED = 1997
FREQUENCIES_HZ = (0.1, 1.0, 5.0)
VOLTAGES = (0.0, 1.0, 2.25)
RATE_HZ = 500.0
VELOCITY_NOISE_MM_S = 0.5


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the CSV files")
    parser.add_argument("--velocity", action="store_true", help="add a velocity_mm_s column (0.5 mm/s noise)")
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    seeds = np.random.SeedSequence(SEED).spawn(len(FREQUENCIES_HZ) * len(VOLTAGES))
    print(
        f"{'file':<22} {'peak unscaled N':>15} {'scale':>7} {'E/cycle J':>9} "
        f"{'E unscaled J':>12} {'noise F N':>9} {'noise x um':>10}"
    )
    for i, (f_hz, volts) in enumerate((f, v) for f in FREQUENCIES_HZ for v in VOLTAGES):
        name = f"mr_{f_hz:g}Hz_{volts:g}V.csv"
        test = mr_damper.write_test(
            out / name,
            frequency_hz=f_hz,
            voltage=volts,
            rate_hz=RATE_HZ,
            rng=np.random.default_rng(seeds[i]),
            velocity=args.velocity,
            velocity_noise_mm_s=VELOCITY_NOISE_MM_S if args.velocity else 0.0,
        )
        n = round(RATE_HZ / f_hz)  # one cycle
        energy = mr_damper.loop_energy(test.x_true[: n + 1], test.f_true[: n + 1]) / 1000.0  # N·mm → J
        noise_f = np.std(test.f - test.f_true)  # the offset is a mean, not noise
        noise_x = np.std(test.x - test.x_true) * 1000.0
        print(
            f"{name:<22} {test.peak_unscaled_N:15.1f} {test.scale:7.3f} {energy:9.1f} "
            f"{energy / test.scale:12.1f} {noise_f:9.2f} {noise_x:10.3f}"
        )


if __name__ == "__main__":
    main()
