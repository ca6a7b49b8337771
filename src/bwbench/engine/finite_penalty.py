"""For libraries that mishandle +inf: report a blown-up model as 10 × the worst finite loss seen.

BOBYQA takes a raw +inf as convergence and dual_annealing's L-BFGS-B needs finite differences;
ten times the worst finite loss keeps them away from the region without distorting the rest.
"""

from __future__ import annotations

import math


class WorstFinitePenalty:
    def __init__(self, before_any_finite: float):
        self.before_any_finite = before_any_finite  # what to report before a finite loss is known
        self.worst_finite = -math.inf

    @property
    def value(self) -> float:
        return 10.0 * self.worst_finite if math.isfinite(self.worst_finite) else self.before_any_finite

    def __call__(self, loss: float) -> float:
        """``loss`` itself when finite (and remembered), else the penalty."""
        if math.isfinite(loss):
            self.worst_finite = max(self.worst_finite, loss)
            return loss
        return self.value
