"""A whole fit of an MR-damper test against one scipy LSODA simulation of the same test, in the same run.

    .venv/bin/python benchmarks/bench_real_fit.py            # ~5-10 min on 2 busy cores
    .venv/bin/python benchmarks/bench_real_fit.py --quick    # three files, no joint fit
    .venv/bin/python benchmarks/bench_real_fit.py --no-explore   # searches on the model's own simulation

The files, written in a temporary folder as a user's would be and read back through ``bwbench.fit``:

- six sine tests of one damper (Spencer et al. 1997's prototype at 1 V, its own force scale, so
  every file is the same damper) from the project's generator (``bwbench.datasets.mr_damper``), with a
  velocity column (0.5 mm/s noise), 0.5 % force noise, 1 µm displacement noise, an 8 N offset, at
  500 Hz and 1 kHz (two slow tests at 1 kHz: records oversampled for their motion);
- one made another way: a band-limited random displacement (0.2–3 Hz, ±20 mm, 1 kHz, from rest) whose
  force this script simulates with scipy's LSODA (rtol 1e-8) of Spencer's equations, the same noise.

For each file: the wall time of ``bwbench.fit`` (Spencer's model, identifiable, lsq-trf, budget 4,100,
the fit's default early stop; numba's compilation done beforehand, once for all, as a process does
once) and of ONE simulation of the same file by the straightforward scipy model, ``solve_ivp(method=
"LSODA")`` with default tolerances, the measured x and ẋ interpolated linearly, at the fitted
parameters (the fastest of three runs of it). ``--clock cpu`` times both in process CPU time, which
leaves out other processes' time slices on a shared machine. ``--repeat N`` times each fit N times too and
takes the fastest (a fit is the same numbers every time: checked), as the LSODA runs are (the fastest of
max(3, N)): on a shared machine one CPU-time measurement of the same work moves by up to 1.5×. The ratio
fit ÷ simulation is what counts (target: median ≤ 5). Then a joint fit of five
of the sine tests and the prediction of the sixth (NRMSE = RMSE / max|F|), its wall time against one
LSODA simulation of each of the five.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import bwbench
from bwbench.data.specimen import read_specimen
from bwbench.datasets import mr_damper

SINES = (  # name, amplitude mm, frequency Hz, sampling Hz, cycles
    ("mr_25mm_1Hz", 25.0, 1.0, 500.0, 3),
    ("mr_10mm_2.5Hz", 10.0, 2.5, 500.0, 3),
    ("mr_15mm_0.5Hz_1kHz", 15.0, 0.5, 1000.0, 2),
    ("mr_20mm_1.5Hz", 20.0, 1.5, 500.0, 3),
    ("mr_5mm_4Hz_1kHz", 5.0, 4.0, 1000.0, 3),
    ("mr_25mm_0.2Hz_1kHz", 25.0, 0.2, 1000.0, 1),
)
VOLTAGE = 1.0
NOISE = {"force_frac": 0.005, "x_mm": 0.001, "v_mm_s": 0.5, "offset_N": 8.0}
# Spencer et al. (1997) at 1 V in N, mm, s: c0 c1 (N·s/mm), k0 k1 (N/mm), x0 (mm), α (N/mm), β γ (mm⁻²), A, n.
SPENCER_1V = dict(c0=2.45, c1=28.595, k0=4.69, k1=0.5, x0=143.0, alpha=83.5, beta=3.63, gamma=3.63, A=301.0, n=2.0)
DIRECT = ("c0", "c1", "k0", "k1", "x0", "alpha", "beta", "gamma", "A", "n")


def lsoda_force(p: dict, t, x, v, rtol=1e-3, atol=1e-6) -> np.ndarray:
    """Spencer's model as one would first write it: solve_ivp LSODA, x and ẋ interpolated linearly."""
    c0, c1, k0, k1, x0, alpha, beta, gamma, A, n = (p[k] for k in DIRECT)

    def rhs(tt, s):
        xi, vi = np.interp(tt, t, x), np.interp(tt, t, v)
        y, z = s
        yd = (alpha * z + c0 * vi + k0 * (xi - y)) / (c0 + c1)
        u = vi - yd
        return [yd, -gamma * abs(u) * z * abs(z) ** (n - 1) - beta * u * abs(z) ** n + A * u]

    sol = solve_ivp(rhs, (t[0], t[-1]), [x[0], 0.0], method="LSODA", t_eval=t, rtol=rtol, atol=atol)
    if not sol.success or sol.y.shape[1] != len(t):
        return np.full(len(t), np.inf)
    y, z = sol.y
    yd = (alpha * z + c0 * v + k0 * (x - y)) / (c0 + c1)
    return c1 * yd + k1 * (x - x0)


def write_sine(folder: Path, name, amplitude, frequency, rate, cycles, rng) -> Path:
    path = folder / f"{name}.csv"
    params = dict(mr_damper.SPENCER_1997)
    mr_damper.write_test(
        path,
        velocity=True,
        amplitude_mm=amplitude,
        frequency_hz=frequency,
        voltage=VOLTAGE,
        rate_hz=rate,
        cycles=cycles,
        peak_force_N=None,
        force_noise_frac=NOISE["force_frac"],
        displacement_noise_mm=NOISE["x_mm"],
        force_offset_N=NOISE["offset_N"],
        rng=rng,
        params=params,
        velocity_noise_mm_s=NOISE["v_mm_s"],
    )
    return path


