"""A model fitted to one specimen, in either formulation: the problems every model plug-in gets.

``DirectProblem``: the model's own parameters searched in its box (the paper formulation of the
switched model). ``IdentifiableProblem``: the model's symmetry-free nonlinear parameters θ searched
in a box scaled from the data, the coefficients that enter the force linearly solved by least
squares for every simulated trajectory (``linear_solve``). One evaluation is one simulation either
way. Both know nothing of optimisers (``bwbench.engine.objective.Objective`` wraps them).

Both start every model the same way (``bwbench.models.start``): the models simulate ``sim_signal`` (the
record, after a pre-roll of its own motion where the rule asks for one) and the loss takes the record's
samples after the warm-up (``loss_signal``, ``f_loss``; ``n_data`` of them).
"""

from __future__ import annotations

import numpy as np

from bwbench.data import bounds as bounds_mod
from bwbench.engine.box import box_from_unit, box_to_unit
from bwbench.models import excitation as excitation_mod


class ModelFit:
    """What every fit of a model to one specimen answers the same way: needs ``model``, ``specimen``,
    ``state``, ``excitation``, ``param_names``, ``lower``, ``upper``, ``log_scaled``."""

    formulation = ""

    def _setup(self, model, specimen, state, excitation, initial_state="auto", warmup_s=0.0):
        self.model, self.specimen, self.excitation = model, specimen, excitation
        self.state = model.check_state(state)
        if getattr(specimen, "quasi_static", False):
            refuse_quasi_static(model, self.formulation, specimen)
        self.signal = excitation_mod.of_specimen(excitation, specimen)
        self.set_start(initial_state, warmup_s)

    def set_start(self, initial_state="auto", warmup_s=0.0) -> None:
        """The start of the record (``bwbench.models.start.plan``) and what follows from it: the excitation
        the model simulates (``sim_signal``), and the samples in the loss (``loss_signal``, ``f_loss``)."""
        from bwbench.models import start as start_mod

        where = getattr(self.specimen, "path", None) or self.specimen.name  # the file, to name in an error
        f = np.asarray(self.specimen.f, dtype=float)
        self.start = start_mod.plan(self.signal, initial_state, warmup_s, str(where), f)
        self.sim_signal = self.start.extend(self.signal)
        self.f_loss = f if self.start.warmup == 0 else f[self.start.loss]
        self.loss_signal = self.signal if self.start.warmup == 0 else start_mod.cut(self.signal, self.start.loss)

    @property
    def name(self) -> str:
        return self.specimen.name

    @property
    def dim(self) -> int:
        return len(self.param_names)

    @property
    def n_data(self) -> int:
        """Number of force samples the loss averages over (the L of eq 6): the record's after its warm-up."""
        return len(self.f_loss)

    def record_forces(self, P) -> np.ndarray:
        """The model force (N) of each direct row of P at the record's samples, (m, L), from the start."""
        return self.start.crop(
            self.model.force_batch(np.atleast_2d(np.asarray(P, dtype=float)), self.sim_signal, self.state)
        )

    def record_trajectories(self, theta) -> np.ndarray:
        """The θ-dependent column of each θ row at the record's samples, (m, L), from the start."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        return self.start.crop(self.model.trajectories(theta, self.sim_signal, self.state))

    def loss_trajectories(self, theta) -> np.ndarray:
        """``record_trajectories`` at the samples in the loss, (m, n_data)."""
        Z = self.record_trajectories(theta)
        return Z if self.start.warmup == 0 else Z[:, self.start.loss]

    def loss_sensitivities(self, theta):
        """The model's ``trajectory_sensitivities`` of one θ at the samples in the loss (None, or (z all
        +inf, None), as the model gives them)."""
        found = self.model.trajectory_sensitivities(np.asarray(theta, dtype=float), self.sim_signal, self.state)
        return _in_loss(self.start, found)

    @property
    def info(self) -> dict:
        out = {
            "specimen": self.specimen.name,
            "model": self.model.name,
            "excitation": self.excitation,
            "formulation": self.formulation,
        }
        if self.state is not None:
            out["state"] = self.state
        return out

    def units(self, names) -> dict:
        """The unit of each parameter name a result of this fit reports (searched, solved, direct)."""
        from bwbench.problems.hysteresis.fit_checks import units

        return units(self, names)

    def fit_checks(self, result, synthetic: bool = False):
        """``fit_checks.check`` at the best parameters of ``result`` (a ``Result`` of this problem)."""
        from bwbench.problems.hysteresis import fit_checks

        params = [result.params.get(name, np.nan) for name in self.param_names]
        return fit_checks.check(self, params, synthetic, result.at_bound)

    def exploration(self):
        """A copy simulating more cheaply for a fit's exploring searches, or None (``exploration``)."""
        from bwbench.problems.hysteresis.exploration import exploration

        return exploration(self)

    def from_unit(self, U) -> np.ndarray:
        return box_from_unit(U, self.lower, self.upper, self.log_scaled)

    def to_unit(self, P) -> np.ndarray:
        return box_to_unit(P, self.lower, self.upper, self.log_scaled)

    def _box(self, box, bounds):
        from bwbench.problems.hysteresis.edges import refuse_past_limits

        refuse_past_limits(self.model, self.state, box.names, box.lower, box.upper, bounds)
        self.param_names = tuple(box.names)
        self.log_scaled = np.array(box.log, dtype=bool)
        self.lower, self.upper = bounds_mod.apply(box.lower, box.upper, self.param_names, bounds or {})


