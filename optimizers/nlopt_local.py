"""NLopt derivative-free local optimisers with random restarts: BOBYQA, Sbplx, Nelder-Mead.

Algorithms (one backend each, same restart scheme):
- ``nlopt-bobyqa``: Powell's BOBYQA, a trust region over quadratic interpolation models.
- ``nlopt-sbplx``: Rowan's Subplex, Nelder-Mead on a sequence of low-dimensional subspaces.
- ``nlopt-neldermead``: the Nelder-Mead simplex with NLopt's bound handling.

Library call: ``nlopt.opt(ALGORITHM, d)`` with bounds [0, 1], ``set_min_objective``,
``set_xtol_rel``/``set_ftol_rel``/``set_maxeval`` (stopping tests of ONE local search), then
``optimize(u0)`` from ``u0`` uniform in the box; when a local search stops, the next starts
from a new uniform point, until the budget is spent. NLopt's own ``maxeval`` is never used as
the budget. ``BudgetExhausted`` is never raised through NLopt: NLopt usually force-stops and
re-raises a Python exception from its objective, but nlopt 2.11's BOBYQA sometimes (26 of
~3100 cut points tried, 14-D, shortly after its initial 2d+1 points) reports XTOL_REACHED
instead of FORCED_STOP, and the Python wrapper then turns the pending exception into
``SystemError: ... returned a result with an exception set``. So once the objective is spent,
``loss`` calls ``opt.force_stop()`` and returns the penalty without evaluating anything, and
the restart loop raises ``BudgetExhausted`` itself when ``optimize`` returns (or raises
``nlopt.ForcedStop``), whatever NLopt's return code. These three algorithms draw no random
numbers, so the run's randomness is only the starting points, drawn from ``rng``. The
objective is called one point at a time (``batched=False``).

Options: ``xtol_rel`` (1e-6) and ``ftol_rel`` (1e-8), each ≥ 0 (0: that test is off; NLopt also
reads a negative value as off, refused here as most likely a typo), ``maxeval`` (0 = no limit per
local search; at most 2³¹ − 1, NLopt's C int). A local search that evaluates nothing ends the
run with a message instead of being restarted for ever.

+inf losses are given to NLopt as 10 × the worst finite loss seen so far (1e300 before any):
BOBYQA fits quadratic models to the values, and with an inf among them it stops after its
initial points reporting XTOL_REACHED. A local search that fails inside NLopt (round-off
limited, an invalid model) just ends that restart.
"""

from __future__ import annotations

import nlopt
import numpy as np

from bwbench.engine.finite_penalty import WorstFinitePenalty
from bwbench.engine.options import Float, Int
from bwbench.engine.registry import register
from bwbench.errors import BudgetExhausted

_OPTIONS = {
    "xtol_rel": Float(1e-6, minimum=0.0),
    "ftol_rel": Float(1e-8, minimum=0.0),
    "maxeval": Int(0, minimum=0, maximum=2**31 - 1),
}


def _restarted_local_search(algorithm, objective, rng, xtol_rel, ftol_rel, maxeval):
    d = objective.dim
    penalty = WorstFinitePenalty(before_any_finite=1e300)
    opt = None

    def loss(u, grad):  # grad is empty: derivative-free algorithms only
        if objective.exhausted:  # stop NLopt ourselves: an exception through it can get lost
            opt.force_stop()
            return penalty.value
        return penalty(objective(u))

    while True:
        spent = objective.nfev
        opt = nlopt.opt(algorithm, d)
        opt.set_lower_bounds(np.zeros(d))
        opt.set_upper_bounds(np.ones(d))
        opt.set_min_objective(loss)
        opt.set_xtol_rel(xtol_rel)
        opt.set_ftol_rel(ftol_rel)
        opt.set_maxeval(int(maxeval))
        try:
            opt.optimize(rng.random(d))
        except (nlopt.ForcedStop, nlopt.RoundoffLimited, RuntimeError, ValueError):
            pass  # ours, or a failed local search (restart elsewhere)
        if objective.exhausted:
            raise BudgetExhausted(f"budget of {objective.budget} evaluations is spent")
        if objective.nfev == spent:  # the next restart would do the same: never loop for nothing
            return {"message": "a local search evaluated nothing; stopped"}


def _backend(name, algorithm, description):
    @register(name, family="local", description=description, options=_OPTIONS, batched=False)
    def minimize(objective, *, rng, xtol_rel=1e-6, ftol_rel=1e-8, maxeval=0):
        return _restarted_local_search(algorithm, objective, rng, xtol_rel, ftol_rel, maxeval)

    minimize.__name__ = minimize.__qualname__ = f"minimize_{name.split('-')[1]}"
    return minimize


minimize_bobyqa = _backend(
    "nlopt-bobyqa", nlopt.LN_BOBYQA, "NLopt BOBYQA (quadratic-model trust region), bounded, random restarts"
)
minimize_sbplx = _backend(
    "nlopt-sbplx", nlopt.LN_SBPLX, "NLopt Sbplx (Subplex: Nelder-Mead on subspaces), bounded, random restarts"
)
minimize_neldermead = _backend(
    "nlopt-neldermead", nlopt.LN_NELDERMEAD, "NLopt Nelder-Mead simplex, bounded, random restarts"
)
