"""The paper's 14-parameter fit of the switched model to one specimen: the generic ``DirectProblem``
of the switched model (``bwbench.models.switched``), kept under its own name for the callers that
build it from a specimen alone."""

from __future__ import annotations

from bwbench.models.switched import MODEL
from bwbench.problems.hysteresis.model_problem import DirectProblem


class SwitchedBoucWenProblem(DirectProblem):
    """The paper's 14 parameters in the Table 5 box (loss: MSE in N²)."""

    def __init__(self, specimen, state: str = "shared", excitation: str = "measured", *, bounds: dict | None = None):
        super().__init__(MODEL, specimen, state, excitation, bounds=bounds)
