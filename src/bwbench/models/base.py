"""What a hysteresis model is, for the problems that fit it: the plug-in base class.

A model is displacement-driven: given the excitation at the sample times (t in s, x in mm, ẋ in
mm/s, ẍ in mm/s²: an object with attributes ``t, x, v, a``) it returns the force (N). A plug-in
subclasses ``Model`` and fills in its equations; the problems, the store and the report only ask
the model (the way an emcee move fills in ``get_proposal`` and the base keeps the bookkeeping).

What a model provides:

- ``name`` (registry key, ``--model NAME``), ``title``, ``reference`` (where the equations come from);
- ``states``: the state conventions it has (() when it has none; the switched model has
  "shared" and "split");
- the **direct** formulation (``direct_name``: "direct", or "paper" for the switched model): its
  published parameters, ``direct_parameters(state)`` (names, units, labels), a search box
  ``direct_box(signal, f, state)`` scaled from the data, and ``force_batch(P, signal, state)``
  (m rows → (m, L) forces, rows of +inf where the model blows up, never NaN, never an exception);
- optionally the **identifiable** formulation, for a model whose force is linear in some
  coefficients once a few nonlinear parameters are fixed, F = Σ_j β_j·g_j(θ; signal):
  ``hysteretic_parameters(state)`` and ``hysteretic_box(signal, f, state)`` (θ, searched),
  ``linear_layout(state)`` (which coefficients β there are, their units, which columns g_j are
  fixed signals and which depend on θ), ``trajectories(theta, signal, state)`` (the θ-dependent
  column, (m, L), +inf rows on blow-up) and ``to_direct(theta, coef, state)`` /
  ``from_direct(P, state)`` (the exact maps where they exist).

Units are the specimen files': mm, s, N.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Parameter:
    """One model parameter: its key (JSON, CSV column, ``--bounds``), unit and a label for figures."""

    name: str
    unit: str = "-"
    label: str = ""
    description: str = ""

    @property
    def text(self) -> str:
        """Label with its unit for an axis, e.g. "x_y (mm)"; dimensionless ones get "(–)"."""
        return f"{self.label or self.name} ({'–' if self.unit in ('-', '') else self.unit})"


@dataclass(frozen=True, eq=False)  # eq=False: comparing ndarray fields would raise
class Box:
    """A search box in physical units; ``log`` flags the coordinates searched uniformly in log."""

    names: tuple
    lower: np.ndarray
    upper: np.ndarray
    log: np.ndarray

    def __post_init__(self):
        for attr in ("lower", "upper"):
            object.__setattr__(self, attr, np.asarray(getattr(self, attr), dtype=float))
        object.__setattr__(self, "log", np.asarray(self.log, dtype=bool))
        if not (len(self.names) == len(self.lower) == len(self.upper) == len(self.log)):
            raise ValueError("a box needs one lower, upper and log flag per name")
        if np.any(self.log & (self.lower <= 0)):
            raise ValueError("a log-scaled coordinate needs a positive lower bound")

    def from_unit(self, U) -> np.ndarray:
        """Unit coordinates (..., d) → physical units."""
        lo, hi = self._ends()
        q = lo + np.asarray(U, dtype=float) * (hi - lo)
        return np.where(self.log, 10.0 ** np.where(self.log, q, 0.0), q)

    def to_unit(self, P) -> np.ndarray:
        """Physical units (..., d) → unit coordinates; NaN for P ≤ 0 on a log coordinate."""
        lo, hi = self._ends()
        P = np.asarray(P, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            q = np.where(self.log, np.log10(np.where(self.log, P, 1.0)), P)
        return (q - lo) / (hi - lo)

    def _ends(self):
        with np.errstate(divide="ignore", invalid="ignore"):
            return (
                np.where(self.log, np.log10(np.where(self.log, self.lower, 1.0)), self.lower),
                np.where(self.log, np.log10(np.where(self.log, self.upper, 1.0)), self.upper),
            )


@dataclass(frozen=True)
class LinearLayout:
    """The coefficients an identifiable formulation solves by least squares, F = Σ β_j·g_j.

    ``names``/``units``: every coefficient, in the order results report them. ``fixed``: (name,
    signal) for the columns that do not depend on θ, the signal one of "x" (mm), "v" (mm/s), "a"
    (mm/s²), "1"; ``varying``: the name of the coefficient of the θ-dependent column. ``branched``:
    the model switches its coefficients with the sign of ẋ, so each fixed column and the varying
    one are split into a '+' (ẋ ≥ 0) and a '−' part, named with the suffix. ``mass``: the name of
    an inertia coefficient m of ẍ (the inertia rule of ``linear_solve`` decides whether the data
    can fit it), or None when the model has no inertia term.
    """

    names: tuple
    units: dict
    fixed: tuple
    varying: str
    branched: bool = False
    mass: str | None = None
    labels: dict = field(default_factory=dict)


class Model:
    """Base class of a model plug-in; subclass it and fill in the methods your model has."""

    name = "model"
    title = ""
    reference = ""
    states: tuple = ()
    direct_name = "direct"
    default_formulation = "direct"
    # Whether a viscous coefficient (N·s/mm) solved in the identifiable formulation is bounded ≥ 0 when
    # the measured loops dissipate (``bwbench.problems.hysteresis.linear.bounds``): right for one dashpot, wrong for a
    # model whose identified branches may have either sign (the switched model: see there).
    viscous_sign_bound = True
    # Simulations this model's kernel stopped at its step budget (a stiff corner of a search box: the
    # loss is +inf), in this process so far; a model whose kernel caps its work adds to it.
    step_budget_stops = 0
    # Whether the model's hysteresis is rate-independent (driven by the displacement path alone), so that
    # it may be fitted to a quasi-static record without time (``Specimen.quasi_static``) in its
    # identifiable formulation, its viscous and inertia terms off. A model with internal dynamics in time
    # (Spencer's) is not.
    rate_independent = False

    @property
    def formulations(self) -> tuple:
        """The formulations this model can be fitted in: its direct one, and "identifiable" if it has one."""
        return (self.direct_name, "identifiable") if self.has_linear_part else (self.direct_name,)

    @property
    def has_linear_part(self) -> bool:
        return type(self).trajectories is not Model.trajectories

    def check_state(self, state):
        """The state convention to use: ``state`` if the model has it, else None (models without any)."""
        if not self.states:
            return None
        if state is None:
            return self.states[0]
        if state not in self.states:
            raise ValueError(f"state must be one of {self.states}, got {state!r}")
        return state

    # -- direct formulation -------------------------------------------------------------------
    def direct_parameters(self, state=None) -> tuple:
        raise NotImplementedError

    def direct_box(self, signal, f, state=None) -> Box:
        raise NotImplementedError

    def force_batch(self, P, signal, state=None) -> np.ndarray:
        raise NotImplementedError

    def mse_batch(self, P, signal, f, state=None) -> np.ndarray:
        """MSE (N²) of each row of P against the measured force f; +inf where the model blows up."""
        F = self.force_batch(P, signal, state)
        with np.errstate(invalid="ignore", over="ignore"):
            mse = np.mean((F - np.asarray(f, dtype=float)) ** 2, axis=1)
        return np.where(np.isfinite(mse), mse, np.inf)

    # -- identifiable formulation (optional) --------------------------------------------------
    def hysteretic_parameters(self, state=None) -> tuple:
        raise NotImplementedError

    def hysteretic_box(self, signal, f, state=None) -> Box:
        raise NotImplementedError

    def linear_layout(self, state=None) -> LinearLayout:
        raise NotImplementedError

    def trajectories(self, theta, signal, state=None) -> np.ndarray:
        raise NotImplementedError

    # What one simulation with its sensitivities (``trajectory_sensitivities``) costs, in plain
    # simulations (measured: benchmarks/bench_call_cost.py): what an exact Jacobian is charged against a
    # budget, so that a backend using it is compared fairly with one taking differences.
    sensitivity_cost = 0

    def trajectory_sensitivities(self, theta, signal, state=None):
        """(the θ-dependent column z (L,), ∂z/∂θ (L, d)) of one θ row (d,), integrated together; None
        when the model has no sensitivities, or where they could not be had (then callers take
        differences); (z all +inf, None) where the simulation itself did not finish (blow-up, step
        budget), so the plain one would not either: callers need not run it."""
        return None

    def to_direct(self, theta, coef: dict, state=None):
        """The direct parameters (a vector) of the same loops as (θ, coefficients by name), or None when
        there are none. Coefficients the direct parameters cannot hold (an inertia other than the
        model's, a constant force offset) are left out: results report them beside."""
        return None

    def from_direct(self, P, state=None):
        """(θ, coefficients by name) of one direct parameter vector P; the inverse of ``to_direct``."""
        raise NotImplementedError

    # -- physical limits (optional) -------------------------------------------------------------
    def coefficient_limits(self, state=None) -> dict:
        """{solved coefficient: (lower, upper, why)}: the physical limits of the coefficients the
        identifiable formulation solves, applied (``linear_bounds.physical_bounds``) when the measured
        loops dissipate energy; ``why`` says what the limit means. {} when the model has none."""
        return {}

    def parameter_limits(self, state=None) -> dict:
        """{searched parameter: {"lower" | "upper": why}}: the search-box edges that are physical limits
        (a spring that cannot be negative), not search limits: a fit on one is a finding about the model
        or the data, not a box to widen. {} when the model has none."""
        return {}

    def plausibility(self, values: dict, signal, state=None) -> list:
        """[(parameter, value, unit, meaning, verdict or "")] for a fit's ``values`` (every reported
        parameter by name) on the excitation ``signal``: what each fitted parameter means physically and,
        where it is implausible, why (verdict). [] when the model has no such table."""
        return []

    # -- checks of a fit (optional) -----------------------------------------------------------
    def viscous_coefficients(self, values: dict, state=None) -> dict | None:
        """∂F/∂ẋ (N·s/mm) of a fit whose parameters are ``values`` (by name, any formulation), per
        branch ({"+": .., "-": ..} for a model that switches with the sign of ẋ, else {"": ..}); None
        when the model cannot say. Used to turn a velocity error into a force error."""
        return None

    def linear_branches(self, theta, trajectory, signal, state=None) -> dict:
        """{branch: True when the fitted branch is linear in x (no yield within the stroke)} for the
        identifiable θ and its trajectory; {} when the model has no such notion."""
        return {}

    def linear_limits(self, state=None) -> dict:
        """{branch: {identifiable parameter name: value}}: for each branch (the keys of
        ``linear_branches``), the values of its shape parameters that make it linear until it yields,
        whatever its other parameters — what a posterior holds fixed when the data cannot tell the
        branch's shape from that (a reduced model, ``bwbench.optimizers.mcmc_reduce``); {} when the
        model has no such notion."""
        return {}

    def yield_parameters(self, state=None) -> dict:
        """{branch: identifiable parameter name} of the parameter that sets where a branch of
        ``linear_limits`` yields: a posterior holds it at the top of its box (the branch never yields
        within the stroke) when the data cannot tell that apart either; {} when the model has none."""
        return {}

    def reduced_gauge(self, held, state=None) -> set:
        """Names of the identifiable parameters (sampled or solved) whose values a reduced model with
        ``held`` (names) held fixed puts in its own gauge: they trade with a held one along a direction
        the data do not see, so they cannot be compared with a truth or with fits of the full model."""
        return set()

    def symmetries(self, params, state=None) -> list:
        """The exact symmetries of the direct formulation at ``params``: a list of (name, orbit), orbit(s)
        giving the direct parameters moved by the scale s > 0 (s = 1: ``params``) with the force
        unchanged; [] when the model has none (or none is known)."""
        return []


def amplitude(x) -> float:
    """Half the displacement range (mm): the scale of every displacement-like bound."""
    a = 0.5 * float(np.ptp(np.asarray(x, dtype=float)))
    if not a > 0:
        raise ValueError("the displacement does not move: no scale for the search box")
    return a


def velocity_scale(signal) -> float:
    """The largest |ẋ| of the excitation (mm/s): the scale of every velocity-like bound."""
    v = float(np.max(np.abs(np.asarray(signal.v, dtype=float))))
    if not v > 0:
        raise ValueError("the velocity is zero everywhere: no scale for the search box")
    return v
