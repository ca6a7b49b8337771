"""Posterior engines on one specimen at one budget: do independent runs agree, and at what cost?

Run by hand (never by CI), one core, ~10-40 min per engine:

    .venv/bin/python benchmarks/bench_posterior_engines.py                      # nested, the default
    .venv/bin/python benchmarks/bench_posterior_engines.py --engines nested,pocomc --budget 1000000

For each engine, ``--runs`` independent runs from independent seeds share ``--budget`` evaluations of the
switched model's identifiable likelihood (σ integrated out, as a study's ``[posterior]`` samples it) on
``--specimen``; each run's equal-weight draws are one chain of ``bwbench.analysis.nested.assess``, the
report's own verdict (rank-normalised split-R̂ ≤ 1.01 and bulk ESS ≥ 400 for every parameter, ln Z and
mode masses agreeing between runs, no run cut). It prints evaluations, wall time, each run's ln Z with
its stated error, the worst R̂ and least bulk ESS, and each parameter's posterior mean per run (unit
coordinates of the box): runs that agree on R̂ can still all be wrong, so compare engines' means too.

Engines: ``nested`` (the project's backend, UltraNest) and ``pocomc`` (preconditioned Monte Carlo:
tempered SMC whose moves run in the coordinates of a normalising flow trained on the particles; not a
project dependency — it needs ``pip install torch==2.13.0 pocomc`` in the venv, and is skipped
otherwise). docs/posterior.md has what they measured.
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import resource
import time
from pathlib import Path

import numpy as np

from bwbench.analysis import posterior_verdict
from bwbench.data.specimen import read_specimen
from bwbench.engine import fitting
from bwbench.engine.objective import Objective
from bwbench.optimizers.nested_sampler import equal_weight_draws
from bwbench.problems.hysteresis.formulations import make_problem
from bwbench.threads import limited

REPO = Path(__file__).resolve().parents[1]
SETTINGS = {"state": "shared", "excitation": "measured", "formulation": "identifiable"}


def run_nested(problem, budget, runs, seed, options):
    extras = fitting.run(problem, "nested", budget, seed, {"runs": runs, **options}).extras
    return extras, sum(extras["run_nfev"])


def run_pocomc(problem, budget, runs, seed, options):
    import pocomc
    import scipy.stats
    import torch

    objective = Objective(problem, budget)

    def log_like(U):
        like = objective.batch_with_likelihood(np.atleast_2d(U))[1]
        return np.where(np.isfinite(like), like, -1e300)

    torch.set_num_threads(1)
    chains, probs, log_z, log_z_err, rng = [], [], [], [], np.random.default_rng(seed)
    for k in range(runs):
        torch.manual_seed(seed + k)
        prior = pocomc.Prior([scipy.stats.uniform(0, 1)] * problem.dim)
        sampler = pocomc.Sampler(prior, log_like, vectorize=True, random_state=seed + k, **options)
        sampler.run(progress=False)
        x, w, logl, _ = sampler.posterior()
        z, err = sampler.evidence()
        w = w / w.sum()
        index = equal_weight_draws(x, w, int(1 / (w @ w)), rng)
        chains.append(x[index])
        probs.append(logl[index])
        log_z.append(float(z))
        log_z_err.append(float(err))
    size = min(len(c) for c in chains)
    extras = {
        "chain": np.stack([c[:size] for c in chains], axis=1),
        "log_prob": np.stack([p[:size] for p in probs], axis=1),
        "log_z": log_z,
        "log_z_err": log_z_err,
    }
    return extras, objective.nfev


ENGINES = {"nested": run_nested, "pocomc": run_pocomc}


def cpu_seconds() -> float:
    """CPU time of this process and of its finished children (the forked workers of ``--workers``)."""
    own, children = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def verdict_of(problem, extras):
    """The report's verdict (``posterior_verdict.judge``) on an engine's runs."""
    from bwbench.problems.hysteresis.report.posterior_draws import parameters

    table = parameters(problem)
    names = list(problem.param_names)
    return posterior_verdict.judge(
        extras["chain"],
        extras["log_prob"],
        extras["log_z"],
        extras["log_z_err"],
        names,
        complete=extras.get("run_complete"),
        ess=extras.get("run_ess"),
        insertion=extras.get("insertion"),
        run_nfev=extras.get("run_nfev"),
        steps=extras.get("run_steps"),
        from_unit=problem.from_unit,
        labels=[f"{table[n][0]} ({table[n][1]})" for n in names],
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specimen", default="pom-mt24u01_0.05MPa_r1")
    parser.add_argument("--engines", default="nested")
    parser.add_argument("--budget", type=int, default=6_000_000)
    parser.add_argument("--runs", type=int, default=4, help="runs (nested: the first round; more are added)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--workers", type=int, default=1, help="processes running runs side by side (nested)")
    parser.add_argument("--state", choices=("shared", "split"), default="shared", help="the switched model's state")
    parser.add_argument(
        "--options", default="{}", help="the engine's options as JSON, e.g. '{\"live_points\": 400}' (nested)"
    )
    parser.add_argument("--save", help="write each engine's extras to SAVE_<engine>.pkl (for the profile script)")
    args = parser.parse_args()
    path = (
        Path(args.specimen) if args.specimen.endswith(".csv") else REPO / "data" / "specimens" / f"{args.specimen}.csv"
    )
    problem = make_problem(read_specimen(path), {**SETTINGS, "state": args.state})
    names = list(problem.param_names)
    print(f"load average at start: {', '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    for engine in args.engines.split(","):
        options = json.loads(args.options)
        if engine == "nested":
            options.setdefault("workers", args.workers)
        try:
            with limited(1):
                started, cpu = time.perf_counter(), cpu_seconds()
                extras, nfev = ENGINES[engine](problem, args.budget, args.runs, args.seed, options)
                wall, cpu = time.perf_counter() - started, cpu_seconds() - cpu
        except ImportError as error:
            print(f"{engine}: skipped ({error})")
            continue
        if args.save:
            with open(f"{args.save}_{engine}.pkl", "wb") as handle:
                pickle.dump(
                    {"extras": extras, "nfev": nfev, "wall": wall, "cpu": cpu, "specimen": args.specimen}, handle
                )
        verdict = verdict_of(problem, extras)
        chain = extras["chain"]
        print(
            f"\n{engine}: {nfev:,} evaluations, {wall:.0f} s wall, {cpu:.0f} s CPU ({nfev / max(cpu, 1e-9):,.0f} "
            f"evaluations per CPU second), {chain.shape[1]} runs × {chain.shape[0]} draws"
        )
        print(f"  load average at end: {', '.join(f'{x:.1f}' for x in os.getloadavg())}")
        print("  " + verdict.line)
        for check in verdict.checks:
            print(f"  [{'pass' if check.passed else 'FAIL' if check.passed is False else ' -- '}] {check.detail}")
        print("  " + verdict.badge["text"])
        print(
            "  ln Z per run: " + ", ".join(f"{z:.2f} ± {e:.2f}" for z, e in zip(extras["log_z"], extras["log_z_err"]))
        )
        if "run_nfev" in extras:
            print("  evaluations per run: " + ", ".join(f"{n:,}" for n in extras["run_nfev"]))
        print("  precision (SE from the runs' scatter, in posterior sd of the searched coordinate; target ≤ 0.1):")
        for r in verdict.precision.itertuples():
            print(
                f"    {r.parameter:>14}: mean {r.mean_physical:.4g} ± {r.se_mean:.2f} sd, 5 % {r.q05_physical:.4g} ± "
                f"{r.se_q05:.2f}, 95 % {r.q95_physical:.4g} ± {r.se_q95:.2f} (runs' means "
                f"{r.run_mean_min_physical:.4g}–{r.run_mean_max_physical:.4g})"
            )
        print("  regions (mass ± SE from the runs' scatter; target ≤ 0.05):")
        for region in verdict.regions:
            print(f"    {region.label}: {region.mass:.2f} ± {region.se:.3f} ({region.spread})")
        if verdict.needed:
            print(f"  needed: {verdict.needed}")
        for j, name in enumerate(names):
            print(f"  {name:>5} mean per run (unit): " + ", ".join(f"{m:.3f}" for m in chain[:, :, j].mean(axis=0)))


if __name__ == "__main__":
    main()
