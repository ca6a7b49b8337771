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
    """One model parameter: its key, unit and a label for figures.

    Parameters
    ----------
    name : str
        The key of the parameter in result JSON, CSV columns and ``--bounds``.
    unit : str, default "-"
        Its unit in the specimen files' units (mm, s, N), "-" when dimensionless.
    label : str, default ""
        The label for figures (default: ``name``).
    description : str, default ""
        What the parameter means, in words.

    Examples
    --------
    >>> Parameter("x_y", "mm", "x_y").text
    'x_y (mm)'
    """

    name: str
    unit: str = "-"
    label: str = ""
    description: str = ""

    @property
    def text(self) -> str:
        """Label with its unit for an axis, e.g. "x_y (mm)"; dimensionless ones get "(–)".

        Returns
        -------
        str
            The label (or the name when there is no label) followed by the unit in parentheses.
        """
        return f"{self.label or self.name} ({'–' if self.unit in ('-', '') else self.unit})"


@dataclass(frozen=True, eq=False)  # eq=False: comparing ndarray fields would raise
class Box:
    """A search box in physical units.

    Parameters
    ----------
    names : tuple of str
        The searched parameters, in order.
    lower, upper : array_like of float
        The box's bounds per name, in the parameters' physical units.
    log : array_like of bool
        Flags the coordinates searched uniformly in log (they need a positive lower bound).

    Raises
    ------
    ValueError
        When the four do not have one entry per name, or a log coordinate has a lower bound ≤ 0.

    Examples
    --------
    >>> box = Box(("k", "c"), [1.0, 0.0], [100.0, 5.0], [True, False])
    >>> box.from_unit([0.5, 0.5])
    array([10. ,  2.5])
    """

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
        """Map unit coordinates to physical units.

        Parameters
        ----------
        U : array_like, shape (..., d)
            Points in the unit box [0, 1]^d.

        Returns
        -------
        numpy.ndarray, shape (..., d)
            The same points in physical units (log coordinates mapped in log10).
        """
        lo, hi = self._ends()
        q = lo + np.asarray(U, dtype=float) * (hi - lo)
        return np.where(self.log, 10.0 ** np.where(self.log, q, 0.0), q)

    def to_unit(self, P) -> np.ndarray:
        """Map physical units to unit coordinates; the inverse of ``from_unit``.

        Parameters
        ----------
        P : array_like, shape (..., d)
            Points in physical units.

        Returns
        -------
        numpy.ndarray, shape (..., d)
            The same points in unit coordinates; NaN for P ≤ 0 on a log coordinate.

        Examples
        --------
        >>> box = Box(("k", "c"), [1.0, 0.0], [100.0, 5.0], [True, False])
        >>> box.to_unit([10.0, 2.5])
        array([0.5, 0.5])
        """
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

    Parameters
    ----------
    names : tuple of str
        Every coefficient, in the order results report them.
    units : dict
        {coefficient: unit} of every coefficient.
    fixed : tuple of (str, str)
        (name, signal) for the columns that do not depend on θ, the signal one of "x" (mm), "v"
        (mm/s), "a" (mm/s²), "1".
    varying : str
        The name of the coefficient of the θ-dependent column.
    branched : bool, default False
        The model switches its coefficients with the sign of ẋ, so each fixed column and the varying
        one are split into a '+' (ẋ ≥ 0) and a '−' part, named with the suffix.
    mass : str or None, default None
        The name of an inertia coefficient m of ẍ (the inertia rule of ``linear_solve`` decides
        whether the data can fit it), or None when the model has no inertia term.
    labels : dict, default {}
        {coefficient: label for figures}.

    Examples
    --------
    >>> LinearLayout(("k", "c", "alpha"), {"k": "N/mm", "c": "N·s/mm", "alpha": "N"},
    ...              fixed=(("k", "x"), ("c", "v")), varying="alpha")
    """

    names: tuple
    units: dict
    fixed: tuple
    varying: str
    branched: bool = False
    mass: str | None = None
    labels: dict = field(default_factory=dict)


class Model:
    """Base class of a model plug-in; subclass it and fill in the methods your model has.

    The class attributes describe the model: ``name`` (registry key, ``--model NAME``), ``title``,
    ``reference`` (where the equations come from), ``states`` (its state conventions, () when it has
    none), ``direct_name`` ("direct", or "paper" for the switched model), ``default_formulation``,
    ``viscous_sign_bound``, ``step_budget_stops``, ``sensitivity_cost`` and ``exploration_note``
    (see their comments).
    Every method takes ``state``, the state convention (None: the model's first, see
    ``check_state``). Signals are objects with attributes ``t, x, v, a`` (s, mm, mm/s, mm/s²),
    forces are in N. The methods of the direct formulation are required; those of the identifiable
    formulation and the checks of a fit are optional, with the defaults documented on each.

    Examples
    --------
    >>> class Dashpot(Model):
    ...     name = "dashpot"
    ...     def direct_parameters(self, state=None):
    ...         return (Parameter("c", "N·s/mm", "c"),)
    ...     def direct_box(self, signal, f, state=None):
    ...         return Box(("c",), [1e-3], [1e3], [True])
    ...     def force_batch(self, P, signal, state=None):
    ...         return np.asarray(P)[:, :1] * signal.v
    """

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
        """The formulations this model can be fitted in: its direct one, and "identifiable" if it has one.

        Returns
        -------
        tuple of str
            ``(direct_name,)`` or ``(direct_name, "identifiable")``.
        """
        return (self.direct_name, "identifiable") if self.has_linear_part else (self.direct_name,)

    @property
    def has_linear_part(self) -> bool:
        """Whether the model has the identifiable formulation (it overrides ``trajectories``).

        Returns
        -------
        bool
        """
        return type(self).trajectories is not Model.trajectories

    def check_state(self, state):
        """The state convention to use.

        Parameters
        ----------
        state : str or None
            The convention asked for; None for the model's first.

        Returns
        -------
        str or None
            ``state`` (or the model's first) if the model has it, else None (models without any).

        Raises
        ------
        ValueError
            When ``state`` is not one of ``states``.

        Examples
        --------
        >>> from bwbench.models import registry
        >>> registry.get("spencer").check_state(None) is None
        True
        """
        if not self.states:
            return None
        if state is None:
            return self.states[0]
        if state not in self.states:
            raise ValueError(f"state must be one of {self.states}, got {state!r}")
        return state

    # -- direct formulation -------------------------------------------------------------------
    def direct_parameters(self, state=None) -> tuple:
        """The published parameters of the direct formulation (required).

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        tuple of Parameter
            Names, units and labels, in the order of the rows of ``P``.
        """
        raise NotImplementedError

    def direct_box(self, signal, f, state=None) -> Box:
        """The search box of the direct formulation, scaled from the data (required).

        Parameters
        ----------
        signal : object
            The excitation: attributes ``t, x, v, a`` (s, mm, mm/s, mm/s²).
        f : array_like
            The measured force (N).
        state : str or None
            The state convention.

        Returns
        -------
        Box
        """
        raise NotImplementedError

    def force_batch(self, P, signal, state=None) -> np.ndarray:
        """Simulate the force of m parameter sets (required).

        Parameters
        ----------
        P : numpy.ndarray, shape (m, d)
            Direct parameters, one set per row, in physical units.
        signal : object
            The excitation: attributes ``t, x, v, a`` (s, mm, mm/s, mm/s²), L samples.
        state : str or None
            The state convention.

        Returns
        -------
        numpy.ndarray, shape (m, L)
            The forces (N); rows of +inf where the model blows up, never NaN, never an exception.

        Examples
        --------
        >>> model = registry.get("spencer")
        >>> F = model.force_batch(P, signal)   # P: (m, d), F: (m, len(signal.x)) in N
        """
        raise NotImplementedError

    def mse_batch(self, P, signal, f, state=None) -> np.ndarray:
        """MSE of each row of P against the measured force.

        Parameters
        ----------
        P : numpy.ndarray, shape (m, d)
            Direct parameters, one set per row.
        signal : object
            The excitation (attributes ``t, x, v, a``).
        f : array_like, shape (L,)
            The measured force (N).
        state : str or None
            The state convention.

        Returns
        -------
        numpy.ndarray, shape (m,)
            The MSE (N²) per row; +inf where the model blows up.

        Examples
        --------
        >>> model.mse_batch(P, signal, specimen.f)   # (m,) in N²
        """
        F = self.force_batch(P, signal, state)
        with np.errstate(invalid="ignore", over="ignore"):
            mse = np.mean((F - np.asarray(f, dtype=float)) ** 2, axis=1)
        return np.where(np.isfinite(mse), mse, np.inf)

    def force_sensitivities(self, P, signal, state=None):
        """The force and its sensitivities of one direct parameter vector, integrated together (optional).

        For exact Jacobians in the direct formulation.

        Parameters
        ----------
        P : numpy.ndarray, shape (d,)
            One set of direct parameters.
        signal : object
            The excitation (attributes ``t, x, v, a``), L samples.
        state : str or None
            The state convention.

        Returns
        -------
        tuple of (numpy.ndarray, numpy.ndarray) or None
            (force of shape (L,) in N, ∂force/∂P of shape (L, d)); None when the model has none
            (callers then take differences; the default).
        """
        return None

    @property
    def has_force_sensitivities(self) -> bool:
        """Whether the model overrides ``force_sensitivities``.

        Returns
        -------
        bool
        """
        return type(self).force_sensitivities is not Model.force_sensitivities

    # -- a cheaper simulation for a fit's exploring searches (optional) ------------------------
    # What ``exploring`` changes, in words, for the fit's message ("" for a model without one).
    exploration_note = ""

    def exploring(self, every: int = 1) -> Model:
        """A copy of this model that simulates more cheaply, for a fit's exploring searches (optional).

        A looser tolerance, a smaller step budget: for the local searches that explore before a fit's
        polish on the model itself. A model without one does not override it (``has_exploring``);
        ``exploration_note`` says what it changes, in words, for the fit's message.

        Parameters
        ----------
        every : int, default 1
            The record is kept every ``every``-th sample (a per-interval budget scales with it).

        Returns
        -------
        Model

        Raises
        ------
        NotImplementedError
            For a model without one (the default).

        Examples
        --------
        >>> model = registry.get("spencer")
        >>> cheap = model.exploring(every=2) if model.has_exploring else model
        """
        raise NotImplementedError

    @property
    def has_exploring(self) -> bool:
        """Whether the model overrides ``exploring``.

        Returns
        -------
        bool
        """
        return type(self).exploring is not Model.exploring

    # -- identifiable formulation (optional) --------------------------------------------------
    def hysteretic_parameters(self, state=None) -> tuple:
        """The nonlinear parameters θ searched in the identifiable formulation (optional).

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        tuple of Parameter
        """
        raise NotImplementedError

    def hysteretic_box(self, signal, f, state=None) -> Box:
        """The search box of θ, scaled from the data (optional, with ``hysteretic_parameters``).

        Parameters
        ----------
        signal : object
            The excitation (attributes ``t, x, v, a``).
        f : array_like
            The measured force (N).
        state : str or None
            The state convention.

        Returns
        -------
        Box
        """
        raise NotImplementedError

    def linear_layout(self, state=None) -> LinearLayout:
        """Which coefficients β the identifiable formulation solves, and their columns (optional).

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        LinearLayout
        """
        raise NotImplementedError

    def trajectories(self, theta, signal, state=None) -> np.ndarray:
        """The θ-dependent column of m θ rows (optional: a model that has it has the identifiable formulation).

        Parameters
        ----------
        theta : numpy.ndarray, shape (m, d)
            Hysteretic parameters, one set per row.
        signal : object
            The excitation (attributes ``t, x, v, a``), L samples.
        state : str or None
            The state convention.

        Returns
        -------
        numpy.ndarray, shape (m, L)
            The column per row; rows of +inf on blow-up.
        """
        raise NotImplementedError

    # What one simulation with its sensitivities (``trajectory_sensitivities``) costs, in plain
    # simulations (measured: benchmarks/bench_call_cost.py): what an exact Jacobian is charged against a
    # budget, so that a backend using it is compared fairly with one taking differences.
    sensitivity_cost = 0

    def trajectory_sensitivities(self, theta, signal, state=None):
        """The θ-dependent column and its sensitivities of one θ row, integrated together (optional).

        Parameters
        ----------
        theta : numpy.ndarray, shape (d,)
            One set of hysteretic parameters.
        signal : object
            The excitation (attributes ``t, x, v, a``), L samples.
        state : str or None
            The state convention.

        Returns
        -------
        tuple of (numpy.ndarray, numpy.ndarray) or None
            (z of shape (L,), ∂z/∂θ of shape (L, d)); None when the model has no sensitivities, or
            where they could not be had (then callers take differences); (z all +inf, None) where the
            simulation itself did not finish (blow-up, step budget), so the plain one would not
            either: callers need not run it. Default: None.
        """
        return None

    def to_direct(self, theta, coef: dict, state=None):
        """The direct parameters of the same loops as an identifiable (θ, coefficients) (optional).

        Coefficients the direct parameters cannot hold (an inertia other than the model's, a constant
        force offset) are left out: results report them beside.

        Parameters
        ----------
        theta : numpy.ndarray, shape (d,)
            The hysteretic parameters.
        coef : dict
            The solved coefficients by name.
        state : str or None
            The state convention.

        Returns
        -------
        numpy.ndarray or None
            The direct parameter vector, or None when there is none (the default).
        """
        return None

    def from_direct(self, P, state=None):
        """The identifiable form of one direct parameter vector; the inverse of ``to_direct``.

        Parameters
        ----------
        P : numpy.ndarray, shape (d,)
            The direct parameters.
        state : str or None
            The state convention.

        Returns
        -------
        tuple of (numpy.ndarray, dict)
            (θ, coefficients by name).
        """
        raise NotImplementedError

    # -- physical limits (optional) -------------------------------------------------------------
    def coefficient_limits(self, state=None) -> dict:
        """The physical limits of the coefficients the identifiable formulation solves (optional).

        They are applied (``linear_bounds.physical_bounds``) when the measured loops dissipate energy.

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        dict
            {solved coefficient: (lower, upper, why)}, ``why`` saying what the limit means; {} when
            the model has none (the default).
        """
        return {}

    def parameter_limits(self, state=None) -> dict:
        """The search-box edges that are physical limits, not search limits (optional).

        A spring that cannot be negative, say: a fit on one is a finding about the model or the data,
        not a box to widen.

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        dict
            {searched parameter: {"lower" | "upper": why}}; {} when the model has none (the default).
        """
        return {}

    def plausibility(self, values: dict, signal, state=None) -> list:
        """What each fitted parameter means physically and, where it is implausible, why (optional).

        Parameters
        ----------
        values : dict
            Every reported parameter of a fit, by name.
        signal : object
            The excitation (attributes ``t, x, v, a``).
        state : str or None
            The state convention.

        Returns
        -------
        list of tuple
            [(parameter, value, unit, meaning, verdict or "")]; [] when the model has no such table
            (the default).
        """
        return []

    # -- checks of a fit (optional) -----------------------------------------------------------
    def viscous_coefficients(self, values: dict, state=None) -> dict | None:
        """∂F/∂ẋ of a fit, per branch: used to turn a velocity error into a force error (optional).

        Parameters
        ----------
        values : dict
            The fit's parameters by name, any formulation.
        state : str or None
            The state convention.

        Returns
        -------
        dict or None
            ∂F/∂ẋ (N·s/mm) per branch ({"+": .., "-": ..} for a model that switches with the sign of
            ẋ, else {"": ..}); None when the model cannot say (the default).
        """
        return None

    def linear_branches(self, theta, trajectory, signal, state=None) -> dict:
        """Which fitted branches are linear in x, no yield within the stroke (optional).

        Parameters
        ----------
        theta : numpy.ndarray
            The identifiable θ.
        trajectory : numpy.ndarray
            Its θ-dependent column.
        signal : object
            The excitation (attributes ``t, x, v, a``).
        state : str or None
            The state convention.

        Returns
        -------
        dict
            {branch: True when the branch is linear}; {} when the model has no such notion (the default).
        """
        return {}

    def linear_limits(self, state=None) -> dict:
        """The shape parameters that make each branch linear until it yields (optional).

        For each branch (the keys of ``linear_branches``), the values of its shape parameters that
        make it linear until it yields, whatever its other parameters — what a posterior holds fixed
        when the data cannot tell the branch's shape from that (a reduced model,
        ``bwbench.optimizers.sampling.reduce``).

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        dict
            {branch: {identifiable parameter name: value}}; {} when the model has no such notion (the
            default).
        """
        return {}

    def yield_parameters(self, state=None) -> dict:
        """The parameter that sets where each branch of ``linear_limits`` yields (optional).

        A posterior holds it at the top of its box (the branch never yields within the stroke) when
        the data cannot tell that apart either.

        Parameters
        ----------
        state : str or None
            The state convention.

        Returns
        -------
        dict
            {branch: identifiable parameter name}; {} when the model has none (the default).
        """
        return {}

    def reduced_gauge(self, held, state=None) -> set:
        """The identifiable parameters a reduced model puts in its own gauge (optional).

        They trade with a held one along a direction the data do not see, so they cannot be compared
        with a truth or with fits of the full model.

        Parameters
        ----------
        held : iterable of str
            The names held fixed by the reduced model.
        state : str or None
            The state convention.

        Returns
        -------
        set of str
            Names of identifiable parameters (sampled or solved); empty by default.
        """
        return set()

    def symmetries(self, params, state=None) -> list:
        """The exact symmetries of the direct formulation at ``params`` (optional).

        Parameters
        ----------
        params : numpy.ndarray
            Direct parameters.
        state : str or None
            The state convention.

        Returns
        -------
        list of (str, callable)
            (name, orbit), ``orbit(s)`` giving the direct parameters moved by the scale s > 0 (s = 1:
            ``params``) with the force unchanged; [] when the model has none or none is known (the
            default).
        """
        return []


def amplitude(x) -> float:
    """Half the displacement range: the scale of every displacement-like bound.

    Parameters
    ----------
    x : array_like
        The displacement (mm).

    Returns
    -------
    float
        Half its range (mm).

    Raises
    ------
    ValueError
        When the displacement does not move.

    Examples
    --------
    >>> amplitude([-2.0, 0.0, 3.0])
    2.5
    """
    a = 0.5 * float(np.ptp(np.asarray(x, dtype=float)))
    if not a > 0:
        raise ValueError("the displacement does not move: no scale for the search box")
    return a


def velocity_scale(signal) -> float:
    """The largest |ẋ| of the excitation: the scale of every velocity-like bound.

    Parameters
    ----------
    signal : object
        The excitation, with its velocity ``v`` (mm/s).

    Returns
    -------
    float
        max |ẋ| (mm/s).

    Raises
    ------
    ValueError
        When the velocity is zero everywhere.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> velocity_scale(SimpleNamespace(v=[-40.0, 25.0]))
    40.0
    """
    v = float(np.max(np.abs(np.asarray(signal.v, dtype=float))))
    if not v > 0:
        raise ValueError("the velocity is zero everywhere: no scale for the search box")
    return v
