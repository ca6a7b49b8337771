"""Uniform random search: the baseline every comparison needs."""

from __future__ import annotations

from bwbench.optimize.registry import register


@register(
    "random",
    family="baseline",
    description="uniform random points in the Table 5 box, evaluated in batches",
    defaults={"batch_size": 100},
)
def minimize(objective, *, rng, batch_size=100):
    while True:  # until the objective raises BudgetExhausted
        objective.batch(rng.random((batch_size, objective.dim)))