class DirectProblem(ModelFit):
    """The model's own parameters fitted to one specimen (loss: MSE in N²)."""

    def __init__(
        self,
        model,
        specimen,
        state=None,
        excitation: str = "measured",
        *,
        bounds: dict | None = None,
        initial_state: str = "auto",
        warmup_s: float = 0.0,
    ):
        self._setup(model, specimen, state, excitation, initial_state, warmup_s)
        self.formulation = model.direct_name
        self.parameter_list = model.direct_parameters(self.state)
        self._box(model.direct_box(self.signal, specimen.f, self.state), bounds)

    def loss_batch(self, P) -> np.ndarray:
        """MSE (N²) of each row of P (physical units, (m, d)) over the samples in the loss; +inf where the
        model blows up."""
        P = np.atleast_2d(np.asarray(P, dtype=float))
        if self.start.plain:  # the model's own (a fused kernel where it has one)
            return self.model.mse_batch(P, self.signal, self.specimen.f, self.state)
        with np.errstate(invalid="ignore", over="ignore"):
            mse = np.mean(self.residual_batch(P) ** 2, axis=1)
        return np.where(np.isfinite(mse), mse, np.inf)

    def residual_batch(self, P) -> np.ndarray:
        """Model − measured force (N) at the samples in the loss, (m, n_data); rows of +inf where the model
        blows up."""
        F = self.record_forces(P)
        with np.errstate(invalid="ignore"):
            R = F[:, self.start.loss] - self.f_loss
        return np.where(np.all(np.isfinite(R), axis=1)[:, None], R, np.inf)

    @property
    def jacobian_cost(self) -> int:
        """Plain evaluations one ``residual_jacobian`` is charged (0: the model has no sensitivities)."""
        return int(self.model.sensitivity_cost) if self.model.has_force_sensitivities else 0

    def residual_jacobian(self, params):
        """(model − measured force (L,) N, its Jacobian (L, d) in physical units) of one direct vector,
        exact (``force_sensitivities`` of the model); None where it cannot be had."""
        found = _in_loss(
            self.start, self.model.force_sensitivities(np.asarray(params, dtype=float), self.sim_signal, self.state)
        )
        if found is None:
            return None
        F, dF = found
        return F - self.f_loss, dF

    def simulate(self, params) -> np.ndarray:
        """Model force (N) at the specimen's samples (the warm-up's too); +inf everywhere on blow-up."""
        return self.record_forces(np.asarray(params, dtype=float)[None, :])[0]

    def parameters(self, params) -> dict:
        return dict(zip(self.param_names, map(float, params)))


