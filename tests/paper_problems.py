"""The switched model's problems built from a specimen alone, as the paper's tests build them: the
paper's 14 parameters in the Table 5 box (``SwitchedBoucWenProblem``), the identifiable formulation
(``IdentifiableProblem``) — thin names for the generic problems of ``bwbench.problems.hysteresis`` —
and the identifiable formulation on a bare excitation and force (``IdentifiableModel``)."""

from __future__ import annotations

import numpy as np

from bwbench.models.switched import simulation as model
from bwbench.models.switched.identifiable import hysteretic_names, kernel_hysteretic, scaled_bounds
from bwbench.models.switched.model import LAYOUT, MODEL
from bwbench.problems.hysteresis import model_problem
from bwbench.problems.hysteresis.linear.solve import LinearDesign, LinearSolution
from bwbench.problems.hysteresis.model_problem import DirectProblem


class SwitchedBoucWenProblem(DirectProblem):
    """The paper's 14 parameters in the Table 5 box (loss: MSE in N²)."""

    def __init__(self, specimen, state: str = "shared", excitation: str = "measured", *, bounds: dict | None = None):
        super().__init__(MODEL, specimen, state, excitation, bounds=bounds)


class IdentifiableProblem(model_problem.IdentifiableProblem):
    """The switched model's identifiable formulation on one specimen."""

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


class IdentifiableModel:
    """The identifiable formulation on one excitation (t, x, v, a) and measured force f (N).

    ``linear_options`` go to ``LinearDesign`` (fix_mass, offsets, mass_min). ``bounds`` is the
    data-scaled box. theta rows are ordered as ``hysteretic_names(state)``.
    """

    def __init__(self, signal, f, state: str = "shared", **linear_options):
        self.names = hysteretic_names(state)
        self.signal, self.state = signal, state
        self.design = LinearDesign(signal, f, LAYOUT, **linear_options)
        self.bounds = scaled_bounds(signal.x, f, state)
        # Residual of a blown-up trajectory: 10·max|F| everywhere, worse than the zero model.
        self.penalty = 10.0 * max(float(np.max(np.abs(f))), 1.0)

    @property
    def n_data(self) -> int:
        return self.design.L

    def trajectories(self, theta) -> np.ndarray:
        """w (m, L) for theta rows (m, d); +inf rows on blow-up."""
        s = self.signal
        H = kernel_hysteretic(theta, self.state)
        return model.hysteretic_state_batch(H, s.t, s.x, s.v, self.state)

    def solve(self, theta, residual: bool = False) -> LinearSolution:
        """Linear coefficients, MSE (N²) and optionally residuals for theta rows (m, d)."""
        return self.design.solve(self.trajectories(theta), residual)

    def mse_batch(self, theta) -> np.ndarray:
        """MSE (N²) of each theta row with its linear coefficients solved; +inf on blow-up."""
        return self.solve(theta).mse

    def residual(self, theta) -> np.ndarray:
        """F_model − F_measured (L,) N for one theta (variable projection); finite always."""
        residual = self.solve(np.asarray(theta, dtype=float)[None, :], residual=True).residual
        assert residual is not None  # asked for
        r = residual[0]
        return r if np.all(np.isfinite(r)) else np.full(self.n_data, self.penalty)

    def residual_unit(self, u) -> np.ndarray:
        """``residual`` at unit coordinates u of ``bounds`` (for least_squares with bounds (0, 1))."""
        return self.residual(self.bounds.from_unit(u))
