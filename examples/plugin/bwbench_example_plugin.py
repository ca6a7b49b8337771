"""An example bwbench optimiser plugin: coordinate search with a shrinking step.

Found through the entry-point group ``bwbench.optimizers`` (see ``pyproject.toml``); the contract it
keeps is in ``bwbench.optimize.registry``'s docstring, and ``tests/test_contract.py`` checks it
with ``bwbench.testing``.
"""

from bwbench.optimize.registry import register


@register("example-coordinate-search", family="plugin", description="coordinate search with a halving step "
          "(example plugin)", defaults={"step": 0.25}, batched=False)
def minimize(objective, *, rng, step=0.25):
    u = rng.random(objective.dim)
    best = objective(u)
    while step > 1e-6:
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