class IdentifiableProblem(ModelFit):
    """θ searched, linear coefficients solved (loss: MSE in N²). ``fix_mass``: "auto" (the inertia
    rule), None (fitted) or a value (N·s²/mm), for models with an inertia term; ``offsets``: the
    constant-force coefficients per branch (True/"branch"), "continuous" or none (False);
    ``bounds``: {name: (lower, upper)} replacing parts of the search box; ``coefficient_bounds``:
    {coefficient: (lower, upper)} replacing the physical defaults of the solved coefficients
    (``linear_bounds.physical_bounds``)."""

    formulation = "identifiable"

    def __init__(
        self,
        model,
        specimen,
        state=None,
        excitation: str = "measured",
        *,
        fix_mass="auto",
        offsets=True,
        bounds: dict | None = None,
        coefficient_bounds: dict | None = None,
        initial_state: str = "auto",
        warmup_s: float = 0.0,
    ):
        from bwbench.problems.hysteresis.linear.columns import coefficient_units
        from bwbench.problems.hysteresis.linear.solve import LinearDesign

        self._setup(model, specimen, state, excitation, initial_state, warmup_s)
        layout = model.linear_layout(self.state)
        solved, notes = coefficient_bounds_of(model, layout, self.loss_signal, self.f_loss, coefficient_bounds)
        self.design = LinearDesign(
            self.loss_signal, self.f_loss, layout, fix_mass=fix_mass, offsets=offsets, bounds=solved, notes=notes
        )
        self.linear_names = self.design.names
        self.linear_units = coefficient_units(layout)
        self.parameter_list = model.hysteretic_parameters(self.state)
        self._box(model.hysteretic_box(self.signal, specimen.f, self.state), bounds)

    @property
    def notes(self) -> list[str]:
        """What the linear solve fixed or dropped, and why (e.g. inertia not excited)."""
        return list(self.design.notes)

    @property
    def info(self) -> dict:
        return {**super().info, "linear_solve": "; ".join(self.notes)}

    def solve(self, P, residual: bool = False):
        """The linear solve (``LinearSolution``) of each θ row of P (m, d)."""
        return self.design.solve(self.loss_trajectories(P), residual)

    def loss_batch(self, P) -> np.ndarray:
        """MSE (N²) of each row of P with its linear coefficients solved; +inf on blow-up."""
        return self.design.mse(self.loss_trajectories(P))

    def log_likelihood_batch(self, P) -> tuple[np.ndarray, np.ndarray]:
        """(MSE in N², log marginal likelihood) of each row of P from one simulation each: the linear
        coefficients integrated out (flat prior on those of the fixed signals, the scale-free g-prior on
        those of the θ-dependent columns: ``marginal``) and σ under Jeffreys' 1/σ; −inf on blow-up."""
        from bwbench.problems.hysteresis.marginal import log_marginal

        solution = self.solve(P)
        return solution.mse, log_marginal(solution, prior="scale-free", varying=len(self.design.w_names))

    def residual_batch(self, P) -> np.ndarray:
        """F_model − F_measured (N) at the samples in the loss, (m, n_data); rows of +inf where the model
        blows up."""
        solution = self.solve(P, residual=True)
        R = solution.residual
        ok = np.isfinite(solution.mse) & np.all(np.isfinite(R), axis=1)
        return np.where(ok[:, None], R, np.inf)

    @property
    def jacobian_cost(self) -> int:
        """Plain evaluations one ``residual_jacobian`` is charged (0: the model has no sensitivities)."""
        return int(self.model.sensitivity_cost)

    def residual_jacobian(self, params):
        """(residual (L,) N, ∂residual/∂θ (L, d) in physical units) of one θ vector, exact (the model's
        sensitivities through the linear solve: ``LinearDesign.residual_jacobian``); None where they
        cannot be had (then take differences); (+inf residual, None) where the simulation did not finish."""
        found = self.loss_sensitivities(params)
        if found is not None and found[1] is None:
            return np.full(self.design.L, np.inf), None  # the simulation did not finish: no plain one either
        return None if found is None else self.design.residual_jacobian(*found)

    def linear(self, params) -> np.ndarray:
        """The solved coefficients (``linear_names``) of one θ vector."""
        return self.solve(np.asarray(params, dtype=float)[None, :]).coef[0]

    def simulate(self, params) -> np.ndarray:
        """Model force (N) at the specimen's samples (the warm-up's too), linear coefficients solved; +inf
        on blow-up."""
        params = np.asarray(params, dtype=float)
        if self.start.warmup == 0:
            return self.residual_batch(params[None, :])[0] + self.specimen.f
        return self.force_with(params, self.linear(params))

    def force_with(self, params, coef) -> np.ndarray:
        """Model force (N) at the record's samples of one θ vector with the linear coefficients ``coef``
        (``linear_names``, e.g. a joint fit's); +inf everywhere on blow-up."""
        from bwbench.problems.hysteresis.linear.columns import linear_force

        w = self.record_trajectories(params)[0]
        values = dict(zip(self.linear_names, map(float, coef)))
        return linear_force(self.model.linear_layout(self.state), values, self.signal, w)

    def parameters(self, params) -> dict:
        """θ, the solved coefficients and the model's direct parameters of the same force, where they exist."""
        return identifiable_parameters(self, params)


