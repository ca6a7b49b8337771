"""A model fitted across the control range, as it predicts: every coefficient stored, the laws with them.

``ControlledModel`` holds the plain model's description (model, formulation, state, excitation), the
fitted values by name (the laws' coefficients among them) and the result's ``control`` block (the
control's name, the laws and their nodes). At one control level it is the plain model with the laws
evaluated there (``at``); on a record whose control varies it integrates with per-sample parameters
(Spencer's model), through the fitted first-order lag when there is one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bwbench.errors import UserError
from bwbench.problems.hysteresis.control import laws as laws_mod
from bwbench.problems.hysteresis.control.lag import FILTER, filtered


def _law(entry):
    return laws_mod.law_of(entry["law"])


def value_at(control: dict, params: dict, name: str, u, objects: dict | None = None) -> np.ndarray:
    """The parameter ``name`` at controls u (L,): its law's value, or its stored constant. ``objects``:
    the fit's own ``Law`` objects by parameter (a user's ``CallableLaw`` is not in the JSON)."""
    u = np.atleast_1d(np.asarray(u, dtype=float))
    entry = control.get("laws", {}).get(name)
    if entry is None or not isinstance(entry, dict):
        return np.full(len(u), float(params[name]))
    law = (objects or {}).get(name)
    if law is None:
        if entry["law"] not in laws_mod.BUILT_IN:
            raise UserError(f"{name} follows a user's law ({entry['law']}): predict with the fit's own model in Python")
        law = _law(entry)
    c = np.array([params[k] for k in entry["coefficients"]], dtype=float)
    return law.value(c, u, np.asarray(entry.get("nodes", control.get("law_nodes")), dtype=float))


def parameters_at(control: dict, params: dict, level: float, objects: dict | None = None) -> dict:
    """The plain model's parameters by name at one control level."""
    owned = {k for entry in control.get("laws", {}).values() for k in entry.get("coefficients", ())}
    out = {k: v for k, v in params.items() if k not in owned and k != FILTER}
    for name in control.get("laws", {}):
        out[name] = float(value_at(control, params, name, [level], objects)[0])
    return out


