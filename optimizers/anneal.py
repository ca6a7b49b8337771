"""Generalised simulated annealing (scipy ``dual_annealing``), restarted until the budget is spent.

Algorithm: Tsallis–Stariolo generalised simulated annealing — a heavy-tailed visiting
distribution whose width shrinks with an artificial temperature, with a Metropolis-like
acceptance — with a bounded L-BFGS-B local search (finite-difference gradients) from each new
best point and from time to time otherwise, unless ``no_local_search`` is set (then it is
plain GSA).

Library call: ``scipy.optimize.dual_annealing(f, [(0, 1)] * d, maxiter=maxiter, x0=u0, rng=rng,
no_local_search=...)`` with ``u0`` uniform in the box. ``rng`` (the run's Generator) is passed
straight through (scipy ≥ 1.15 takes ``rng=``), so scipy's draws are part of the run's stream.
scipy's ``maxfun`` is left at its default: scipy calls it a soft limit and overshoots it during
local searches; the objective enforces the budget. When an annealing run ends (``maxiter``
temperature cycles), a new one starts from a fresh random point. scipy evaluates one point at a
time (``batched=False``) and lets the objective's ``BudgetExhausted`` propagate out of both the
annealer and the local search.

Options: ``maxiter`` (1000, scipy's default: annealing iterations per restart; ≥ 1: with 0,
scipy 1.17's ``while not need_to_stop: for i in range(maxiter)`` loops for ever after its first
evaluation, spending no budget), ``no_local_search`` (false). Should a restart evaluate nothing,
the run stops and says so rather than restarting for ever.

+inf losses (model blew up) are given to scipy as 10 × the worst finite loss seen so far: the
local search takes finite-difference gradients, which would be inf or NaN next to a blow-up
region. Before any finite loss has been seen the loss stays +inf, which makes scipy redraw the
starting point (it retries a non-finite start from new random points, up to 1000 times).
"""

from __future__ import annotations

import numpy as np

from bwbench.engine.finite_penalty import WorstFinitePenalty
from bwbench.engine.options import Bool, Int
from bwbench.engine.registry import register


@register(
    "anneal",
    family="annealing",
    description="scipy dual_annealing (generalised simulated annealing + L-BFGS-B), random restarts",
    options={"maxiter": Int(1000, minimum=1), "no_local_search": Bool(False)},
    batched=False,
)
def minimize(objective, *, rng, maxiter=1000, no_local_search=False):
    from scipy.optimize import dual_annealing  # here: scipy.optimize is slow to import

    d = objective.dim
    penalty = WorstFinitePenalty(before_any_finite=np.inf)

    def loss(u):
        return penalty(objective(u))

    while True:  # until the objective raises BudgetExhausted
        spent = objective.nfev
        dual_annealing(
            loss,
            [(0.0, 1.0)] * d,
            maxiter=int(maxiter),
            x0=rng.random(d),
            rng=rng,
            no_local_search=bool(no_local_search),
        )
        if objective.nfev == spent:  # the next restart would do the same: never loop for nothing
            return {"message": "an annealing run evaluated nothing; stopped"}
