"""The cost of bounds on the solved linear coefficients: the linear solve with and without them.

    .venv/bin/python benchmarks/bench_linear_bounds.py [--rows 32] [--repeat 7]

On an MR-damper sine test of ``bwbench.datasets.mr_damper`` (25 mm, 1 Hz, 1 V, 1,501 samples, recorded
velocity) and on three such tests stacked (a joint fit, 3,502 samples), the switched model's
trajectories of ``--rows`` θ drawn in its identifiable box are solved by ``LinearDesign.solve``:

- unbounded: no bound at all (the path before bounds existed);
- bounds, none active: bounds of ±10¹² on every coefficient, which no row breaks: what an evaluation
  pays for the check alone;
- physical bounds: m in [0, 1] and c± ≥ 0 (``linear_bounds.physical_bounds``), which random θ often break;
- tight bounds on every coefficient (10 % of its median size), broken by every row: the worst case,
  most rows going to BVLS (``lsq_linear``) on their p × p triangular system.

Prints the median time per row of each (the simulation of the row is not included) and its ratio to
the unbounded solve in the same run, and for scale the time of one simulation of the model. Then
whole fits, what a user waits for: ``lsq-trf`` on the single test at ``--budget`` evaluations with
the physical bounds (the default) and with every bound removed, alternated ``--fits`` times; the
median wall time of each, their ratio, and the share of evaluated rows the bounds re-solved.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from bwbench import threads
from bwbench.datasets import mr_damper
from bwbench.models import excitation
from bwbench.models.switched.model import LAYOUT, MODEL
from bwbench.problems.hysteresis.joint_problem import stack_signals
from bwbench.problems.hysteresis.linear import solve as ls
from bwbench.problems.hysteresis.linear.bounds import physical_bounds


def record(amplitude, frequency, seed):
    test = mr_damper.sine_test(
        amplitude_mm=amplitude,
        frequency_hz=frequency,
        voltage=1.0,
        rate_hz=500.0,
        cycles=3 if frequency <= 1 else 2,
        peak_force_N=None,
        rng=seed,
        velocity_noise_mm_s=0.5,
    )
    return excitation.measured(test.t, test.x, test.v), test.f


def per_row(function, rows: int, repeat: int) -> float:
    function()  # compile and warm up
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return float(np.median(times)) / rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=int, default=32)
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--budget", type=int, default=4100)
    parser.add_argument("--fits", type=int, default=3)
    args = parser.parse_args()
    parts = [record(25.0, 1.0, 0), record(10.0, 2.5, 1), record(15.0, 0.5, 2)]
    cases = {"one test": parts[:1], "three tests stacked": parts}
    with threads.limited(1):
        for name, chosen in cases.items():
            signals = [s for s, _ in chosen]
            e = signals[0] if len(signals) == 1 else stack_signals(signals)
            f = np.concatenate([f for _, f in chosen])
            box = MODEL.hysteretic_box(signals[0], chosen[0][1], "shared")
            theta = box.from_unit(np.random.default_rng(0).uniform(0.2, 0.8, size=(args.rows, box.lower.size)))
            Z = np.concatenate([MODEL.trajectories(theta, s, "shared") for s in signals], axis=1)
            Z = Z[np.all(np.isfinite(Z), axis=1)]
            rows = len(Z)
            physical, _ = physical_bounds(LAYOUT, e, f, ls.coefficient_units(LAYOUT))
            unbounded = ls.LinearDesign(e, f, LAYOUT, fix_mass=None, mass_min=None)
            free = unbounded.solve(Z)
            loose = ls.LinearDesign(
                e, f, LAYOUT, fix_mass=None, bounds={n: (-1e12, 1e12) for n in unbounded.free_names}
            )
            bounded = ls.LinearDesign(e, f, LAYOUT, fix_mass=None, bounds=physical)
            # tight bounds every row breaks: each coefficient held to 10 % of its median unbounded size
            size = 0.1 * np.median(np.abs(free.coef_ls), axis=0)
            tight = ls.LinearDesign(
                e, f, LAYOUT, fix_mass=None, bounds={n: (-s, s) for n, s in zip(unbounded.free_names, size)}
            )
            # (default arguments bind this iteration's objects: each lambda is timed before the next)
            t_free = per_row(lambda d=unbounded, Z=Z: d.solve(Z), rows, args.repeat)
            t_loose = per_row(lambda d=loose, Z=Z: d.solve(Z), rows, args.repeat)
            t_physical = per_row(lambda d=bounded, Z=Z: d.solve(Z), rows, args.repeat)
            t_active = per_row(lambda d=tight, Z=Z: d.solve(Z), rows, args.repeat)
            t_sim = per_row(lambda th=theta, s=signals[0]: MODEL.trajectories(th, s, "shared"), len(theta), args.repeat)
            print(
                f"{name} ({len(f):,} samples, {rows} rows of random θ; the physical bounds re-solve "
                f"{int(bounded.solve(Z).bound_active.sum())}, the tight ones {int(tight.solve(Z).bound_active.sum())}):"
            )
            print(f"  unbounded solve                    {t_free * 1e6:9.1f} µs/row   1.00×")
            print(f"  bounds, none active (the check)    {t_loose * 1e6:9.1f} µs/row   {t_loose / t_free:.2f}×")
            print(f"  physical bounds (m, c±)            {t_physical * 1e6:9.1f} µs/row   {t_physical / t_free:.2f}×")
            print(f"  tight bounds on every coefficient  {t_active * 1e6:9.1f} µs/row   {t_active / t_free:.2f}×")
            print(f"  for scale: one simulation of the first test {t_sim * 1e6:9.1f} µs/row")
        whole_fits(parts[0], args.budget, args.fits)


def whole_fits(part, budget: int, fits: int) -> None:
    """lsq-trf with the default (physical) bounds and with none, alternated; medians and their ratio."""
    from bwbench.data.specimen import Specimen
    from bwbench.engine import fitting
    from bwbench.problems.hysteresis.model_problem import IdentifiableProblem

    e, f = part
    spec = Specimen("mr_25mm_1Hz.csv", "mr_25mm_1Hz", e.t, e.x_recorded, f, v=e.v)
    open_bounds = {n: (-np.inf, np.inf) for n in ("m", "c+", "c-")}
    active = {}
    cases = [
        (f"{label}, {bounds}", mass, given)
        for label, mass in (("m fitted", None), ("m by the rule", "auto"))
        for bounds, given in (("physical bounds", None), ("no bounds", open_bounds))
    ]
    times = {name: [] for name, _, _ in cases}
    for _ in range(fits):
        for name, mass, given in cases:
            problem = IdentifiableProblem(MODEL, spec, "shared", fix_mass=mass, coefficient_bounds=given)
            counted = _count_active(problem)
            start = time.perf_counter()
            result = fitting.run(problem, "lsq-trf", budget, 1)
            times[name].append(time.perf_counter() - start)
            active[name] = (counted["active"] / max(counted["rows"], 1), result.rmse_N)
    print(f"whole fit, lsq-trf, {budget} evaluations (median of {fits}, alternated):")
    for name, values in times.items():
        base = float(np.median(times[name.split(",")[0] + ", no bounds"]))
        share, rmse = active[name]
        print(
            f"  {name:<32} {np.median(values):7.2f} s   {np.median(values) / base:.2f}×   rows re-solved "
            f"{share:.0%}, RMSE {rmse:.3g} N"
        )


def _count_active(problem) -> dict:
    """Wrap ``problem.design.solve`` to count the rows it solved and those the bounds re-solved."""
    counted = {"rows": 0, "active": 0}
    solve = problem.design.solve

    def counting(Z, residual=False):
        out = solve(Z, residual)
        counted["rows"] += len(out.mse)
        counted["active"] += int(out.bound_active.sum())
        return out

    problem.design.solve = counting
    return counted


if __name__ == "__main__":
    main()
