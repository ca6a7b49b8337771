"""Measured-like MR-damper tests that bwbench did not make, and Spencer fits of them as an engineer runs them.

    .venv/bin/python benchmarks/measured_like_mr.py --out /tmp/mlike            # write the files only
    nice -n 5 .venv/bin/python benchmarks/measured_like_mr.py --out /tmp/mlike --fit   # and fit each (~1-3 min)

The force is Spencer, Dyke, Sain & Carlson (1997)'s model at its published values (the paper's
table, in its own units cm, s, N, V; ``SPENCER_1997`` below), integrated by scipy's ``solve_ivp``
(LSODA, rtol 1e-8) — not bwbench's kernel nor its generator. Each test is what a damper rig records:

- the damper at rest at t = 0 (x = ẋ = 0, internal state y = z = 0), a sine whose amplitude ramps
  in over the first cycle and out over the last (a raised-cosine envelope), steady cycles between;
- amplitudes 5–25 mm, 0.5–4 Hz, 0–2.25 V, sampled at 200 Hz–1 kHz;
- a velocity channel (the exact ẋ plus noise), encoder noise on x, load-cell noise on F; half the
  files have the load cell tared at rest (the accumulator preload k₁·x₀ removed), the others not.

``--fit``: ``bwbench fit --model spencer --optimizer lsq-trf`` of each file (seed 1, default budget),
run from a scratch folder, then a table of NRMSE (RMSE/max|F| and RMSE/max F), the truth's own
NRMSE on the noisy record (the floor), the searched parameters on a box edge, the solved
coefficients outside Spencer's physical bounds (c₀, c₁, k₀, k₁ < 0), and the start-up error (model
minus measured force over the first 2 % of the record, N rms).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

# Spencer et al. (1997), Table 1, in N, cm, s, V (c·a + c·b·u with the voltage u held constant).
SPENCER_1997 = {"c0a": 21.0, "c0b": 3.50, "k0": 46.9, "c1a": 283.0, "c1b": 2.95, "k1": 5.00, "x0": 14.3,
                "alpha_a": 140.0, "alpha_b": 695.0, "gamma": 363.0, "beta": 363.0, "A": 301.0, "n": 2.0}
# name, amplitude mm, frequency Hz, voltage V, sampling Hz, steady cycles, tared load cell
TESTS = (
    ("rig_a10_f2_v1_500Hz", 10.0, 2.0, 1.0, 500.0, 3, True),
    ("rig_a25_f1_v2.25_200Hz", 25.0, 1.0, 2.25, 200.0, 3, False),
    ("rig_a5_f4_v0.5_1kHz", 5.0, 4.0, 0.5, 1000.0, 4, True),
    ("rig_a15_f2.5_v2.25_1kHz", 15.0, 2.5, 2.25, 1000.0, 3, False),
    ("rig_a20_f0.5_v1.5_200Hz", 20.0, 0.5, 1.5, 200.0, 2, True),
    ("rig_a8_f3_v0_500Hz", 8.0, 3.0, 0.0, 500.0, 3, False),
)
FORCE_NOISE_FRAC = 0.005  # of the peak |F|
X_NOISE_MM = 0.002
V_NOISE_FRAC = 0.005  # of the peak |ẋ|
SEED = 30


def excitation(t, amplitude_mm, f_hz, cycles_total):
    """x (mm) and ẋ (mm/s) of a sine whose amplitude ramps in over the first cycle and out over the last."""
    T = 1.0 / f_hz
    end = cycles_total * T
    w = 2 * math.pi * f_hz
    t = np.asarray(t, dtype=float)
    env = np.ones_like(t)
    denv = np.zeros_like(t)
    up, down = t < T, t > end - T
    env[up] = 0.5 * (1 - np.cos(math.pi * t[up] / T))
    denv[up] = 0.5 * math.pi / T * np.sin(math.pi * t[up] / T)
    s = end - t[down]
    env[down] = 0.5 * (1 - np.cos(math.pi * s / T))
    denv[down] = -0.5 * math.pi / T * np.sin(math.pi * s / T)
    x = amplitude_mm * env * np.sin(w * t)
    v = amplitude_mm * (denv * np.sin(w * t) + env * w * np.cos(w * t))
    return x, v


def spencer_force(t, amplitude_mm, f_hz, cycles_total, volts):
    """Spencer's force (N) at the times t, from rest, by LSODA in the paper's units (cm)."""
    p = SPENCER_1997
    c0, c1 = p["c0a"] + p["c0b"] * volts, p["c1a"] + p["c1b"] * volts
    alpha = p["alpha_a"] + p["alpha_b"] * volts
    k0, k1, x0, A, n, beta, gamma = p["k0"], p["k1"], p["x0"], p["A"], p["n"], p["beta"], p["gamma"]

    def drive(tt):
        x, v = excitation(np.array([tt]), amplitude_mm / 10.0, f_hz, cycles_total)
        return x[0], v[0]

    def rhs(tt, s):
        y, z = s
        x, v = drive(tt)
        yd = (alpha * z + c0 * v + k0 * (x - y)) / (c0 + c1)
        u = v - yd
        zd = -gamma * abs(u) * z * abs(z) ** (n - 1) - beta * u * abs(z) ** n + A * u
        return [yd, zd]

    sol = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], method="LSODA", t_eval=t, rtol=1e-8, atol=1e-10,
                    max_step=0.05 / f_hz)
    if not sol.success:
        raise RuntimeError(sol.message)
    y, z = sol.y
    x, v = excitation(t, amplitude_mm / 10.0, f_hz, cycles_total)
    yd = (alpha * z + c0 * v + k0 * (x - y)) / (c0 + c1)
    return c1 * yd + k1 * (x - x0)


def write_tests(out: Path) -> dict:
    """The CSV files of ``TESTS`` in ``out``; returns {name: (path, noise-free force)}."""
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    made = {}
    for name, a, f_hz, volts, rate, steady, tared in TESTS:
        cycles = steady + 2
        t = np.arange(0.0, cycles / f_hz + 0.5 / rate, 1.0 / rate)
        x, v = excitation(t, a, f_hz, cycles)
        F = spencer_force(t, a, f_hz, cycles, volts)
        if tared:
            F = F - F[0]
        peak = float(np.max(np.abs(F)))
        f_meas = F + rng.normal(0, FORCE_NOISE_FRAC * peak, len(t))
        x_meas = x + rng.normal(0, X_NOISE_MM, len(t))
        v_meas = v + rng.normal(0, V_NOISE_FRAC * np.max(np.abs(v)), len(t))
        path = out / f"{name}.csv"
        with open(path, "w") as fh:
            fh.write("time_s,displacement_mm,velocity_mm_s,force_N\n")
            for row in zip(t, x_meas, v_meas, f_meas):
                fh.write(f"{row[0]:.6f},{row[1]:.5f},{row[2]:.4f},{row[3]:.3f}\n")
        made[name] = (path, F, f_meas)
        print(f"{name}: {len(t)} samples, peak |F| {peak:.0f} N, F(0) measured {f_meas[0]:.1f} N")
    return made


def fit_all(made: dict, out: Path, optimizer: str) -> None:
    work = out / "fits"
    work.mkdir(exist_ok=True)
    bwbench = str(Path(sys.executable).with_name("bwbench"))
    rows = []
    for name, (path, F_true, f_meas) in made.items():
        res = work / f"{name}.json"
        start = time.perf_counter()
        proc = subprocess.run([bwbench, "fit", str(path.resolve()), "--model", "spencer", "--optimizer", optimizer,
                               "--seed", "1", "--out", str(res), "--plot", str(work / f"{name}.png")],
                              cwd=work, capture_output=True, text=True)
        wall = time.perf_counter() - start
        (work / f"{name}.log").write_text(proc.stdout + proc.stderr)
        data = json.loads(res.read_text())
        p = data["params"]
        # the start-up error: the fitted force minus the measured over the first 2 % of the record
        from bwbench.problems.fitted_model import FittedModel

        pred = FittedModel.from_result(data).predict(str(path))
        head = max(5, len(f_meas) // 50)
        startup = float(np.sqrt(np.mean((pred.force_N[:head] - f_meas[:head]) ** 2)))
        truth = float(np.sqrt(np.mean((F_true - f_meas) ** 2)))
        rmse = float(np.sqrt(np.mean((pred.force_N - f_meas) ** 2)))
        edges = [k for k in data.get("at_bound", {})]
        unphysical = [k for k in ("c0", "c1", "k0", "k1") if isinstance(p.get(k), (int, float)) and p[k] < 0]
        rows.append((name, rmse / np.max(np.abs(f_meas)), rmse / np.max(f_meas), truth / np.max(np.abs(f_meas)),
                     edges, unphysical, p.get("k1"), p.get("x0"), startup, wall))
    print(f"\n{'file':<26} {'NRMSE|F|':>8} {'NRMSE F+':>8} {'truth':>7} {'start N':>8} {'k1 N/mm':>8} "
          f"{'x0 mm':>9} {'wall s':>6}  on edge / unphysical")
    for r in rows:
        k1 = f"{r[6]:.3g}" if isinstance(r[6], (int, float)) else "-"
        x0 = f"{r[7]:.3g}" if isinstance(r[7], (int, float)) else "-"
        print(f"{r[0]:<26} {r[1]:8.4f} {r[2]:8.4f} {r[3]:7.4f} {r[8]:8.1f} {k1:>8} {x0:>9} {r[9]:6.1f}  "
              f"{','.join(r[4]) or '-'} / {','.join(r[5]) or '-'}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the CSV files (and fits)")
    parser.add_argument("--fit", action="store_true", help="fit each file with bwbench fit --model spencer")
    parser.add_argument("--optimizer", default="lsq-trf")
    args = parser.parse_args()
    made = write_tests(args.out)
    if args.fit:
        fit_all(made, args.out, args.optimizer)


if __name__ == "__main__":
    main()
