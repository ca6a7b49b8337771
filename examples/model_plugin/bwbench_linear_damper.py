"""An example bwbench model plug-in: a linear viscous damper beside a linear spring, in N, mm, s:

    F = c·ẋ + k·x

(c in N·s/mm, k in N/mm). No hysteresis: the loop it draws is an ellipse on a sine, the baseline any
hysteresis model must beat. Found through the entry-point group ``bwbench.models`` (see
``pyproject.toml``), so ``bwbench models`` lists it and a fit, a study or a spawned/Dask worker finds it
by its name, "linear-damper", wherever this package is installed.

What a model plug-in provides (``bwbench.models.base`` says what each member means):

- ``name``, ``title``, ``reference``; ``states`` (() here: one parameter set for both directions);
- ``direct_parameters(state)``: each parameter's name, unit and label;
- ``direct_box(signal, f, state)``: a search box scaled from the data (here from the force, stroke
  and velocity ranges, so it fits N or kN, mm strokes or 50 mm ones alike);
- ``force_batch(P, signal, state)``: (m, d) parameter rows → (m, L) forces at the samples (rows of
  +inf where the model blows up, never NaN, never an exception);
- optionally ``viscous_coefficients`` (∂F/∂ẋ, to turn a velocity error into a force error), and
  the identifiable formulation's members for a model whose force is linear in some coefficients
  once a few nonlinear parameters are fixed (this model has no nonlinear parameter: direct only).

The module must import without side effects beyond defining ``MODEL``: every worker imports it.
"""

from __future__ import annotations

import numpy as np

from bwbench.models.base import Box, Model, Parameter, amplitude, velocity_scale

PARAMETERS = (Parameter("c", "N·s/mm", "c", "viscous coefficient"), Parameter("k", "N/mm", "k", "stiffness"))


class LinearDamper(Model):
    name = "linear-damper"
    title = "linear viscous damper and spring (example plug-in)"
    reference = "F = c·ẋ + k·x: the Kelvin-Voigt element, e.g. Chopra, Dynamics of Structures, ch. 2"

    def direct_parameters(self, state=None) -> tuple:
        return PARAMETERS

    def direct_box(self, signal, f, state=None) -> Box:
        """c ∈ [0, 2·max|F|/max|ẋ|], k ∈ [0, 2·max|F|/amplitude]: each term alone can carry twice the force."""
        force = float(np.max(np.abs(np.asarray(f, dtype=float))))
        force = force if force > 0 else 1.0  # a zero-force file: any box, every fit is F = 0
        return Box(
            ("c", "k"),
            [0.0, 0.0],
            [2 * force / velocity_scale(signal), 2 * force / amplitude(signal.x)],
            [False, False],
        )

    def force_batch(self, P, signal, state=None) -> np.ndarray:
        P = np.atleast_2d(np.asarray(P, dtype=float))
        v, x = np.asarray(signal.v, dtype=float), np.asarray(signal.x, dtype=float)
        with np.errstate(over="ignore", invalid="ignore"):
            F = P[:, :1] * v[None, :] + P[:, 1:2] * x[None, :]
        return np.where(np.all(np.isfinite(F), axis=1)[:, None], F, np.inf)

    def viscous_coefficients(self, values: dict, state=None) -> dict | None:
        return {"": values["c"]} if "c" in values else None


MODEL = LinearDamper()
