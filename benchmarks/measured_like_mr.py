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
run from a scratch folder, then a table of NRMSE (RMSE/max F, the literature's, and RMSE/max|F|),
the published parameters' NRMSE on the recorded signals (the analogue of the authors' per-test fit:
the recorded velocity's noise drives the model too, so even they do not reach the force noise), the
searched parameters on a box edge, those on a physical limit, the solved coefficients outside
Spencer's physical bounds (c₀, c₁, k₀, k₁ < 0), and the start-up error (model minus measured force
over the first 2 % of the record, N rms). ``--table FOLDER``: the table of fits already made.
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
SPENCER_1997 = {
    "c0a": 21.0,
    "c0b": 3.50,
    "k0": 46.9,
    "c1a": 283.0,
    "c1b": 2.95,
    "k1": 5.00,
    "x0": 14.3,
    "alpha_a": 140.0,
    "alpha_b": 695.0,
    "gamma": 363.0,
    "beta": 363.0,
    "A": 301.0,
    "n": 2.0,
}
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

    sol = solve_ivp(
        rhs, (t[0], t[-1]), [0.0, 0.0], method="LSODA", t_eval=t, rtol=1e-8, atol=1e-10, max_step=0.05 / f_hz
    )
    if not sol.success:
        raise RuntimeError(sol.message)
    y, z = sol.y
    x, v = excitation(t, amplitude_mm / 10.0, f_hz, cycles_total)
    yd = (alpha * z + c0 * v + k0 * (x - y)) / (c0 + c1)
    return c1 * yd + k1 * (x - x0)


def write_tests(out: Path, tests=TESTS) -> dict:
    """The CSV files of ``tests`` (rows as ``TESTS``) in ``out``; returns {name: (path, noise-free force)}."""
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(SEED)
    made = {}
    for name, a, f_hz, volts, rate, steady, tared in tests:
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


def published_theta(volts: float) -> np.ndarray:
    """Spencer's published parameters at ``volts`` as bwbench's direct vector (N, mm, s)."""
    p = SPENCER_1997
    return np.array(
        [
            (p["c0a"] + p["c0b"] * volts) / 10,
            (p["c1a"] + p["c1b"] * volts) / 10,
            p["k0"] / 10,
            p["k1"] / 10,
            p["x0"] * 10,
            (p["alpha_a"] + p["alpha_b"] * volts) / 10,
            p["beta"] / 100,
            p["gamma"] / 100,
            p["A"],
            p["n"],
        ]
    )


def published_rmse(path: Path, volts: float) -> float:
    """RMSE (N) of the published shape (θ of the published parameters) on the recorded file, through
    bwbench's Spencer model driven by the recorded velocity, c₁, k₁ and f₀ solved (a tared file has its
    own offset): the analogue of the authors' own per-test fit, the floor the recorded signals allow."""
    from bwbench.data.specimen import read_specimen
    from bwbench.models import registry
    from bwbench.problems.hysteresis.model_problem import IdentifiableProblem

    model = registry.get("spencer")
    theta, _ = model.from_direct(published_theta(volts))
    problem = IdentifiableProblem(model, read_specimen(path))
    return float(np.sqrt(problem.loss_batch(theta[None, :])[0]))


