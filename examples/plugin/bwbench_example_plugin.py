"""An example bwbench optimiser plugin: coordinate search with a shrinking step.

Found through the entry-point group ``bwbench.optimizers`` (see ``pyproject.toml``); the contract it
keeps is in ``bwbench.engine.registry``'s docstring, and ``tests/test_contract.py`` checks it
with ``bwbench.testing`` (including a run at each edge of every declared option's range).

Its one option is declared with a type and a valid range, so ``bwbench fit --option step=...`` and a
study's ``[optimizers]`` table refuse a bad value in one line before anything runs, and
``bwbench optimizers`` shows ``step  float in (0, 1], default 0.25``.
"""

from bwbench.engine.options import Float
from bwbench.engine.registry import register


@register(
    "example-coordinate-search",
    family="plugin",
    description="coordinate search with a halving step (example plugin)",
    # the initial step, in unit coordinates: the box is 1 wide, and a step of 0 would never move
    options={"step": Float(0.25, minimum=0.0, maximum=1.0, exclusive_minimum=True)},
    batched=False,
)
def minimize(objective, *, rng, step=0.25):
    u = rng.random(objective.dim)
    best = objective(u)
    while step > 1e-6:  # every pass evaluates 2·d points: the loop always spends budget
        improved = False
        for i in range(objective.dim):
            for sign in (1.0, -1.0):
                trial = u.copy()
                trial[i] = min(1.0, max(0.0, trial[i] + sign * step))
                loss = objective(trial)  # raises BudgetExhausted past the budget: that ends the run
                if loss < best:
                    u, best, improved = trial, loss, True
        if not improved:
            step /= 2
    return {"message": "step below 1e-6"}
