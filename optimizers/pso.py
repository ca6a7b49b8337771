"""Global-best particle swarm optimisation (pyswarms ``GlobalBestPSO``).

Algorithm: Kennedy & Eberhart's PSO with a star topology. Each particle moves with velocity
``v ← w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x)`` inside the unit box; particles that leave
the box are reflected back (``bh_strategy="reflective"``; pyswarms' default "periodic" would
wrap a particle from one bound to the opposite one, which has no meaning for physical
parameters). The whole swarm is one ``objective.batch`` call per iteration.

Library call: ``pyswarms.single.GlobalBestPSO(n_particles, d, options={c1, c2, w},
bounds=(0, 1)).optimize(objective.batch, iters=<unbounded>, verbose=False)``. pyswarms checks
its iteration count only between iterations, so the swarm just runs until the objective raises
``BudgetExhausted`` (which pyswarms lets propagate). ``ftol`` stays at −inf: no early stop.

Options: ``n_particles`` (40), ``c1``/``c2``/``w``. Defaults are Clerc & Kennedy's constriction
values (w = 0.7298, c1 = c2 = 1.49618, IEEE TEC 2002), the standard PSO setting with a
convergence guarantee; pyswarms' documentation example (0.5, 0.3, 0.9) has an inertia so
high that the swarm barely contracts within a few thousand evaluations.

+inf losses are passed through unchanged: PSO only compares losses (``<`` for personal bests,
``argmin`` for the global best), and inf never wins a comparison.

Two pieces of global state need containing, both in ``_pyswarms_sandbox``:
- pyswarms draws every random number from numpy's legacy global generator (``np.random.uniform``
  in the swarm initialisation and the velocity update). We save that state, set it from ``rng``,
  and restore it afterwards, so the run is repeatable and callers' global state is untouched.
  A lock serialises pso runs within a process, since two threads sharing the global generator
  would interleave draws.
- every pyswarms ``Reporter`` (created at import and in each optimiser, topology and handler
  constructor) calls ``logging.config.dictConfig`` with a default that installs INFO handlers on
  the root logger and creates ``./report.log``. We make ``dictConfig`` a no-op while pyswarms is
  imported and constructed.
"""

from __future__ import annotations

import contextlib
import logging.config
import sys
import threading

import numpy as np

from bwbench.registry import register

_GLOBAL_RNG_LOCK = threading.Lock()


@contextlib.contextmanager
def _pyswarms_sandbox(rng):
    """Run pyswarms with numpy's global generator seeded from ``rng`` and logging left alone."""
    with _GLOBAL_RNG_LOCK:
        saved_state = np.random.get_state()
        saved_dict_config = logging.config.dictConfig
        # A full MT19937 state seeded through SeedSequence, not a 32-bit np.random.seed.
        np.random.set_state(np.random.RandomState(np.random.MT19937(rng.integers(2**63))).get_state())
        logging.config.dictConfig = lambda config: None
        try:
            yield
        finally:
            logging.config.dictConfig = saved_dict_config
            np.random.set_state(saved_state)


@register(
    "pso",
    family="swarm",
    description="pyswarms GlobalBestPSO on the unit box, constriction coefficients, reflective bounds",
    defaults={"n_particles": 40, "c1": 1.49618, "c2": 1.49618, "w": 0.7298},
)
def minimize(objective, *, rng, n_particles=40, c1=1.49618, c2=1.49618, w=0.7298):
    d = objective.dim
    with _pyswarms_sandbox(rng):
        from pyswarms.single import GlobalBestPSO  # imported here: importing pyswarms configures logging

        swarm = GlobalBestPSO(
            n_particles=int(n_particles), dimensions=d, options={"c1": c1, "c2": c2, "w": w},
            bounds=(np.zeros(d), np.ones(d)), bh_strategy="reflective",
        )
        # Never returns: the objective raises BudgetExhausted mid-iteration.
        swarm.optimize(objective.batch, iters=sys.maxsize, verbose=False)
    return {"message": "pyswarms stopped before the budget was spent"}
