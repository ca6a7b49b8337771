"""Uniform random search: the baseline every comparison needs.

Options: ``batch_size`` (100; 1 to 100,000: points drawn and evaluated per call — every call
spends at least one evaluation, so the loop always ends; the cap only bounds memory).
"""

from __future__ import annotations

from bwbench.engine.options import Int
from bwbench.engine.registry import register


@register(
    "random",
    family="baseline",
    description="uniform random points in the Table 5 box, evaluated in batches",
    options={"batch_size": Int(100, minimum=1, maximum=100_000)},
)
def minimize(objective, *, rng, batch_size=100):
    while True:  # until the objective raises BudgetExhausted
        objective.batch(rng.random((batch_size, objective.dim)))
