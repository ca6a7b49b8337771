"""A test-only optimiser plugin, found through the entry-point group ``bwbench.optimizers``."""

from bwbench.optimize.registry import register


@register("test-plugin-coordinate", family="plugin", description="coordinate search, from a plugin",
          defaults={"step": 0.25})
def minimize(objective, *, rng, step=0.25):
    u = rng.random(objective.dim)
    best = objective(u)
    while step > 1e-6:
        improved = False
        for i in range(objective.dim):
            for sign in (1.0, -1.0):
                trial = u.copy()
                trial[i] = min(1.0, max(0.0, trial[i] + sign * step))
                loss = objective(trial)
                if loss < best:
                    u, best, improved = trial, loss, True
        if not improved:
            step /= 2
    return {"message": "step below 1e-6"}
