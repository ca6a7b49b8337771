"""Which velocity estimator drives the model when a specimen file has no velocity column.

Exact motions (``tests/exact_motions.py``, written independently of the synthetic generator):
triangular ramps at 5 mm/min with half-cosine reversals over 8 s, a sine of ±10 mm and 480 s, and a
band-limited random motion (≤ 1/120 Hz, peak 10 mm). Each is sampled at several rates, gets encoder
noise N(0, σ) and is rounded to 10 nm as the files are written. Every estimator sees only those
samples; its x, ẋ, ẍ then drive the switched model with each of the 15 parameter sets of Tables 6–8,
compared with the same model driven by the exact x, ẋ, ẍ at the same samples (which is within
1e-3 N of the continuous truth). Printed per motion, rate (Hz), noise (µm) and estimator:
RMS and max velocity error (mm/s) and the force RMSE (N) it causes, median and max over the 15 sets,
the time the estimator took, and for the chosen estimator its own error estimate
(``derivatives.velocity_error``); then, per estimator over all cases, how often it is within 1.5× of
the best one's force error, the geometric mean of its ratio to the best, and its worst case.

Run: `.venv/bin/python benchmarks/bench_differentiator.py [--quick]`.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import exact_motions as em  # noqa: E402
from bwbench.datasets.synthetic import read_paper_parameters  # noqa: E402
from bwbench.models import derivatives  # noqa: E402
from bwbench.models.switched import simulation as model  # noqa: E402

RESOLUTION_MM = 1e-5  # the files print displacement with 5 decimals


def _sg(window, order):
    def estimate(t, x):
        from scipy.signal import savgol_filter

        dt = t[1] - t[0]
        return tuple(savgol_filter(x, window, order, deriv=d, delta=dt, mode="interp") for d in (0, 1, 2))

    return estimate


def _interp(k):
    def estimate(t, x):
        from scipy.interpolate import make_interp_spline

        s = make_interp_spline(t, x, k=k)
        return s(t), s(t, 1), s(t, 2)

    return estimate


def _fitpack(k):
    def estimate(t, x):
        from scipy.interpolate import UnivariateSpline

        sigma = derivatives.robust_noise(x)
        s = UnivariateSpline(t, x, k=k, s=len(x) * sigma**2)
        return s(t), s.derivative(1)(t), s.derivative(2)(t)

    return estimate


def _chosen(t, x):
    e = derivatives.estimate(t, x)
    return e.x, e.v, e.a


ESTIMATORS = {
    "SG(9,4)": _sg(9, 4),
    "SG(25,4)": _sg(25, 4),
    "interp k=3": _interp(3),
    "interp k=5": _interp(5),
    "smooth k=3": _fitpack(3),
    "smooth k=5": _fitpack(5),
    "chosen": _chosen,
}


def motions(rng):
    duration = em.ramp_duration() - 0.3  # stop before the crosshead is at rest: ẋ = 0 is a coin toss
    return {
        "ramps": (duration, em.ramp),
        "sine": (1920.0, lambda t: em.sine(t + 17.3)),
        "random": (1920.0, lambda t: em.random_motion(t, np.random.default_rng(7))),
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="ramps only, 1 and 2 Hz")
    args = parser.parse_args()
    truths = [row["params"] for row in read_paper_parameters()]
    rates = (1.0, 2.0) if args.quick else (0.5, 1.0, 2.0, 10.0)
    noises_um = (0.0, 0.1, 1.0) if args.quick else (0.0, 0.1, 1.0, 5.0)
    rng = np.random.default_rng(2024)
    cases = []  # per (motion, rate, noise): {estimator: median force RMSE}
    print(
        f"{'motion':<7} {'Hz':>4} {'noise µm':>8}  {'estimator':<12} {'v rms mm/s':>10} {'v max mm/s':>10} "
        f"{'F rms N med':>11} {'F rms N max':>11} {'ms':>6}  {'v rms predicted':>15}"
    )
    for motion, (duration, exact) in motions(rng).items():
        if args.quick and motion != "ramps":
            continue
        for rate in rates:
            t = np.arange(0.0, duration, 1.0 / rate) + 0.0123  # no sample on a reversal
            x, v, a = exact(t)
            reference = [model.simulate(p, t, x, v, a) for p in truths]
            for noise in noises_um:
                cases.append({})
                x_rec = np.round((x + rng.normal(0.0, noise * 1e-3, x.shape)) / RESOLUTION_MM) * RESOLUTION_MM
                for name, estimator in ESTIMATORS.items():
                    started = time.perf_counter()
                    xs, vs, acc = estimator(t, x_rec)
                    ms = 1e3 * (time.perf_counter() - started)
                    err = vs - v
                    force = [
                        np.sqrt(np.mean((model.simulate(p, t, xs, vs, acc) - f) ** 2))
                        for p, f in zip(truths, reference)
                    ]
                    cases[-1][name] = float(np.median(force))
                    predicted = f"{derivatives.velocity_error(t, x_rec):15.2e}" if name == "chosen" else ""
                    print(
                        f"{motion:<7} {rate:4g} {noise:8g}  {name:<12} {np.sqrt(np.mean(err**2)):10.2e} "
                        f"{np.max(np.abs(err)):10.2e} {np.median(force):11.3f} {np.max(force):11.3f} {ms:6.1f}  "
                        f"{predicted}",
                        flush=True,
                    )
    print(
        f"\nover the {len(cases)} cases: {'within 1.5× of the best':>24} {'geometric mean / best':>22} "
        f"{'worst median F rms N':>21}"
    )
    for name in ESTIMATORS:
        ratios = np.array([case[name] / min(case.values()) for case in cases])
        print(
            f"{name:<12} {int(np.sum(ratios <= 1.5)):>17} of {len(cases):<4} {np.exp(np.mean(np.log(ratios))):22.2f} "
            f"{max(case[name] for case in cases):21.2f}"
        )


if __name__ == "__main__":
    main()
