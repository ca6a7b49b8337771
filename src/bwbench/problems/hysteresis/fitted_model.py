"""A fitted model: every coefficient as stored, ready to simulate or predict the force of any test.

A fit result (``bwbench fit``'s JSON, a study run, ``bwbench.fit``) names the model, formulation,
state and excitation and holds every parameter by name. ``FittedModel`` rebuilds the force from
those numbers alone, nothing refitted:

- direct formulation: the model's own parameters through ``Model.force_batch``;
- identifiable: the θ-dependent column w(θ) simulated on the new excitation, then F = Σ β_j·g_j with
  the **stored** linear coefficients β (``linear_columns``; a branched model's '+' set where ẋ ≥ 0,
  its '−' set where ẋ < 0).

Every record starts as the fit's did (``initial_state``, ``warmup_s``: the rule of
``bwbench.models.start``, stored in the fit's JSON under "start"). ``predict`` adds the errors over
the samples after the warm-up: RMSE (N), and NRMSE = RMSE / max|F_measured| (–), the measure the MR-damper
literature reports. It is what ``bwbench predict``, ``evaluate``/``simulate`` given a fit result, the
report's held-out check and ``bwbench.FittedModel`` all use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bwbench.errors import UserError

IDENTIFIABLE = "identifiable"
EXCITATIONS = ("measured", "sine")


def _bare_unit(unit: str) -> str:
    """A unit without its note ("kg (the mass ...)" -> "kg") or spaces, for comparing."""
    return unit.split(" (", 1)[0].replace(" ", "")


@dataclass(frozen=True)
class Prediction:
    """The force a fitted model predicts on one record, against the measured one.

    Made by ``FittedModel.predict``. Its errors ``rmse_N`` (N), ``nrmse`` = RMSE/max|measured| (–)
    and ``mse`` (N²) are over the samples after the first ``warmup`` (the warm-up: simulated, not
    scored), and +inf when the model blows up on this record.

    Parameters
    ----------
    specimen : str
        The record's name.
    time_s : numpy.ndarray, shape (L,)
        Time (s).
    displacement_mm : numpy.ndarray, shape (L,)
        The displacement that drove the model (mm).
    force_N : numpy.ndarray, shape (L,)
        The predicted force (N).
    measured_N : numpy.ndarray, shape (L,)
        The measured force (N).
    velocity_mm_s : numpy.ndarray or None, default None
        The velocity that drove the model (mm/s), for the F–v loop.
    warmup : int, default 0
        Samples at the start simulated but not scored.
    quasi_static : bool, default False
        No time: ``time_s`` is the point's index, the velocity the direction of motion.
    offset_N : float or None, default None
        The constant force (N) re-solved on this record (``refit_offset``); None when every
        coefficient is as stored.

    Examples
    --------
    >>> p = bwbench.load_fit("fit.json").predict("othertest.csv")
    >>> p.rmse_N, p.nrmse
    >>> p.frame().head()
    """

    specimen: str
    time_s: np.ndarray
    displacement_mm: np.ndarray
    force_N: np.ndarray
    measured_N: np.ndarray
    velocity_mm_s: np.ndarray | None = field(default=None, repr=False)  # what drove the model (for the F–v loop)
    warmup: int = 0  # samples at the start simulated but not scored
    quasi_static: bool = False  # no time: time_s is the point's index, the velocity the direction of motion
    # The constant force (N) re-solved on this record and added to the stored model's (``refit_offset``);
    # None when every coefficient is as stored.
    offset_N: float | None = None

    @property
    def n(self) -> int:
        """The number of samples scored (after the warm-up).

        Returns
        -------
        int
        """
        return len(self.measured_N) - self.warmup

    @property
    def reversals(self) -> int:
        """How many times the motion reverses (``models.protocol.reversals``): a figure zooms in on a long record."""
        from bwbench.models.protocol import reversals

        return len(reversals(self.displacement_mm))

    @property
    def mse(self) -> float:
        """The mean squared error of the predicted force.

        Returns
        -------
        float
            MSE (N²); +inf when the model blows up on this record.
        """
        with np.errstate(over="ignore", invalid="ignore"):
            value = float(np.mean((self.force_N - self.measured_N)[self.warmup :] ** 2))
        return value if math.isfinite(value) else math.inf

    @property
    def rmse_N(self) -> float:
        """The root mean squared error of the predicted force.

        Returns
        -------
        float
            RMSE (N); +inf when the model blows up on this record.
        """
        return math.sqrt(self.mse)

    @property
    def nrmse(self) -> float:
        """The RMSE over the largest measured force magnitude, the MR-damper literature's measure.

        Returns
        -------
        float
            RMSE / max|F measured| (–) over the samples scored; +inf when the model blows up or the
            force is zero.
        """
        peak = float(np.max(np.abs(self.measured_N[self.warmup :])))
        return self.rmse_N / peak if peak > 0 else math.inf

    @property
    def warmup_s(self) -> float:
        """The span of the warm-up (s)."""
        return float(self.time_s[self.warmup] - self.time_s[0]) if self.warmup else 0.0

    def metrics(self) -> dict:
        """The numbers of this prediction by name, and their units.

        Returns
        -------
        dict
            specimen, n, mse (N²), rmse_N (N), nrmse (–), max_abs_force_N (N), and ``units``:
            {name: unit}.

        Examples
        --------
        >>> bwbench.load_fit("fit.json").predict("othertest.csv").metrics()["rmse_N"]
        """
        return {
            "specimen": self.specimen,
            "n": self.n,
            "mse": self.mse,
            "rmse_N": self.rmse_N,
            "nrmse": self.nrmse,
            "max_abs_force_N": float(np.max(np.abs(self.measured_N[self.warmup :]))),
            "warmup_samples": self.warmup,
            **({} if self.offset_N is None else {"refitted_offset_N": self.offset_N}),
            "units": {
                **({} if self.offset_N is None else {"refitted_offset_N": "N (added to the stored constant force)"}),
                "mse": "N²",
                "rmse_N": "N",
                "nrmse": "– (RMSE / max|F measured|)",
                "max_abs_force_N": "N",
                "n": "samples (after the warm-up)",
                "warmup_samples": "samples",
            },
        }

    def frame(self):
        """The prediction as a table.

        Returns
        -------
        pandas.DataFrame
            time_s, displacement_mm, force_measured_N, force_model_N, residual_N.

        Examples
        --------
        >>> p = bwbench.load_fit("fit.json").predict("othertest.csv")
        >>> p.frame().to_csv("prediction.csv", index=False)
        """
        import pandas as pd

        return pd.DataFrame(
            {
                "time_s": self.time_s,
                "displacement_mm": self.displacement_mm,
                "force_measured_N": self.measured_N,
                "force_model_N": self.force_N,
                "residual_N": self.force_N - self.measured_N,
            }
        )

    def plot(self, ax=None):
        """Plot the prediction: loops F–x and F–v, force and residual against time, measured and predicted.

        The global backend and rcParams are left as they were.

        Parameters
        ----------
        ax : matplotlib.axes.Axes or sequence of Axes or None, default None
            Draw into it instead.

        Returns
        -------
        matplotlib.figure.Figure

        Examples
        --------
        >>> bwbench.load_fit("fit.json").predict("othertest.csv").plot().savefig("prediction.png")
        """
        from bwbench.render import fit_plots

        return fit_plots.figure([self], f"prediction of {self.specimen}", ax)

    def __repr__(self) -> str:
        from bwbench.render import reprs

        return reprs.prediction_repr(self)

    def _repr_html_(self) -> str:
        from bwbench.render import reprs

        return reprs.prediction_html(self)


@dataclass(frozen=True)
class FittedModel:
    """One model with every coefficient fixed (physical units, by name; see the module docstring).

    Parameters
    ----------
    model : str
        A registered model name (``bwbench models``).
    formulation : str
        Its direct one or "identifiable".
    params : dict
        Every parameter the formulation needs, by name, in physical units.
    state : str or None, default None
        The state convention (None for a model without one).
    excitation : str, default "measured"
        "measured" or "sine".
    units : dict, default {}
        Their units (for the record).
    initial_state : str, default "auto"
        How every record starts ("auto", "rest", "pre-roll": ``bwbench.models.start``), as the fit
        started its own.
    warmup_s : float, default 0
        Seconds at the start of each record simulated but not scored.

    Raises
    ------
    bwbench.UserError
        Naming the key, for a field of the wrong type, an unknown model, formulation, state or
        excitation, a missing parameter, or one outside its model's domain (not finite, an exponent
        n ≤ 0).

    Examples
    --------
    >>> model = bwbench.load_fit("fit.json")
    >>> model.predict("othertest.csv").rmse_N
    >>> model.simulate("othertest.csv").to_csv("simulated.csv", index=False)
    """

    model: str
    formulation: str
    params: dict
    state: str | None = None
    excitation: str = "measured"
    units: dict = field(default_factory=dict)
    initial_state: str = "auto"
    warmup_s: float = 0.0

    def __post_init__(self):
        from bwbench.models import registry

        for key, value, kind in (
            ("model", self.model, str),
            ("formulation", self.formulation, str),
            ("params", self.params, dict),
            ("units", self.units, dict),
            ("excitation", self.excitation, str),
        ):
            if not isinstance(value, kind) or (kind is str and not value):
                raise UserError(f'"{key}" is {value!r}: it must be a {"name" if kind is str else "JSON object"}')
        if self.excitation not in EXCITATIONS:
            raise UserError(f'"excitation" is {self.excitation!r}: it must be one of {", ".join(EXCITATIONS)}')
        if self.state is not None and not isinstance(self.state, str):
            raise UserError(f'"state" is {self.state!r}: it must be a name or null')
        from bwbench.models import start

        start.check(self.initial_state, self.warmup_s, ('"start.initial_state"', '"start.warmup_s"'))
        model = registry.get(self.model)
        if self.formulation not in model.formulations:
            raise UserError(
                f"model {self.model!r} has no formulation {self.formulation!r}; it has {', '.join(model.formulations)}"
            )
        object.__setattr__(self, "state", model.check_state(self.state) if model.states else None)
        missing = [n for n in self.needed() if not isinstance(self.params.get(n), (int, float))]
        if missing:
            raise UserError(
                f"the {self.formulation} formulation of {self.model} needs {', '.join(missing)}: "
                "not in these parameters"
            )
        self._check_domain()
        self._check_units()

    def _check_units(self) -> None:
        """Refuse a parameter whose stated unit is not the one bwbench computes with.

        ``UserError`` naming the key: a fit converted by hand to SI (m, m^-n) would otherwise be read
        in mm and its force be off by orders of magnitude, with no word.
        """
        model = self._model
        expected = {p.name: p.unit for p in model.direct_parameters(self.state)}
        expected.update({p.name: p.unit for p in model.hysteretic_parameters(self.state)})
        if self.formulation == IDENTIFIABLE:
            from bwbench.problems.hysteresis.linear.columns import coefficient_units

            expected.update(coefficient_units(model.linear_layout(self.state)))
        # every stated parameter, not only the needed ones: an identifiable fit also stores the paper's
        # form, and a file converted there is as wrong as one converted in the coefficients it uses
        for name in dict.fromkeys([*self.needed(), *self.params]):
            stated, unit = self.units.get(name), expected.get(name)
            if not isinstance(stated, str) or unit is None:
                continue  # not stated (a hand-written parameter file): read in bwbench's units
            if _bare_unit(stated) != _bare_unit(unit):
                raise UserError(
                    f'units.{name} is "{stated}", but bwbench computes {name} in "{_bare_unit(unit)}" (mm, N, s): '
                    "convert the value back, or refit in those units"
                )

    def _check_domain(self) -> None:
        """``UserError`` naming the key for a parameter outside its model's domain.

        Not finite (only a solved coefficient of a branch the fit's data never had may be null), or an
        exponent n ≤ 0.
        """
        coefficients = set()
        if self.formulation == IDENTIFIABLE:
            from bwbench.problems.hysteresis.linear.columns import coefficient_names

            coefficients = set(coefficient_names(self._model.linear_layout(self.state)))
        for name in self.needed():
            value = float(self.params[name])
            if math.isnan(value) and name in coefficients:
                continue  # null: the fit's data never moved in that branch (``force`` says so if it must)
            if not math.isfinite(value):
                raise UserError(f"params.{name} is {self.params[name]!r}: not a finite number")
            if name.rstrip("+-") == "n" and value <= 0:
                raise UserError(f"params.{name} is {value:g}: an exponent of the hysteresis must be > 0")

    @property
    def _model(self):
        from bwbench.models import registry

        return registry.get(self.model)

    def needed(self) -> tuple:
        """The parameter names the force needs in this formulation.

        Returns
        -------
        tuple of str
        """
        model = self._model
        if self.formulation != IDENTIFIABLE:
            return tuple(p.name for p in model.direct_parameters(self.state))
        from bwbench.problems.hysteresis.linear.columns import coefficient_names

        return tuple(p.name for p in model.hysteretic_parameters(self.state)) + coefficient_names(
            model.linear_layout(self.state)
        )

    @classmethod
    def from_result(cls, data: dict, source: str = "the fit result") -> "FittedModel":
        """The fitted model of a result dict (``bwbench fit``'s JSON).

        Parameters
        ----------
        data : dict
            The result: its model (default: the switched model, for results written before the key),
            formulation, state, excitation and params (null for a coefficient the fit could not have).
        source : str, default "the fit result"
            What names the result in an error message.

        Returns
        -------
        FittedModel

        Raises
        ------
        bwbench.UserError
            Starting with ``source``, when ``data`` is not a fit result or cannot make a model.

        Examples
        --------
        >>> import json
        >>> FittedModel.from_result(json.load(open("fit.json")), "fit.json")
        """
        from bwbench.models import registry

        if not isinstance(data, dict) or not isinstance(data.get("params"), dict):
            raise UserError(f'{source}: not a fit result (no "params" object)')
        if "formulation" not in data:
            raise UserError(
                f'{source}: not a fit result (no "formulation"): give --formulation and --model '
                "to read it as a parameter file"
            )
        name = data.get("model") or registry.DEFAULT
        start = data.get("start", {})  # absent (a result written before the rule, or by hand): the default
        # null is how strict JSON writes a coefficient the fit could not have (a branch without samples)
        params = {
            k: math.nan if v is None else v
            for k, v in data["params"].items()
            if v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))
        }
        try:
            units = data.get("units") or {}
            if not isinstance(units, dict):
                raise UserError(f'"units" is a JSON {type(units).__name__}, not an object of name -> unit')
            if not isinstance(name, str):
                raise UserError(f'"model" is {name!r}: it must be a model name (see `bwbench models`)')
            if not isinstance(start, dict):
                raise UserError(f'"start" is {start!r}: it must be an object with initial_state and warmup_s')
            return cls(
                name,
                data["formulation"],
                params,
                data.get("state"),
                data.get("excitation", "measured"),
                dict(units),
                start.get("initial_state", "auto"),
                start.get("warmup_s", 0.0),
            )
        except UserError as err:
            raise UserError(f"{source}: {err}") from None

    @classmethod
    def from_run(cls, run, start: dict | None = None) -> "FittedModel":
        """The fitted model of a study's run, started as the study started its records.

        A column the database left empty (NaN, None, "") takes its default: a model without states
        stores none.

        Parameters
        ----------
        run : mapping
            A row of ``Study.runs``: model, formulation, state, excitation, params_json.
        start : dict or None, default None
            ``initial_state`` and ``warmup_s`` as the study started its records (None: the defaults).

        Returns
        -------
        FittedModel

        Raises
        ------
        bwbench.UserError
            When the run's parameters cannot make a model.

        Examples
        --------
        >>> runs = bwbench.load_study("study.sqlite").runs
        >>> FittedModel.from_run(runs.iloc[0]).predict("othertest.csv")
        """
        import json

        def text(key, default):
            value = run.get(key)
            return value if isinstance(value, str) and value else default

        raw = run.get("params_json")
        params = json.loads(raw) if isinstance(raw, str) else {}
        params = {k: math.nan if v is None else v for k, v in params.items()}
        from bwbench.models import registry

        return cls(
            text("model", registry.DEFAULT),
            text("formulation", "paper"),
            params,
            text("state", None),
            text("excitation", "measured"),
            **(start or {}),
        )

    @classmethod
    def read(cls, path) -> "FittedModel":
        """The fitted model of a result JSON file (``bwbench.load_fit``).

        Parameters
        ----------
        path : str or pathlib.Path
            The result JSON.

        Returns
        -------
        FittedModel

        Raises
        ------
        bwbench.UserError
            Naming the file, for anything wrong.

        Examples
        --------
        >>> FittedModel.read("fit.json")
        """
        from bwbench.data.json_input import read_json_file

        return cls.from_result(read_json_file(Path(path)), str(path))

    def describe(self) -> str:
        """The model in words.

        Returns
        -------
        str
            E.g. "spencer (direct formulation, measured excitation)".
        """
        state = f", {self.state} state" if self.state else ""
        start = f", initial state {self.initial_state}" + (f", warm-up {self.warmup_s:g} s" if self.warmup_s else "")
        return f"{self.model} ({self.formulation} formulation{state}, {self.excitation} excitation{start})"

    def signal(self, specimen):
        """The excitation this model is driven by on a specimen.

        Parameters
        ----------
        specimen : Specimen
            The record.

        Returns
        -------
        object
            The signal, with attributes ``t, x, v, a`` (s, mm, mm/s, mm/s²).
        """
        from bwbench.models import excitation

        return excitation.of_specimen(self.excitation, specimen)

    def start(self, signal, f=None):
        """How a record starts: the fit's rule applied to ``signal``.

        Parameters
        ----------
        signal : object
            The excitation: attributes ``t, x, v, a`` (s, mm, mm/s, mm/s²).
        f : numpy.ndarray or None, default None
            Its measured force (N), when there is one.

        Returns
        -------
        bwbench.models.start.Start
        """
        from bwbench.models import start

        return start.plan(signal, self.initial_state, self.warmup_s, f=f)

    def force(self, signal, f=None) -> np.ndarray:
        """The model force on an excitation, started by the fit's rule.

        Parameters
        ----------
        signal : object
            The excitation: attributes ``t, x, v, a`` (s, mm, mm/s, mm/s²).
        f : numpy.ndarray or None, default None
            Its measured force (N), when there is one (None: none known).

        Returns
        -------
        numpy.ndarray, shape (L,)
            The force (N); +inf everywhere where the model blows up.

        Raises
        ------
        bwbench.UserError
            When the record moves in a direction whose coefficients the fit never saw.

        Examples
        --------
        >>> from bwbench.data.specimen import read_specimen
        >>> model = bwbench.load_fit("fit.json")
        >>> model.force(model.signal(read_specimen("othertest.csv")))   # (L,) in N
        """
        model = self._model
        start = self.start(signal, f)
        simulated = start.extend(signal)
        if self.formulation != IDENTIFIABLE:
            P = np.array([self.params[n] for n in self.needed()], dtype=float)
            return start.crop(model.force_batch(P[None, :], simulated, self.state))[0]

        from bwbench.problems.hysteresis.linear.columns import linear_force

        theta = np.array([self.params[p.name] for p in model.hysteretic_parameters(self.state)], dtype=float)
        w = start.crop(model.trajectories(theta[None, :], simulated, self.state))[0]
        return linear_force(model.linear_layout(self.state), self.params, signal, w, strict=True)

    def predict(self, specimen, refit_offset: bool = False) -> Prediction:
        """The force on a specimen against its measured one.

        The file is read and checked as every command does: a dead channel refused, the rest of data
        check's warnings printed.

        Parameters
        ----------
        specimen : str, pathlib.Path, Specimen or pandas.DataFrame
            A specimen CSV's path, a ``Specimen`` or a DataFrame with the file's columns (``time_s``,
            ``displacement_mm``, ``force_N``, optionally ``velocity_mm_s``, ``acceleration_mm_s2``).
        refit_offset : bool, default False
            Re-solve the constant force on this record (least squares: the mean of measured −
            predicted, added to the stored model's) — for a record from another test set-up, whose
            load cell reads another zero; every other coefficient as stored.

        Returns
        -------
        Prediction

        Raises
        ------
        bwbench.UserError
            For a file that cannot be read, or a record the fitted coefficients cannot drive.

        Examples
        --------
        >>> bwbench.load_fit("fit.json").predict("othertest.csv").nrmse
        """
        spec = _specimen(specimen)
        signal = self.signal(spec)
        start = self.start(signal, spec.f)
        force = self.force(signal, spec.f)
        measured = np.asarray(spec.f, dtype=float)
        offset = None
        if refit_offset and np.all(np.isfinite(force)):
            offset = float(np.mean((measured - force)[start.warmup :]))  # over the samples scored
            force = force + offset
        return Prediction(
            spec.name,
            np.asarray(spec.t, dtype=float),
            np.asarray(signal.x, dtype=float),
            force,
            measured,
            np.asarray(signal.v, dtype=float),
            warmup=start.warmup,
            quasi_static=bool(getattr(signal, "rate_independent", False)),
            offset_N=offset,
        )

    def simulate(self, specimen):
        """``predict(specimen).frame()`` with the velocity and acceleration that drove the model.

        Parameters
        ----------
        specimen : str, pathlib.Path, Specimen or pandas.DataFrame
            A specimen CSV's path, a ``Specimen`` or a DataFrame with the file's columns (``time_s``,
            ``displacement_mm``, ``force_N``, optionally ``velocity_mm_s``, ``acceleration_mm_s2``).

        Returns
        -------
        pandas.DataFrame
            time_s, displacement_mm, velocity_mm_s, acceleration_mm_s2, force_model_N,
            force_measured_N.

        Raises
        ------
        bwbench.UserError
            As ``predict``.

        Examples
        --------
        >>> bwbench.load_fit("fit.json").simulate("othertest.csv").head()
        """
        import pandas as pd

        spec = _specimen(specimen)
        s = self.signal(spec)
        return pd.DataFrame(
            {
                "time_s": s.t,
                "displacement_mm": s.x,
                "velocity_mm_s": s.v,
                "acceleration_mm_s2": s.a,
                "force_model_N": self.force(s, spec.f),
                "force_measured_N": spec.f,
            }
        )

    def __repr__(self) -> str:
        from bwbench.render import reprs

        return reprs.model_repr(self)

    def _repr_html_(self) -> str:
        from bwbench.render import reprs

        return reprs.model_html(self)

    def to_dict(self) -> dict:
        """What a result JSON holds of this model.

        Returns
        -------
        dict
            model, formulation, state, excitation, params, units.

        Examples
        --------
        >>> bwbench.load_fit("fit.json").to_dict()["formulation"]
        'identifiable'
        """
        return {
            "model": self.model,
            "formulation": self.formulation,
            "state": self.state,
            "excitation": self.excitation,
            "params": dict(self.params),
            "units": dict(self.units),
            "start": {"initial_state": self.initial_state, "warmup_s": self.warmup_s},
        }


def _specimen(specimen):
    """A ``Specimen`` from a path or a DataFrame with the file's columns, or as given.

    Read and checked as every command does: a dead channel refused, the rest of data check's
    warnings printed; ``UserError`` for anything else.
    """
    from bwbench.data import plausibility
    from bwbench.data.specimen import Specimen
    from bwbench.data.specimen_input import as_specimen

    if isinstance(specimen, Specimen):
        return specimen
    if isinstance(specimen, (str, Path)) and not str(specimen).strip():
        raise UserError(f"a specimen must be a path to a specimen CSV, a Specimen or a DataFrame, got {specimen!r}")
    spec = as_specimen(specimen)
    plausibility.screen([spec], force_needed=False)
    return spec
