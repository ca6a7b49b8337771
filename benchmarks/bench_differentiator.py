"""Why the measured excitation uses a Savitzky-Golay (9, 4) differentiator.

Simulates the 15 truth parameter sets of Tables 6-8 on the synthetic machine motion (exact
x, v, a on a 20x finer grid), then fits them back with the 1 Hz samples differentiated by
several Savitzky-Golay filters, with and without 1 um encoder noise. Prints the truth-parameter
MSE (N^2): what an optimiser could at best reach if the model were exact. Force noise is not
added here, so 0 is the floor. Run: `.venv/bin/python benchmarks/bench_differentiator.py`.
"""

import numpy as np

from bwbench.models import excitation
from bwbench.models import switched_bouc_wen as model
from bwbench.data import synthetic

SETTINGS = synthetic.Settings()
CHOICES = [(5, 2), (7, 2), (7, 3), (9, 3), (9, 4), (11, 4)]


def main():
    rows = synthetic.read_paper_parameters()
    step = 1.0 / SETTINGS.sample_rate_hz
    t = np.arange(0.0, 1920.0 + step, step)
    x, _, _, _ = synthetic.triangular_motion(t, SETTINGS)
    fine = np.arange(0.0, 1920.0 + 1e-9, step / SETTINGS.fine_factor)
    xf, vf, af, _ = synthetic.triangular_motion(fine, SETTINGS)
    forces = [model.simulate(r["params"], fine, xf, vf, af)[:: SETTINGS.fine_factor] for r in rows]
    noise = np.random.default_rng(0).normal(0, SETTINGS.noise_displacement_mm, x.shape)
    print(f"{'filter':>8} {'noise-free median':>18} {'max':>8} {'1 um noise median':>18} {'max':>8}")
    for window, order in CHOICES:
        cells = []
        for x_in in (x, x + noise):
            e = excitation.measured(t, x_in, window, order)
            mse = [model.mse_batch(r["params"][None], e.t, e.x, e.v, e.a, f)[0] for r, f in zip(rows, forces)]
            cells += [np.median(mse), np.max(mse)]
        print(f"SG({window},{order}) {cells[0]:18.1f} {cells[1]:8.1f} {cells[2]:18.1f} {cells[3]:8.1f}")


if __name__ == "__main__":
    main()
