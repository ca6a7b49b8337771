"""The paper's real-coded genetic algorithm (Section 3.2), as written there.

A population of ``population`` (100) points is drawn uniformly in the unit box and evaluated.
Each generation then:

1. tournament selection: two distinct individuals drawn at random, the lower loss kept,
   repeated until a new population of the same size is filled;
2. mutation: each individual, with probability ``p_mutation`` (0.5), gets ONE randomly chosen
   parameter replaced by a uniform draw over its range;
3. crossover: consecutive individuals of the selected population are paired (selection left
   them in random order, so this is random pairing) and each pair, with probability
   ``p_crossover`` (0.5), swaps ONE randomly chosen parameter;
4. the offspring are evaluated in one batch (all of them, changed or not, as the paper's
   "after those two steps the fitness function is calculated" reads: 100 per generation);
5. survival, (μ+λ): the new population is the best ``population`` of parents ∪ offspring.

Choice for step 5: the paper says "a new population composed of best solutions is created" and
that its size is constant. Choosing the best implies a pool larger than the population; replacing
parents by all offspring would leave nothing to choose. So parents compete with offspring, which
also makes the best loss non-increasing, as the paper's convergence plot (Fig. 16) shows. Ties
go to parents (stable sort, parents first). Duplicates are not removed: an unchanged copy of a
parent survives next to it, as it would in the paper's procedure.

The paper stops after 40 generations: 100 + 40·100 = 4,100 evaluations. When the generations are
done before the budget, the run stops and says so.

Options (checked before the run, see ``register``): ``population`` (100; 2 to 100,000: a tournament
needs two distinct individuals; the cap only bounds memory), ``generations`` (40; ≥ 0: 0 evaluates
the initial population only), ``p_mutation`` and ``p_crossover`` (0.5; probabilities in [0, 1]).
"""

from __future__ import annotations

import numpy as np

from bwbench.engine.options import Float, Int
from bwbench.engine.registry import register


def tournament(rng, pop, loss) -> np.ndarray:
    """Binary tournament: a new population of len(pop) winners (copies), shape like ``pop``."""
    n = len(pop)
    first = rng.integers(n, size=n)
    # The offset 1..n-1 makes the second contestant a different individual.
    second = (first + rng.integers(1, n, size=n)) % n
    winners = np.where(loss[first] <= loss[second], first, second)
    return pop[winners]


def mutate(rng, pop, p) -> np.ndarray:
    """With probability p per row, replace one random column by a uniform draw in [0, 1)."""
    out = pop.copy()
    n, d = out.shape
    # Draw everything for every row so the random stream does not depend on which rows hit.
    hit = rng.random(n) < p
    cols = rng.integers(d, size=n)
    values = rng.random(n)
    out[hit, cols[hit]] = values[hit]
    return out


def crossover(rng, pop, p) -> np.ndarray:
    """Pairs (0,1), (2,3), ...: with probability p per pair, swap one random column.

    With an odd number of rows the last one has no partner and is left as it is.
    """
    out = pop.copy()
    first = np.arange(0, len(pop) - 1, 2)
    hit = rng.random(len(first)) < p
    cols = rng.integers(pop.shape[1], size=len(first))
    a, c = first[hit], cols[hit]
    out[a, c], out[a + 1, c] = pop[a + 1, c], pop[a, c]
    return out


def survivors(pop, loss, kids, kid_loss):
    """(μ+λ): the len(pop) lowest-loss rows of parents ∪ offspring, parents first on ties."""
    both, both_loss = np.vstack([pop, kids]), np.concatenate([loss, kid_loss])
    keep = np.argsort(both_loss, kind="stable")[: len(pop)]
    return both[keep], both_loss[keep]


@register(
    "paper-ga",
    family="evolutionary",
    description="the paper's GA (Sec. 3.2): binary tournament, one-gene uniform mutation and "
    "one-gene swap crossover at 50%, (mu+lambda) survival, 100 x 40 generations",
    options={
        "population": Int(100, minimum=2, maximum=100_000),
        "generations": Int(40, minimum=0),
        "p_mutation": Float(0.5, minimum=0.0, maximum=1.0),
        "p_crossover": Float(0.5, minimum=0.0, maximum=1.0),
    },
)
def minimize(objective, *, rng, population=100, generations=40, p_mutation=0.5, p_crossover=0.5):
    pop = rng.random((population, objective.dim))
    loss = objective.batch(pop)
    for _ in range(generations):
        kids = crossover(rng, mutate(rng, tournament(rng, pop, loss), p_mutation), p_crossover)
        pop, loss = survivors(pop, loss, kids, objective.batch(kids))
    return {"message": f"{generations} generations done"}
