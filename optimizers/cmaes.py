"""CMA-ES with IPOP restarts (the ``cma`` package, ask/tell).

Algorithm: Hansen's covariance matrix adaptation evolution strategy — sample ``popsize``
points from N(m, σ²C), rank them, move the mean to the weighted best, adapt C and σ — with
the IPOP restart rule (Auger & Hansen 2005): when a run stops on cma's own termination tests
(tolfun, tolx, stagnation, ...), start again from a new uniform random mean with twice the
population.

Library call: ``cma.CMAEvolutionStrategy(u0, sigma0, {"bounds": [0, 1], "popsize": λ, "randn": ...,
"seed": nan, "verbose": -9, "verb_disp": 0, "verb_log": 0, ...})``, then ``X = es.ask()``;
``es.tell(X, objective.batch(X))`` — each population is one batch. cma's default boundary
handling (``BoundTransform``) maps every sample into the box, so no point is clipped.

Randomness: cma's ``seed`` option calls ``np.random.seed`` and samples with the global
``np.random.randn``. Instead ``randn`` is set to draw from the run's Generator and ``seed`` to
NaN ("do nothing"), so the global generator is never touched. Output: by default cma prints
to stdout, writes ``outcmaes/*.dat`` files and reads a ``cma_signals.in`` file from the
working directory if one exists; all three are switched off.

Options: ``sigma0`` (0.3, in unit coordinates: a third of the box; in [1e-11, 1]: the box is 1
wide, and below cma's own ``tolx`` = 1e-11 every run stops after one population — cma divides by
zero at 0 and fails an internal assertion at 1e-308), ``popsize`` (None = cma's default
4 + ⌊3 ln d⌋; else 2 to 1,000: cma's recombination weights need two points; doubled at each
restart). Should a restart stop before asking for a population, the run ends with a message
instead of doubling the population for ever without evaluating anything.

+inf losses are given to cma as 1e300. CMA-ES uses only the ranking of a population, so any
value above every finite loss would do; cma does accept inf, but its termination tests take
fitness ranges (max − min) and warn on inf − inf. A population that blew up entirely ends the
run on ``tolflatfitness`` and triggers a restart, as with inf.
"""

from __future__ import annotations

import numpy as np

from bwbench.engine.options import Float, Int
from bwbench.engine.registry import register


@register(
    "cmaes",
    family="evolution-strategy",
    description="CMA-ES (cma package, ask/tell) on the unit box, IPOP restarts doubling the population",
    options={
        "sigma0": Float(0.3, minimum=1e-11, maximum=1.0),
        "popsize": Int(None, minimum=2, maximum=1000, none="cma's default, 4 + ⌊3 ln d⌋"),
    },
)
def minimize(objective, *, rng, sigma0=0.3, popsize=None):
    import cma  # here, not at module level: it pulls in matplotlib and scipy.stats (slow to import in every worker)

    d = objective.dim

    def randn(*shape):  # cma's randn(lam, N) contract, drawn from the run's Generator
        return rng.standard_normal(shape)

    popsize = int(popsize) if popsize else 4 + int(3 * np.log(d))
    while True:  # until the objective raises BudgetExhausted
        spent = objective.nfev
        es = cma.CMAEvolutionStrategy(
            rng.random(d),
            sigma0,
            {
                "bounds": [0.0, 1.0],
                "popsize": popsize,
                "randn": randn,
                "seed": np.nan,
                "verbose": -9,
                "verb_disp": 0,
                "verb_log": 0,
                "signals_filename": "",
            },
        )
        while not es.stop():
            X = es.ask()
            losses = objective.batch(np.asarray(X))
            es.tell(X, np.where(np.isfinite(losses), losses, 1e300))
        if objective.nfev == spent:  # the next restart would do the same: never loop for nothing
            return {"message": f"cma stopped before asking for points ({', '.join(es.stop())}); stopped"}
        popsize *= 2