def fit_all(made: dict, out: Path, optimizer: str) -> None:
    work = out / "fits"
    work.mkdir(exist_ok=True)
    bwbench = str(Path(sys.executable).with_name("bwbench"))
    volts = {name: v for name, _, _, v, *_ in TESTS}
    rows = []
    for name, (path, _, f_meas) in made.items():
        res = work / f"{name}.json"
        start = time.perf_counter()
        proc = subprocess.run(
            [
                bwbench,
                "fit",
                str(path.resolve()),
                "--model",
                "spencer",
                "--optimizer",
                optimizer,
                "--seed",
                "1",
                "--out",
                str(res),
                "--plot",
                str(work / f"{name}.png"),
            ],
            cwd=work,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - start
        (work / f"{name}.log").write_text(proc.stdout + proc.stderr)
        data = json.loads(res.read_text())
        rows.append(summary(name, path, data, f_meas, published_rmse(path, volts[name]), wall))
    print_table(rows)


def summary(name, path, data, f_meas, published, wall) -> dict:
    """One row of the table: NRMSEs, the start-up error, edges, physical limits of one fit's JSON."""
    from bwbench.problems.hysteresis.fitted_model import FittedModel

    p = data["params"]
    pred = FittedModel.from_result(data).predict(str(path))
    head = max(5, len(f_meas) // 50)  # the first 2 % of the record
    startup = float(np.sqrt(np.mean((pred.force_N[:head] - f_meas[:head]) ** 2)))
    rmse = float(np.sqrt(np.mean((pred.force_N - f_meas) ** 2)))
    physical = set(data.get("physical_limits", {}))
    edges = [k for k in data.get("at_bound", {}) if k not in physical]
    unphysical = [k for k in ("c0", "c1", "k0", "k1") if isinstance(p.get(k), (int, float)) and p[k] < 0]
    return {
        "name": name,
        "nrmse": rmse / np.max(f_meas),
        "nrmse_abs": rmse / np.max(np.abs(f_meas)),
        "published": published / np.max(f_meas),
        "startup": startup,
        "k1": p.get("k1"),
        "x0": p.get("x0"),
        "edges": edges,
        "limits": sorted(physical),
        "unphysical": unphysical,
        "wall": wall,
    }


def print_table(rows) -> None:
    print(
        f"\n{'file':<26} {'NRMSE':>7} {'|F|':>7} {'publ.':>7} {'start N':>8} {'k1 N/mm':>8} {'x0 mm':>8} "
        f"{'wall s':>6}  box edge / on a physical limit / solved < 0"
    )
    for r in rows:
        k1 = f"{r['k1']:.3g}" if isinstance(r["k1"], (int, float)) else "-"
        x0 = f"{r['x0']:.3g}" if isinstance(r["x0"], (int, float)) else "-"
        print(
            f"{r['name']:<26} {r['nrmse']:7.4f} {r['nrmse_abs']:7.4f} {r['published']:7.4f} {r['startup']:8.1f} "
            f"{k1:>8} {x0:>8} {r['wall']:6.0f}  {','.join(r['edges']) or '-'} / {','.join(r['limits']) or '-'} / "
            f"{','.join(r['unphysical']) or '-'}"
        )
    print(
        "NRMSE: RMSE/max F (the literature's); |F|: RMSE/max|F|; publ.: the published parameters' shape on the "
        "recorded signals (RMSE/max F); start: RMSE of the first 2 % of the record (N)"
    )


def table_of(folder: Path, out: Path) -> None:
    """The table of fits already in ``folder`` (JSON per file) against the files in ``out``."""
    volts = {name: v for name, _, _, v, *_ in TESTS}
    rows = []
    for name in volts:
        path, res = out / f"{name}.csv", folder / f"{name}.json"
        if not res.exists():
            continue
        f_meas = np.loadtxt(path, delimiter=",", skiprows=1)[:, 3]
        rows.append(
            summary(name, path, json.loads(res.read_text()), f_meas, published_rmse(path, volts[name]), float("nan"))
        )
    print_table(rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="folder for the CSV files (and fits)")
    parser.add_argument("--fit", action="store_true", help="fit each file with bwbench fit --model spencer")
    parser.add_argument("--optimizer", default="lsq-trf")
    parser.add_argument(
        "--table",
        type=Path,
        metavar="FOLDER",
        help="only print the table of the fits (JSON per file) in FOLDER against the files in --out",
    )
    args = parser.parse_args()
    if args.table:
        table_of(args.table, args.out)
        return
    made = write_tests(args.out)
    if args.fit:
        fit_all(made, args.out, args.optimizer)


if __name__ == "__main__":
    main()