@dataclass(frozen=True, eq=False)
class ControlledModel:
    """See the module docstring."""

    model: str
    formulation: str
    params: dict
    control: dict
    state: str | None = None
    excitation: str = "measured"
    units: dict = field(default_factory=dict)
    objects: dict = field(default_factory=dict, repr=False)  # the fit's Law objects (a CallableLaw)

    @classmethod
    def from_result(cls, data: dict, source: str = "the fit result") -> "ControlledModel":
        control = data.get("control")
        if not isinstance(control, dict) or not isinstance(control.get("laws"), dict):
            raise UserError(f'{source}: not a fit across a control (no "control" block)')
        params = {k: (math.nan if v is None else v) for k, v in data["params"].items()}
        return cls(
            data.get("model") or "switched-bouc-wen",
            data["formulation"],
            params,
            control,
            data.get("state"),
            data.get("excitation", "measured"),
            dict(data.get("units") or {}),
        )

    @property
    def control_name(self) -> str:
        return self.control["name"]

    def describe(self) -> str:
        state = f", {self.state} state" if self.state else ""
        laws = ", ".join(f"{n} {e['law']}" for n, e in self.control.get("laws", {}).items()) or "no law"
        return f"{self.model} ({self.formulation} formulation{state}) across {self.control_name}: {laws}"

    def to_dict(self) -> dict:
        return {
            "model": self.model,
            "formulation": self.formulation,
            "state": self.state,
            "excitation": self.excitation,
            "params": dict(self.params),
            "units": dict(self.units),
            "control": dict(self.control),
        }

    def at(self, level: float):
        """The plain ``FittedModel`` at one control level."""
        from bwbench.problems.hysteresis.fitted_model import FittedModel

        return FittedModel(
            self.model,
            self.formulation,
            parameters_at(self.control, self.params, float(level), self.objects),
            self.state,
            self.excitation,
        )

    def predict(self, specimen, refit_offset: bool = False):
        """The force on ``specimen`` (a ``Specimen`` with its control) against its measured one;
        ``refit_offset``: the constant force re-solved on this record (as ``FittedModel.predict``)."""
        from bwbench.problems.hysteresis.fitted_model import Prediction

        specimen = self._read(specimen)  # a path or a DataFrame: read with this model's control
        if specimen.control is None:
            raise UserError(
                f"{specimen.path}: no {self.control_name} for this file: the model's parameters depend on it"
            )
        u = np.asarray(specimen.control, dtype=float)
        plain = self.at(float(u[0]))
        signal = plain.signal(specimen)
        if np.ptp(u) == 0 and FILTER not in self.params:
            force = plain.force(signal)
        else:
            force = self.force_varying(signal, u, np.diff(np.asarray(specimen.t, dtype=float)))
        measured = np.asarray(specimen.f, dtype=float)
        offset = None
        if refit_offset and np.all(np.isfinite(force)):
            offset = float(np.mean(measured - force))  # least squares: the mean of measured − predicted
            force = force + offset
        return Prediction(
            specimen.name,
            np.asarray(specimen.t, dtype=float),
            np.asarray(signal.x, dtype=float),
            force,
            measured,
            np.asarray(signal.v, dtype=float),
            offset_N=offset,
        )

    def simulate(self, specimen):
        """``predict(specimen)`` as a pandas DataFrame: time_s, displacement_mm, velocity_mm_s, the control,
        force_model_N, force_measured_N (``bwbench simulate --params FIT.json``)."""
        import pandas as pd

        prediction = self.predict(specimen)
        spec = self._read(specimen)
        return pd.DataFrame(
            {
                "time_s": prediction.time_s,
                "displacement_mm": prediction.displacement_mm,
                "velocity_mm_s": prediction.velocity_mm_s,
                self.control_name: np.asarray(spec.control, dtype=float),
                "force_model_N": prediction.force_N,
                "force_measured_N": prediction.measured_N,
            }
        )

    def _read(self, specimen):
        """``specimen`` (a path, DataFrame or ``Specimen``) with this model's control."""
        if hasattr(specimen, "control"):
            return specimen
        from bwbench.data import control as control_mod
        from bwbench.data.specimen_input import as_specimen

        spec = control_mod.ControlSpec(self.control_name)
        if isinstance(specimen, (str, Path)):
            return control_mod.read(specimen, spec)
        return control_mod.attach(as_specimen(specimen), spec)

    def force_varying(self, signal, command, dt) -> np.ndarray:
        """The force (N) on a record whose control changes (per-sample parameters; Spencer's model)."""
        from bwbench.models import registry

        model: Any = registry.get(self.model)
        if not hasattr(model, "trajectories_varying"):
            raise UserError(
                f"the control varies within the record: model {self.model!r} takes no per-sample parameters"
            )
        eta = self.params.get(FILTER)
        u_smp, u_int = filtered(command, dt, float(eta)) if eta is not None else (command, command[:-1])
        if self.formulation != "identifiable":
            names = [p.name for p in model.direct_parameters(self.state)]
            P_int = np.column_stack([value_at(self.control, self.params, n, u_int, self.objects) for n in names])
            P_smp = np.column_stack([value_at(self.control, self.params, n, u_smp, self.objects) for n in names])
            return model.force_varying(P_int, P_smp, signal, self.state)
        from bwbench.problems.hysteresis.linear.columns import branch_masks, signal_column

        names = [p.name for p in model.hysteretic_parameters(self.state)]
        T_int = np.column_stack([value_at(self.control, self.params, n, u_int, self.objects) for n in names])
        T_smp = np.column_stack([value_at(self.control, self.params, n, u_smp, self.objects) for n in names])
        w = model.trajectories_varying(T_int, T_smp, signal, self.state)
        layout = model.linear_layout(self.state)
        F = np.zeros(len(signal.x))
        if layout.mass:
            F += value_at(self.control, self.params, layout.mass, u_smp, self.objects) * np.asarray(
                signal.a, dtype=float
            )
        for b, mask in branch_masks(layout, signal.v).items():
            if not mask.any():
                continue
            for name, source in layout.fixed:
                if f"{name}{b}" in self.params or f"{name}{b}" in self.control.get("laws", {}):
                    F += value_at(self.control, self.params, f"{name}{b}", u_smp, self.objects) * signal_column(
                        signal, source, mask
                    )
            with np.errstate(invalid="ignore", over="ignore"):
                F += value_at(self.control, self.params, f"{layout.varying}{b}", u_smp, self.objects) * np.where(
                    mask, w, 0.0
                )
        return F if np.all(np.isfinite(F)) else np.full(len(F), np.inf)


def of_problem(problem, params) -> ControlledModel:
    """The ``ControlledModel`` of a ``ControlledProblem`` at ``params`` (by name, or the searched vector)."""
    values = params if isinstance(params, dict) else problem.parameters(params)
    return ControlledModel(
        problem.model.name,
        problem.formulation,
        dict(values),
        problem.laws_json(values),
        problem.state,
        problem.excitation,
        problem.units(list(values)),
        dict(problem.laws),
    )


def model_of_result(data: dict, source: str = "the fit result"):
    """The model a fit result JSON holds: a ``ControlledModel`` when it has laws of a control, else the
    plain ``FittedModel``."""
    from bwbench.problems.hysteresis.fitted_model import FittedModel

    if isinstance(data, dict) and isinstance(data.get("control"), dict):
        return ControlledModel.from_result(data, source)
    return FittedModel.from_result(data, source)
