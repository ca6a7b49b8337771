"""The identification problem: model + specimen + bounds + loss. Knows nothing of optimisers.

A problem maps unit coordinates u ∈ [0, 1]^d to physical parameters and returns the mean squared
error (the paper's −F_err) of a whole population in one batched call. ``Objective`` wraps any
object with this interface; a second problem (another model, another loss) plugs in the same way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.models import excitation as excitation_mod
from bwbench.models import switched_bouc_wen as model
from bwbench.data.parameters import LOWER, UPPER
from bwbench.data.specimen import Specimen


class SpecimenFit:
    """What every fit of the switched model to one specimen answers the same way, whatever the
    formulation: needs ``specimen`` and ``param_names``."""

    @property
    def name(self) -> str:
        return self.specimen.name

    @property
    def dim(self) -> int:
        return len(self.param_names)

    @property
    def n_data(self) -> int:
        """Number of force samples the loss averages over (the L of eq 6)."""
        return self.specimen.n_samples

    def units(self, names) -> dict:
        """The unit of each parameter name (paper, identifiable or linear) a result of this fit reports."""
        from bwbench.problems.switched_vpp.fit_checks import units

        return units(names)

    def fit_checks(self, result, synthetic: bool = False):
        """``fit_checks.check`` at the best parameters of ``result`` (a ``Result`` of this problem)."""
        from bwbench.problems.switched_vpp import fit_checks

        params = [result.params.get(name, np.nan) for name in self.param_names]
        return fit_checks.check(self, params, synthetic, result.at_bound)


@dataclass
class SwitchedBoucWenProblem(SpecimenFit):
    """The paper's 14-parameter switched Bouc-Wen fit to one specimen (loss: MSE in N²)."""

    specimen: Specimen
    state: str = "shared"
    excitation: str = "measured"
    param_names: tuple = model.PARAM_NAMES
    lower: np.ndarray = field(default_factory=lambda: LOWER.copy())
    upper: np.ndarray = field(default_factory=lambda: UPPER.copy())

    def __post_init__(self):
        if self.state not in model.STATES:
            raise ValueError(f"state must be one of {model.STATES}, got {self.state!r}")
        self.signal = excitation_mod.of_specimen(self.excitation, self.specimen)

    formulation = "paper"

    @property
    def info(self) -> dict:
        return {"specimen": self.specimen.name, "state": self.state, "excitation": self.excitation,
                "formulation": self.formulation}

    def from_unit(self, U) -> np.ndarray:
        return self.lower + np.asarray(U, dtype=float) * (self.upper - self.lower)

    def to_unit(self, P) -> np.ndarray:
        return (np.asarray(P, dtype=float) - self.lower) / (self.upper - self.lower)

    def simulate(self, params) -> np.ndarray:
        """Model force (N) at the specimen's sample times; +inf everywhere on blow-up."""
        s = self.signal
        return model.simulate(params, s.t, s.x, s.v, s.a, self.state)

    def residual_batch(self, P) -> np.ndarray:
        """Model − measured force (N), shape (m, L); rows of +inf where the model blows up."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        s = self.signal
        # The batched z kernel, then the force that is linear in z (eqs 2-3) branch by branch.
        Z = model.hysteretic_state_batch(P[:, list(model.HYSTERETIC_INDEX)], s.t, s.x, s.v, self.state)
        plus = s.v >= 0.0
        force = np.empty_like(Z)
        for branch, mask in ((P[:, :7], plus), (P[:, 7:], ~plus)):
            xi, wn, alpha = branch[:, 5:6], branch[:, 6:7], branch[:, 2:3]
            force[:, mask] = (s.a[mask] + 2.0 * xi * wn * s.v[mask] + alpha * wn * wn * s.x[mask]
                              + (1.0 - alpha) * wn * wn * Z[:, mask])
        with np.errstate(invalid="ignore"):
            R = force - self.specimen.f
        return np.where(np.all(np.isfinite(R), axis=1)[:, None], R, np.inf)

    def loss_batch(self, P) -> np.ndarray:
        """MSE (N²) of each row of P (physical units, shape (m, 14)); +inf where it blows up."""
        s = self.signal
        return model.mse_batch(P, s.t, s.x, s.v, s.a, self.specimen.f, self.state)
