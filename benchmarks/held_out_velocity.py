"""Held-out checks of the velocity handling on specimens bwbench's generator did not make.

Each of the 15 truth sets of Tables 6–8 drives an independent test machine: triangular ramps at
5 mm/min with 8 s half-cosine reversals (``tests/exact_motions.py``), sampled at 2 Hz, the force
from an independent solver (``tests/reference.py``: LSODA in time between the analytic reversals).
The specimens are written as CSV files and read back through ``bwbench.data.specimen``, as a user's
files would be, then the truth is evaluated through bwbench's problem:

1. noise-free, no velocity column: the truth's RMS error (target ≤ 0.5 N);
2. 2 N force noise, 1 µm encoder noise, with a ``velocity_mm_s`` column: the truth's MSE against the
   force-noise variance, 4 N² (target within 10 %), and against the realised noise's own MSE;
   and the same file without the column.

Run: `.venv/bin/python benchmarks/held_out_velocity.py` (about a minute).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import exact_motions as em  # noqa: E402
from bwbench.data.specimen import read_specimen  # noqa: E402
from bwbench.datasets.synthetic import read_paper_parameters  # noqa: E402
from bwbench.models.switched.model import MODEL  # noqa: E402
from bwbench.problems.hysteresis.model_problem import DirectProblem  # noqa: E402
from reference import reference_force_of_motion  # noqa: E402

RATE_HZ = 2.0
FORCE_NOISE_N = 2.0
ENCODER_NOISE_MM = 1e-3


def truth_loss(path, truth) -> float:
    return float(DirectProblem(MODEL, read_specimen(path)).loss_batch(np.asarray(truth)[None])[0])


def main():
    t = np.arange(0.0, em.ramp_duration() - 0.3, 1.0 / RATE_HZ) + 0.0123  # no sample on a reversal
    x, v, _ = em.ramp(t)
    rng = np.random.default_rng(2024)
    rows = read_paper_parameters()
    print(f"{'truth set':<24} {'1: RMS N':>9} {'2: MSE N²':>9} {'/ 4 N²':>7} {'/ realised':>10} {'no column N²':>12}")
    out = {"rms": [], "ratio": [], "realised": [], "without": []}
    with tempfile.TemporaryDirectory() as folder:
        for row in rows:
            truth = row["params"]
            force = reference_force_of_motion(truth, t, em.ramp, em.ramp_reversals())
            clean = Path(folder) / "clean.csv"
            clean.write_text(em.render_csv(t, x, force), encoding="utf-8")
            rms = np.sqrt(truth_loss(clean, truth))
            noise_f = rng.normal(0.0, FORCE_NOISE_N, t.shape)
            noisy_x = x + rng.normal(0.0, ENCODER_NOISE_MM, t.shape)
            with_v = Path(folder) / "with_velocity.csv"
            with_v.write_text(em.render_csv(t, noisy_x, force + noise_f, v=v), encoding="utf-8")
            without_v = Path(folder) / "without_velocity.csv"
            without_v.write_text(em.render_csv(t, noisy_x, force + noise_f), encoding="utf-8")
            mse, mse_without = truth_loss(with_v, truth), truth_loss(without_v, truth)
            realised = float(np.mean((np.round(force + noise_f, 4) - force) ** 2))  # the file prints 0.1 mN
            label = f"{row['material']} {float(row['underpressure_MPa']):.2f} MPa"
            print(
                f"{label:<24} {rms:9.3f} {mse:9.3f} {mse / FORCE_NOISE_N**2:7.3f} {mse / realised:10.3f} {mse_without:12.2f}",
                flush=True,
            )
            for key, value in zip(out, (rms, mse / FORCE_NOISE_N**2, mse / realised, mse_without)):
                out[key].append(value)
    print(
        f"1. noise-free, no velocity column: truth RMS {min(out['rms']):.3f}–{max(out['rms']):.3f} N (target ≤ 0.5 N)"
    )
    print(
        f"2. with a velocity column: truth MSE / 4 N² = {min(out['ratio']):.3f}–{max(out['ratio']):.3f} "
        f"(target 0.9–1.1); / the realised noise's MSE {min(out['realised']):.4f}–{max(out['realised']):.4f}; "
        f"without the column {min(out['without']):.1f}–{max(out['without']):.1f} N²"
    )


if __name__ == "__main__":
    main()
