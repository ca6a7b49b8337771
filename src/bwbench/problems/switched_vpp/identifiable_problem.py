"""The switched model's identifiable formulation as a problem: search the 7 (shared) or 6 (split)
symmetry-free hysteretic parameters in a box scaled from the specimen, solve the 9 coefficients that
enter the force linearly (m, and c, k, h, f per branch) for every simulated trajectory.

One evaluation is still one simulation of the model: the linear solve is part of it. Results are
reported in both parametrisations (``parameters``): the identifiable numbers, the linear
coefficients, and the paper's 14 of the same loops where they exist (mass and offsets aside: the
paper fixes m = 1 and has no offsets, so those are reported beside them).
"""

from __future__ import annotations

import numpy as np

from bwbench.data import bounds as bounds_mod
from bwbench.data.specimen import Specimen
from bwbench.models import excitation as excitation_mod
from bwbench.models import switched_bouc_wen as model
from bwbench.problems.box import box_from_unit, box_to_unit
from bwbench.problems.switched_vpp import identifiable as fm
from bwbench.problems.switched_vpp.linear_solve import LINEAR_NAMES
from bwbench.problems.switched_vpp.problem import SpecimenFit


class IdentifiableProblem(SpecimenFit):
    """The identifiable formulation fitted to one specimen (loss: MSE in N²).

    ``fix_mass``: "auto" (fitted only when the data excite inertia, else fixed at the paper's 1),
    None (fitted) or a value (N·s²/mm); ``offsets``: fit a constant force per branch (DESIGN §8);
    ``bounds``: {name: (lower, upper)} replacing parts of the data-scaled box.
    """

    formulation = "identifiable"

    def __init__(self, specimen: Specimen, state: str = "shared", excitation: str = "measured", *,
                 fix_mass="auto", offsets: bool = True, bounds: dict | None = None):
        if state not in model.STATES:
            raise ValueError(f"state must be one of {model.STATES}, got {state!r}")
        self.specimen, self.state, self.excitation = specimen, state, excitation
        self.signal = excitation_mod.of_specimen(excitation, specimen)
        self.model = fm.IdentifiableModel(self.signal, specimen.f, state, fix_mass=fix_mass, offsets=offsets)
        box = self.model.bounds
        self.param_names = tuple(box.names)
        self.log_scaled = np.array(box.log, dtype=bool)
        self.lower, self.upper = bounds_mod.apply(box.lower, box.upper, self.param_names, bounds or {})

    @property
    def notes(self) -> list[str]:
        """What the linear solve fixed or dropped, and why (e.g. inertia not excited)."""
        return list(self.model.design.notes)

    @property
    def info(self) -> dict:
        return {"specimen": self.specimen.name, "state": self.state, "excitation": self.excitation,
                "formulation": self.formulation, "linear_solve": "; ".join(self.notes)}

    def from_unit(self, U) -> np.ndarray:
        return box_from_unit(U, self.lower, self.upper, self.log_scaled)

    def to_unit(self, P) -> np.ndarray:
        return box_to_unit(P, self.lower, self.upper, self.log_scaled)

    def loss_batch(self, P) -> np.ndarray:
        """MSE (N²) of each row of P (shape (m, d)) with its linear coefficients solved; +inf on blow-up."""
        return self.model.mse_batch(np.atleast_2d(np.asarray(P, dtype=float)))

    def log_likelihood_batch(self, P) -> tuple[np.ndarray, np.ndarray]:
        """(MSE in N², log marginal likelihood) of each row of P from one simulation each: the linear
        coefficients integrated out analytically under a flat prior and σ under Jeffreys' 1/σ
        (``marginal.log_marginal``); −inf where the model blows up."""
        from bwbench.problems.switched_vpp.marginal import log_marginal

        solution = self.model.solve(np.atleast_2d(np.asarray(P, dtype=float)))
        return solution.mse, log_marginal(solution)

    def residual_batch(self, P) -> np.ndarray:
        """F_model − F_measured (N), shape (m, L); rows of +inf where the model blows up."""
        solution = self.model.solve(np.atleast_2d(np.asarray(P, dtype=float)), residual=True)
        R = solution.residual
        return np.where(np.isfinite(solution.mse)[:, None] & np.all(np.isfinite(R), axis=1)[:, None], R, np.inf)

    def linear(self, params) -> np.ndarray:
        """The 9 solved coefficients (``LINEAR_NAMES``) of one parameter vector."""
        return self.model.solve(np.asarray(params, dtype=float)[None, :]).coef[0]

    def simulate(self, params) -> np.ndarray:
        """Model force (N) at the specimen's samples, linear coefficients solved; +inf on blow-up."""
        return self.residual_batch(np.asarray(params, dtype=float)[None, :])[0] + self.specimen.f

    def parameters(self, params) -> dict:
        """Everything a result reports: the identifiable numbers, the linear coefficients, and the
        paper's 14 of the same loops (mass fixed at 1 and offsets left out) where they exist."""
        params = np.asarray(params, dtype=float)
        out = dict(zip(self.param_names, map(float, params)))
        if not np.all(np.isfinite(params)):
            return out
        linear = self.linear(params)
        out.update(zip(LINEAR_NAMES, map(float, linear)))
        paper = to_paper_ignoring_offsets(params, linear, self.state)
        if paper is not None:
            out.update(zip(model.PARAM_NAMES, map(float, paper)))
        return out


def to_paper_ignoring_offsets(theta, linear, state: str):
    """The paper's 14 parameters of the loops of (theta, linear) with m = 1 and f = 0 put in (the
    paper's model has neither); None where no gauge makes every ωn² positive."""
    linear = np.array(linear, dtype=float)
    linear[LINEAR_NAMES.index("m")] = 1.0
    for b in "+-":
        linear[LINEAR_NAMES.index(f"f{b}")] = 0.0
    if not np.all(np.isfinite(linear)):
        return None
    return fm.to_paper(theta, linear, state).params
