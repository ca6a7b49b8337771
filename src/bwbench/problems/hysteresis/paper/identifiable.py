"""The switched model's identifiable formulation on one excitation and force: the trajectories of the
symmetry-free hysteretic parameters and their linear solve (the equations and maps are in
``bwbench.models.switched_identifiable``; a fit to a specimen is ``model_problem.IdentifiableProblem``).
"""

from __future__ import annotations

import numpy as np

from bwbench.models import switched_bouc_wen as model
from bwbench.models.switched import LAYOUT
from bwbench.models.switched_identifiable import hysteretic_names, kernel_hysteretic, scaled_bounds
from bwbench.problems.hysteresis.linear.solve import LinearDesign, LinearSolution


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
