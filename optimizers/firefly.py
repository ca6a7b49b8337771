"""Yang's standard firefly algorithm with a geometrically decaying randomisation α.

Variant: X.-S. Yang's firefly algorithm (Nature-Inspired Metaheuristic Algorithms, 2008/2010)
with α_t = α0·θ^t, t the generation, which is how Yang's own later code tames the random walk.
The paper cites the *modified* firefly algorithm of Zaman & Sikder (2015) for Bouc-Wen
identification; its abstract says it makes the control parameters change during the run, but
we do not know its exact update rules, so this is the standard algorithm it modifies, not theirs.

All in unit coordinates u ∈ [0, 1]^d (γ is per unit-box distance squared). Each generation:

- brightness is the loss at the start of the generation (lower = brighter);
- attractiveness β_ij = β0·exp(−γ·r_ij²) for all pairs, computed once per generation from the
  generation-start positions by broadcasting (Yang's loop recomputes r after each move of i);
- every firefly i moves towards every brighter firefly j in turn, brightest j first (Yang sorts
  the swarm by brightness): u_i ← u_i + β_ij·(u_j − u_i) + α_t·(ε − ½), ε ~ U[0,1)^d.
  Composing the moves one j at a time keeps each step a convex pull plus noise; summing all
  pulls at once would overshoot when many fireflies are brighter;
- the brightest firefly, attracted by none, takes a random walk α_t·(ε − ½), as in Yang (2008),
  rather than being evaluated again where it is;
- positions are clipped to [0, 1] and the whole swarm is evaluated in one batch.

Moves use the generation-start positions of the others (Yang's code moves i towards the old
position of j), so the loop over j is over numpy rows of the whole swarm at once. Runs until the
objective raises BudgetExhausted (every generation evaluates the whole swarm, so it always ends).

Options (checked before the run, see ``register``): ``population`` (25; 2 to 1,000: one firefly has
nobody to follow; the pairwise distances take population² × d numbers), ``beta0`` (1; in [0, 2]:
above 2 a move throws i farther from j than it started, repulsion rather than attraction),
``gamma`` (1; ≥ 0), ``alpha0`` (0.2; in [0, 1]: the random step in box widths), ``alpha_decay``
(0.97; in (0, 1]: 0 would freeze the random walk after one generation, above 1 it grows).
"""

from __future__ import annotations

import numpy as np

from bwbench.engine.options import Float, Int
from bwbench.engine.registry import register


def attractiveness(U, beta0, gamma) -> np.ndarray:
    """β_ij = β0·exp(−γ·‖u_i − u_j‖²) for all pairs: shape (n, n)."""
    r2 = ((U[:, None, :] - U[None, :, :]) ** 2).sum(axis=-1)
    return beta0 * np.exp(-gamma * r2)


def move(rng, U, loss, alpha, beta0, gamma) -> np.ndarray:
    """One generation of moves; returns the new positions (n, d), clipped to [0, 1]."""
    n, d = U.shape
    beta = attractiveness(U, beta0, gamma)
    brighter = loss[None, :] < loss[:, None]  # brighter[i, j]: j attracts i
    new = U.copy()
    for j in np.argsort(loss, kind="stable"):
        pulled = brighter[:, j]
        step = beta[:, j, None] * (U[j] - new) + alpha * (rng.random((n, d)) - 0.5)
        new[pulled] += step[pulled]
    alone = ~brighter.any(axis=1)  # the brightest (ties included): nobody to follow
    new[alone] += alpha * (rng.random((int(alone.sum()), d)) - 0.5)
    return np.clip(new, 0.0, 1.0)


@register(
    "firefly",
    family="swarm",
    description="Yang's standard firefly algorithm, vectorised, with alpha decaying as alpha0*theta^t",
    options={
        "population": Int(25, minimum=2, maximum=1000),
        "beta0": Float(1.0, minimum=0.0, maximum=2.0),
        "gamma": Float(1.0, minimum=0.0),
        "alpha0": Float(0.2, minimum=0.0, maximum=1.0),
        "alpha_decay": Float(0.97, minimum=0.0, maximum=1.0, exclusive_minimum=True),
    },
)
def minimize(objective, *, rng, population=25, beta0=1.0, gamma=1.0, alpha0=0.2, alpha_decay=0.97):
    U = rng.random((population, objective.dim))
    loss = objective.batch(U)
    alpha = float(alpha0)
    while True:  # until the objective raises BudgetExhausted
        U = move(rng, U, loss, alpha, beta0, gamma)
        loss = objective.batch(U)
        alpha *= alpha_decay
