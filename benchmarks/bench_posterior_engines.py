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
import time
from pathlib import Path

import numpy as np

from bwbench.analysis import nested
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
    return extras["chain"], extras["log_prob"], extras["log_z"], extras["log_z_err"], sum(extras["run_nfev"])


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
    return (
        np.stack([c[:size] for c in chains], axis=1),
        np.stack([p[:size] for p in probs], axis=1),
        log_z,
        log_z_err,
        objective.nfev,
    )


ENGINES = {"nested": run_nested, "pocomc": run_pocomc}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--specimen", default="pom-mt24u01_0.05MPa_r1")
    parser.add_argument("--engines", default="nested")
    parser.add_argument("--budget", type=int, default=1_000_000)
    parser.add_argument("--runs", type=int, default=4)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--state", choices=("shared", "split"), default="shared", help="the switched model's state")
    parser.add_argument(
        "--options", default="{}", help="the engine's options as JSON, e.g. '{\"live_points\": 400}' (nested)"
    )
    args = parser.parse_args()
    problem = make_problem(
        read_specimen(REPO / "data" / "specimens" / f"{args.specimen}.csv"), {**SETTINGS, "state": args.state}
    )
    names = list(problem.param_names)
    for engine in args.engines.split(","):
        try:
            with limited(1):
                started = time.perf_counter()
                chain, log_prob, log_z, log_z_err, nfev = ENGINES[engine](
                    problem, args.budget, args.runs, args.seed, json.loads(args.options)
                )
                wall = time.perf_counter() - started
        except ImportError as error:
            print(f"{engine}: skipped ({error})")
            continue
        verdict = nested.assess(chain, log_prob, log_z, log_z_err, names)
        table = verdict["diagnostics"]
        print(f"\n{engine}: {nfev:,} evaluations, {wall:.0f} s, {chain.shape[0]} draws per run")
        print("  ln Z per run: " + ", ".join(f"{z:.2f} ± {e:.2f}" for z, e in zip(log_z, log_z_err)))
        print(f"  worst R̂ {table['r_hat'].max():.3f}, least bulk ESS {table['ess_bulk'].min():.0f}")
        print("  " + verdict["message"])
        for j, name in enumerate(names):
            print(f"  {name:>5} mean per run: " + ", ".join(f"{m:.3f}" for m in chain[:, :, j].mean(axis=0)))


if __name__ == "__main__":
    main()
