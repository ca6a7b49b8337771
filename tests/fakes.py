"""A cheap stand-in for a problem, shared by the backend tests: identity map from the unit box,
a shifted sphere loss, an optional region of +inf (a "blow-up"), and a count of every evaluation
made independently of the objective."""

from __future__ import annotations

import numpy as np


class SphereProblem:
    def __init__(self, dim=14, centre=None, blow_up=None, n_data=100):
        self.dim = dim
        self.param_names = tuple(f"p{i}" for i in range(dim))
        self.info: dict = {}
        self.n_data = n_data
        self.centre = np.linspace(0.2, 0.8, dim) if centre is None else np.broadcast_to(centre, (dim,))
        self.blow_up = blow_up  # P -> bool mask of rows that blow up, or None
        self.evaluated = 0
        self.blew_up = 0
        self.call_sizes: list[int] = []

    def from_unit(self, U):
        return np.asarray(U, dtype=float)

    def loss_batch(self, P):
        P = np.atleast_2d(P)
        self.evaluated += len(P)
        self.call_sizes.append(len(P))
        loss = np.sum((P - self.centre) ** 2, axis=1)
        if self.blow_up is None:
            return loss
        blown = self.blow_up(P)
        self.blew_up += int(blown.sum())
        return np.where(blown, np.inf, loss)