def start_settings(problem) -> tuple[str, float]:
    """(initial_state, warmup_s) as asked of a fit's problem (one file or joint: every file the same)."""
    first = (getattr(problem, "parts", None) or [problem])[0]
    return first.start.initial_state, first.start.warmup_s


def _in_loss(start, found):
    """(values (L_sim,), derivatives (L_sim, d)) simulated from ``start`` cut to the samples in the loss; None
    and (z, None) (a simulation that did not finish) passed on, cut likewise."""
    if found is None:
        return None
    z, dz = found
    part = start.loss
    z = start.crop(z)[part]
    return z, None if dz is None else np.asarray(dz)[start.preroll :][part]


def refuse_quasi_static(model, formulation: str, specimen) -> None:
    """``UserError`` when ``model`` in ``formulation`` cannot be fitted to the quasi-static ``specimen``
    (no time): a rate-dependent model, or a direct formulation, whose parameters hold a viscous or
    inertia force that a record without time cannot give."""
    from bwbench.errors import UserError

    where = f"{specimen.path}: a quasi-static test (no time_s column)"
    if not getattr(model, "rate_independent", False):
        raise UserError(
            f"{where}: the {model.name} model is rate-dependent and needs time; fit a Bouc-Wen model (bouc-wen, switched-bouc-wen, bwbn)"
        )
    if formulation != "identifiable":
        raise UserError(
            f"{where}: the {formulation} formulation has viscous and inertia terms in its parameters; "
            "use --formulation identifiable (they are held at 0 there)"
        )


def identifiable_parameters(problem, params) -> dict:
    """{name: value} of the searched θ of an identifiable ``problem`` (one file or joint), its solved
    coefficients and the model's direct parameters of the same force where they exist; θ alone when
    it is not finite."""
    params = np.asarray(params, dtype=float)
    out = dict(zip(problem.param_names, map(float, params)))
    if not np.all(np.isfinite(params)):
        return out
    coef = dict(zip(problem.linear_names, map(float, problem.linear(params))))
    out.update(coef)
    direct = problem.model.to_direct(params, coef, problem.state)
    if direct is not None:
        out.update(zip((p.name for p in problem.model.direct_parameters(problem.state)), map(float, direct)))
    return out


def coefficient_bounds_of(model, layout, signal, f, given: dict | None = None) -> tuple[dict, list[str]]:
    """({coefficient: (lower, upper)}, notes): the physical defaults of ``linear_bounds`` for this
    record (or stacked records) with the ``given`` ones (a user's) put in by name."""
    from bwbench.problems.hysteresis.linear.bounds import physical_bounds
    from bwbench.problems.hysteresis.linear.columns import coefficient_units

    bounds, notes = physical_bounds(
        layout,
        signal,
        f,
        coefficient_units(layout),
        viscous_sign=getattr(model, "viscous_sign_bound", True),
        model_bounds=model.coefficient_limits(),
    )
    for name, (lo, hi) in (given or {}).items():
        bounds[name] = (float(lo), float(hi))
        notes.append(f"{name} bounded to [{lo:g}, {hi:g}] by the caller")
    return bounds, notes