def write_random(folder: Path, rng) -> Path:
    """Band-limited random motion from rest, its force by LSODA at rtol 1e-8: not the project's generator."""
    rate, duration = 1000.0, 6.0
    t = np.arange(0.0, duration, 1.0 / rate)
    freqs = np.fft.rfftfreq(len(t), 1.0 / rate)
    spectrum = np.where(
        (freqs >= 0.2) & (freqs <= 3.0), rng.normal(size=freqs.size) + 1j * rng.normal(size=freqs.size), 0
    )
    x = np.fft.irfft(spectrum, len(t))
    x *= np.minimum(1.0, t / 0.5) ** 2  # from rest
    x *= 20.0 / np.max(np.abs(x))
    v = np.gradient(x, t)
    force = lsoda_force(SPENCER_1V, t, x, v, rtol=1e-8, atol=1e-10)
    peak = np.max(np.abs(force))
    f = force + NOISE["offset_N"] + rng.normal(0.0, NOISE["force_frac"] * peak, t.shape)
    xm = x + rng.normal(0.0, NOISE["x_mm"], t.shape)
    vm = v + rng.normal(0.0, NOISE["v_mm_s"], t.shape)
    path = folder / "mr_random_1kHz.csv"
    rows = "".join(f"{a:.6f},{b:.5f},{c:.3f},{d:.4f}\n" for a, b, c, d in zip(t, xm, vm, f))
    path.write_text("time_s,displacement_mm,velocity_mm_s,force_N\n" + rows, encoding="utf-8")
    return path


CLOCK = time.perf_counter  # --clock cpu: time.process_time (a fit runs on one thread)


def timed(fn):
    start = CLOCK()
    out = fn()
    return out, CLOCK() - start


def fastest(fit, repeat: int):
    """(the fit, the fastest of ``repeat`` runs of it); every run must give the same fit."""
    runs = [timed(fit) for _ in range(max(1, repeat))]
    first = runs[0][0]
    assert all(r.nfev == first.nfev and r.mse == first.mse for r, _ in runs), "a fit differed between runs"
    return first, min(seconds for _, seconds in runs)


def simulation_time(path: Path, params: dict, repeat: int = 3) -> float:
    """The fastest of ``repeat`` LSODA simulations of the file (one run is at the mercy of the load)."""
    s = read_specimen(path)
    v = s.v if getattr(s, "v", None) is not None else np.gradient(s.x, s.t)
    return min(timed(lambda: lsoda_force(params, s.t, s.x, v))[1] for _ in range(repeat))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="three files, no joint fit")
    parser.add_argument("--budget", type=int, default=4100)
    parser.add_argument("--stop", choices=("agreed", "budget"), default="agreed")
    parser.add_argument(
        "--coordinates-only",
        action="store_true",
        help="lsq-trf's earlier agreement rule: ends agree by their parameters only (agree_same_fit=false)",
    )
    parser.add_argument(
        "--no-explore",
        action="store_true",
        help="lsq-trf's local searches on the model's own simulation throughout (explore=false: the fit before the exploring searches)",
    )
    parser.add_argument(
        "--repeat",
        type=int,
        default=1,
        help="time each fit this many times and take the fastest, as the LSODA runs (fastest of max(3, N))",
    )
    parser.add_argument(
        "--clock",
        choices=("wall", "cpu"),
        default="wall",
        help="cpu: process CPU time for the fit and the LSODA runs alike (leaves out other processes' time slices)",
    )
    args = parser.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    options = {"agree_same_fit": False} if args.coordinates_only else {}
    if args.no_explore:
        options["explore"] = False
    rng = np.random.default_rng(2027)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        sines = [write_sine(folder, *row, rng) for row in SINES]
        files = sines + [write_random(folder, rng)]
        if args.quick:
            files = [sines[0], sines[2], files[-1]]
        bwbench.fit(sines[1], model="spencer", optimizer="lsq-trf", budget=30)  # compile once, outside the timing
        print(f"{'file':<22} {'samples':>7} {'fit s':>7} {'nfev':>5} {'LSODA s':>8} {'fit/LSODA':>9} {'NRMSE':>7}")
        ratios = []
        for path in files:
            fit, seconds = fastest(
                lambda path=path: bwbench.fit(
                    path,
                    model="spencer",
                    optimizer="lsq-trf",
                    budget=args.budget,
                    seed=1,
                    stop=args.stop,
                    options=options,
                ),
                args.repeat,
            )
            reference = simulation_time(path, {k: fit.params[k] for k in DIRECT}, max(3, args.repeat))
            ratios.append(seconds / reference)
            print(
                f"{path.stem:<22} {fit.files[0]['n']:>7} {seconds:>7.2f} {fit.nfev:>5} {reference:>8.3f} "
                f"{ratios[-1]:>9.1f} {fit.files[0]['nrmse']:>7.4f}",
                flush=True,
            )
        print(f"median fit/LSODA: {np.median(ratios):.1f} (target ≤ 5)")
        if args.quick:
            return
        train, held_out = sines[:5], sines[5]
        joint, seconds = fastest(
            lambda: bwbench.fit(
                *train,
                model="spencer",
                optimizer="lsq-trf",
                budget=args.budget,
                seed=1,
                stop=args.stop,
                options=options,
            ),
            args.repeat,
        )
        reference = sum(simulation_time(p, {k: joint.params[k] for k in DIRECT}, max(3, args.repeat)) for p in train)
        prediction = joint.predict(held_out)
        in_sample = ", ".join(f"{row['nrmse']:.4f}" for row in joint.files)
        print(
            f"joint fit of {len(train)} files: {seconds:.1f} s, {joint.nfev} evaluations, "
            f"{seconds / reference:.1f}× one LSODA simulation of the five ({reference:.2f} s); "
            f"in-sample NRMSE {in_sample}"
        )
        print(f"prediction of {held_out.stem}: NRMSE {prediction.nrmse:.4f}")


if __name__ == "__main__":
    main()
