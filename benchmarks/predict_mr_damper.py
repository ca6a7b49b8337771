"""Predict, not only fit: joint fits of three MR-damper tests, and true predictions of two others.

    .venv/bin/python benchmarks/predict_mr_damper.py --out /tmp/predict   # ~5 min on 2 busy cores

One damper (Spencer et al. 1997's prototype at 1 V, its own force scale: no per-test rescaling, so
every file is the same damper), recorded at 500 Hz with a velocity channel (0.5 mm/s noise), 0.5 %
force noise, 1 µm displacement noise and an 8 N load-cell offset (``bwbench.datasets.mr_damper``):

- training: sine tests at 25 mm 1 Hz, 10 mm 2.5 Hz and 15 mm 0.5 Hz;
- predicted: a sine at 20 mm 1.5 Hz, and a random-displacement record (8 s, band-limited noise of
  0.2–3 Hz, ±20 mm, starting at rest), its force simulated with ``bwbench.models.spencer.model`` on that
  motion, the same noise and offset.

For Spencer's model and the switched Bouc-Wen (both identifiable), `bwbench fit` of the three
training files jointly and of the first alone (lsq-trf, 4,100 evaluations, seed 1), then
`bwbench predict` of both predicted files with the stored coefficients. Prints the NRMSE
(RMSE / max|F|) table; the files, fits, predictions and figures stay in ``--out``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from bwbench.datasets import mr_damper

TRAIN = (("mr_25mm_1Hz", 25.0, 1.0), ("mr_10mm_2.5Hz", 10.0, 2.5), ("mr_15mm_0.5Hz", 15.0, 0.5))
SINE = ("mr_20mm_1.5Hz", 20.0, 1.5)
RANDOM = "mr_random"
RATE_HZ = 500.0
# Spencer et al. (1997) at 1 V in N, mm, s: c0 c1 (N·s/mm), k0 k1 (N/mm), x0 (mm), α (N/mm), β γ (mm⁻²), A, n.
SPENCER_1V = np.array([2.45, 28.595, 4.69, 0.5, 143.0, 83.5, 3.63, 3.63, 301.0, 2.0])
NOISE = {"force_frac": 0.005, "x_mm": 0.001, "v_mm_s": 0.5, "offset_N": 8.0}
MODELS = ("spencer", "switched-bouc-wen")


def write_sines(out: Path) -> float:
    """The sine tests; returns the noise σ (N) they got, for the random record."""
    sigma = None
    for i, (name, amplitude, frequency) in enumerate(TRAIN + (SINE,)):
        test = mr_damper.write_test(
            out / f"{name}.csv",
            amplitude_mm=amplitude,
            frequency_hz=frequency,
            voltage=1.0,
            rate_hz=RATE_HZ,
            cycles=3 if frequency < 2 else 5,
            peak_force_N=None,
            rng=i,
            velocity=True,
            velocity_noise_mm_s=NOISE["v_mm_s"],
            force_noise_frac=NOISE["force_frac"],
        )
        sigma = sigma or NOISE["force_frac"] * test.peak_unscaled_N
    return sigma


def write_random(out: Path, sigma: float, seed: int = 7) -> None:
    """Band-limited random displacement (0.2–3 Hz, peak 20 mm, from rest) and Spencer's force on it."""
    from bwbench.models import excitation, registry

    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 8.0, 1.0 / RATE_HZ)
    freqs = np.linspace(0.2, 3.0, 40)
    x = sum(np.sin(2 * np.pi * f * t + p) / f for f, p in zip(freqs, rng.uniform(0, 2 * np.pi, freqs.size)))
    x -= x[0]
    x *= np.sin(np.pi / 2 * np.clip(t / 0.5, 0, 1)) ** 2  # from rest: x = ẋ = 0 at t = 0
    x *= 20.0 / np.max(np.abs(x))
    v = np.gradient(x, t, edge_order=2)
    a = np.gradient(v, t, edge_order=2)
    force = registry.get("spencer").force_batch(SPENCER_1V[None, :], excitation.Excitation("measured", t, x, v, a))[0]
    f = force + NOISE["offset_N"] + rng.normal(0, sigma, t.size)
    xm = x + rng.normal(0, NOISE["x_mm"], t.size)
    vm = v + rng.normal(0, NOISE["v_mm_s"], t.size)
    rows = "".join(f"{a_:.6f},{b:.5f},{c:.3f},{d:.4f}\n" for a_, b, c, d in zip(t, xm, vm, f))
    (out / f"{RANDOM}.csv").write_text("time_s,displacement_mm,velocity_mm_s,force_N\n" + rows, encoding="utf-8")


def bwbench(*args) -> None:
    subprocess.run([sys.executable, "-m", "bwbench.cli", *map(str, args)], check=True, stdout=subprocess.DEVNULL)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--budget", type=int, default=4100)
    args = parser.parse_args()
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    sigma = write_sines(out)
    write_random(out, sigma)
    train = [out / f"{n}.csv" for n, *_ in TRAIN]
    predicted = [out / f"{SINE[0]}.csv", out / f"{RANDOM}.csv"]
    rows = []
    for model in MODELS:
        for label, files in (("joint: 3 sines", train), ("one sine: 25 mm 1 Hz", train[:1])):
            stem = f"{model}_{'joint' if len(files) > 1 else 'single'}"
            fit = out / f"{stem}.json"
            bwbench(
                "fit",
                *files,
                "--model",
                model,
                "--formulation",
                "identifiable",
                "--optimizer",
                "lsq-trf",
                "--budget",
                args.budget,
                "--seed",
                1,
                "--out",
                fit,
                "--plot",
                out / f"{stem}_fit.png",
            )
            bwbench(
                "predict",
                "--fit",
                fit,
                *predicted,
                "--out",
                out / f"{stem}_predict.json",
                "--plot",
                out / f"{stem}_predict.png",
            )
            fitted = json.loads(fit.read_text())
            predictions = json.loads((out / f"{stem}_predict.json").read_text())["predictions"]
            rows.append(
                (
                    model,
                    label,
                    {f["specimen"]: f["nrmse"] for f in fitted["files"]},
                    {p["specimen"]: p["nrmse"] for p in predictions},
                    fitted["params"].get("m"),
                )
            )
    print(f"noise: force σ = {sigma:.3g} N, velocity 0.5 mm/s, offset 8 N\n")
    print(
        "| model (identifiable) | fitted to | NRMSE on the training files | predicted: 20 mm 1.5 Hz sine | "
        "predicted: random record | m (N·s²/mm) |"
    )
    print("|---|---|---|---|---|---|")
    for model, label, train_nrmse, pred, m in rows:
        fitted_text = ", ".join(f"{n.removeprefix('mr_')} {v:.4f}" for n, v in train_nrmse.items())
        mass = "–" if m is None else f"{m:.3g}"
        print(f"| {model} | {label} | {fitted_text} | {pred[SINE[0]]:.4f} | {pred[RANDOM]:.4f} | {mass} |")


if __name__ == "__main__":
    main()
