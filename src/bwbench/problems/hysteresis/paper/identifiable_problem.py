"""The switched model's identifiable formulation as a problem: the generic ``IdentifiableProblem``
of the switched model, kept under its own name for the callers that build it from a specimen alone.

The 7 (shared) or 6 (split) symmetry-free hysteretic parameters are searched in a box scaled from
the specimen; the 9 coefficients that enter the force linearly (m, and c, k, h, f per branch) are
solved for every simulated trajectory. Results are reported in both parametrisations: the
identifiable numbers, the linear coefficients, and the paper's 14 of the same loops where they
exist (``models.switched.SwitchedBoucWen.to_direct``: mass fixed at 1 and offsets left out — the
paper has neither — and reported beside).
"""

from __future__ import annotations

from bwbench.models.switched import MODEL
from bwbench.problems.hysteresis import model_problem


class IdentifiableProblem(model_problem.IdentifiableProblem):
    def __init__(
        self,
        specimen,
        state: str = "shared",
        excitation: str = "measured",
        *,
        fix_mass="auto",
        offsets: bool = True,
        bounds: dict | None = None,
    ):
        super().__init__(MODEL, specimen, state, excitation, fix_mass=fix_mass, offsets=offsets, bounds=bounds)
