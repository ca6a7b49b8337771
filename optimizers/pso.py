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

Options: ``n_particles`` (40; 1 to 1,000: pyswarms' star topology builds an n_particles² index
array every iteration), ``c1``/``c2`` (each in [0, 4]) and ``w`` (in [0, 1): with w ≥ 1 velocities
never decay). Defaults are Clerc & Kennedy's constriction values (w = 0.7298, c1 = c2 = 1.49618, IEEE TEC 2002), the standard PSO setting with a
convergence guarantee, rather than pyswarms' documentation example (c1 0.5, c2 0.3, w 0.9).
Measured at 4,100 evaluations, 5 seeds on each of three synthetic specimens, the median MSE
was lower with the constriction values on all three (13 vs 22, 175 vs 247, 161 vs 171 N²),
though not on every seed.

A runaway swarm ends the run. pyswarms' reflective handler brings a position back into [0, 1] one
box width per pass, and nothing bounds the velocity but the inertia: |v| can reach (c1 + c2)/(1 − w)
box widths, 8·10⁶ at w = 1 − 10⁻⁶, c1 = c2 = 4, i.e. millions of passes per iteration, a loop that
spends no budget (and w ≥ 1 is unbounded). So the handler is wrapped: a position more than
``_DIVERGED`` box widths out stops the run with a message. At the defaults |v| < 2.99/0.27 + 1 ≈ 12
box widths, so it never fires there (runs stay bit-identical to runs without the wrapper).

+inf losses are passed through unchanged: PSO only compares losses (``<`` for personal bests,
``argmin`` for the global best), and inf never wins a comparison.

Two pieces of global state need containing:
- pyswarms draws every random number from numpy's legacy global generator (``np.random.uniform``
  in the swarm initialisation and the velocity update). ``bwbench.engine.global_rng.seeded_global_rng``
  sets that state from ``rng`` and restores it afterwards, so the run is repeatable and the caller's
  global state is untouched.
- every pyswarms ``Reporter`` (created at import and in each optimiser, topology and handler
  constructor) calls ``logging.config.dictConfig`` with a default that installs INFO handlers on
  the root logger and creates ``./report.log``. ``_logging_config_frozen`` makes ``dictConfig`` a
  no-op while pyswarms is imported and the optimiser constructed (``optimize`` creates no
  Reporter), which is why pyswarms is imported inside ``minimize``, not at module level.
"""

from __future__ import annotations

import contextlib
import logging.config
import sys

import numpy as np

from bwbench.engine.global_rng import seeded_global_rng
from bwbench.engine.options import Float, Int
from bwbench.engine.registry import register

# Box widths from the box beyond which the swarm has diverged (see the module docstring); reflecting
# such a position back costs pyswarms about that many passes, a few milliseconds.
_DIVERGED = 1000.0


class _Diverged(Exception):
    pass


@contextlib.contextmanager
def _logging_config_frozen():
    """Make ``logging.config.dictConfig`` a no-op for the duration (see the module docstring)."""
    saved = logging.config.dictConfig
    logging.config.dictConfig = lambda config: None
    try:
        yield
    finally:
        logging.config.dictConfig = saved


@register(
    "pso",
    family="swarm",
    description="pyswarms GlobalBestPSO on the unit box, constriction coefficients, reflective bounds",
    options={
        "n_particles": Int(40, minimum=1, maximum=1000),
        "c1": Float(1.49618, minimum=0.0, maximum=4.0),
        "c2": Float(1.49618, minimum=0.0, maximum=4.0),
        "w": Float(0.7298, minimum=0.0, maximum=1.0, exclusive_maximum=True),
    },
)
def minimize(objective, *, rng, n_particles=40, c1=1.49618, c2=1.49618, w=0.7298):
    d = objective.dim
    with seeded_global_rng(rng):
        with _logging_config_frozen():
            # Imported here, not at the top: importing pyswarms configures logging.
            from pyswarms.single import GlobalBestPSO

            swarm = GlobalBestPSO(
                n_particles=int(n_particles),
                dimensions=d,
                options={"c1": c1, "c2": c2, "w": w},
                bounds=(np.zeros(d), np.ones(d)),
                bh_strategy="reflective",
            )
        reflect = swarm.bh

        def bounded(position, bounds, **kwargs):
            if not np.all(np.abs(position) < _DIVERGED):  # NaN included
                raise _Diverged
            return reflect(position, bounds, **kwargs)

        swarm.bh = bounded
        try:
            # Never returns: the objective raises BudgetExhausted mid-iteration.
            swarm.optimize(objective.batch, iters=sys.maxsize, verbose=False)
        except _Diverged:
            return {
                "message": f"the swarm ran away (a particle over {_DIVERGED:g} box widths out): "
                f"c1 = {c1}, c2 = {c2}, w = {w} are outside PSO's stable region"
            }
    return {"message": "pyswarms stopped before the budget was spent"}
