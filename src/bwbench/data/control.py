"""The control channel of a test: the current, voltage or underpressure that sets a damper's force.

A controllable damper (an MR damper's current or voltage, a vacuum-packed-particle damper's
underpressure) is tested at several control levels, or under a control that changes during the test.
Its value at each sample comes from one of:

- a column of the specimen CSV named ``<quantity>_<unit>`` (``current_A``, ``voltage_V``,
  ``underpressure_MPa``), read when the control is named (``--control current_A``);
- a level per file: the ``levels`` a caller gives (a study TOML's ``control = 0.5`` per specimen,
  the API's ``control_levels``), or the file's entry in the ``manifest.json`` beside it (a field of the
  control's name, as the shipped specimens carry ``underpressure_MPa``);
- one constant for every file that has no column (``--control current_A=0.5``).

A file's level may come from one source only: a column and a level for the same file, or two levels
that differ, is refused ("given twice"), as is a file with none. Every value must be finite.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bwbench.errors import InputFileError, UserError

# <quantity>_<unit>: the quantity may hold underscores (magnetic_field_T), the unit is the last part.
_NAME = re.compile(r"(?P<quantity>[A-Za-z][A-Za-z0-9]*(?:_[A-Za-z0-9]+)*?)_(?P<unit>[A-Za-zµΩ%][A-Za-z0-9µΩ%]*)")
# The specimen's own columns cannot be a control.
_OWN = ("time_s", "displacement_mm", "force_N", "velocity_mm_s", "acceleration_mm_s2")
# More distinct values than this, and the control is reported as a range, not as levels.
MAX_LEVELS = 12


@dataclass(frozen=True)
class ControlSpec:
    """A control named on the command line or in the API: its column ``name`` and the ``value`` for every
    file that has no such column (None: each file must have the column or a level of its own)."""

    name: str
    value: float | None = None

    @property
    def quantity(self) -> str:
        return _split(self.name)[0]

    @property
    def unit(self) -> str:
        return _split(self.name)[1]


def _split(name: str) -> tuple[str, str]:
    match = _NAME.fullmatch(name)
    if match is None:
        raise UserError(
            f"--control {name!r}: a control is named <quantity>_<unit>, e.g. current_A, voltage_V, underpressure_MPa"
        )
    return match["quantity"], match["unit"]


def parse(text) -> ControlSpec:
    """``COLUMN`` or ``COLUMN=VALUE`` (``--control current_A=0.5``) as a ``ControlSpec``; ``UserError``
    for a name that is not ``<quantity>_<unit>``, a specimen column, or a value that is not a finite number."""
    if isinstance(text, ControlSpec):
        return text
    if not isinstance(text, str) or not text.strip():
        raise UserError(f"--control must be COLUMN or COLUMN=VALUE (e.g. current_A=0.5), got {text!r}")
    name, sep, value = (part.strip() for part in text.partition("="))
    _split(name)
    if name in _OWN:
        raise UserError(f"--control {name}: that is a column of every specimen, not a control")
    if not sep:
        return ControlSpec(name)
    try:
        number = float(value)
    except ValueError:
        raise UserError(f"--control {text}: the level {value!r} is not a number") from None
    if not math.isfinite(number):
        raise UserError(f"--control {text}: the level must be a finite number")
    return ControlSpec(name, number)


def parse_all(texts) -> ControlSpec | None:
    """The one control of several ``--control`` flags (None when there are none); a control named twice
    (``--control current_A=0.5 --control current_A=1``) or two controls are refused."""
    specs = [parse(t) for t in (texts or ())]
    if not specs:
        return None
    names = [s.name for s in specs]
    if len(set(names)) > 1:
        raise UserError(f"--control names {' and '.join(dict.fromkeys(names))}: a fit has one control")
    if len(specs) > 1:
        raise UserError(f"--control {names[0]} is given twice: give one level for the files without the column")
    return specs[0]


def levels_of(levels, spec: ControlSpec) -> dict:
    """{file path or name: level} checked: every level a finite number."""
    out = {}
    for key, value in (levels or {}).items():
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise UserError(f"{key}: the {spec.name} level must be a finite number, got {value!r}")
        out[str(key)] = float(value)
    return out


def read(path, spec: ControlSpec, level: float | None = None):
    """The specimen of the CSV ``path`` with its control: its column ``spec.name``, else ``level`` (the
    file's own), its manifest's field, or ``spec.value``; ``UserError`` naming the file when it has
    none or two (see the module docstring)."""
    from bwbench.data.specimen import read_specimen

    return attach(read_specimen(path, control=spec.name), spec, level)


def attach(specimen, spec: ControlSpec, level: float | None = None):
    """``specimen`` (a ``Specimen``, its control column read or not) with its control resolved."""
    where = specimen.path
    entry = _manifest_level(specimen.path, spec.name)
    if specimen.control is not None:
        if level is not None:
            raise UserError(
                f"{where}: the {spec.name} level is given twice: the file's column and a level for the file "
                f"({level:g}); keep one"
            )
        return specimen  # the column is the measurement: a manifest's nominal level is not needed
    sources = {}
    if level is not None:
        sources["the level given for the file"] = float(level)
    if entry is not None:
        sources["manifest.json"] = entry
    if spec.value is not None:
        sources[f"--control {spec.name}={spec.value:g}"] = spec.value
    if not sources:
        raise UserError(
            f"{where}: no column {spec.name} and no {spec.name} level for this file: add the column, or give "
            f"the level with --control {spec.name}=VALUE"
        )
    if len(set(sources.values())) > 1:
        said = " and ".join(f"{k} ({v:g})" for k, v in sources.items())
        raise UserError(f"{where}: the {spec.name} level is given twice: {said}; keep one")
    value = next(iter(sources.values()))
    u = np.full(specimen.n_samples, value)
    u.flags.writeable = False
    return dataclasses.replace(specimen, control=u, control_name=spec.name)


def _manifest_level(path, name: str) -> float | None:
    """The field ``name`` of the file's entry in the manifest.json beside it, or None."""
    if not path or not Path(path).is_file():
        return None
    from bwbench.data.manifest import manifest_entry

    try:
        entry = manifest_entry(path)
    except (OSError, ValueError):
        return None
    value = (entry or {}).get(name)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputFileError(
            str(Path(path).parent / "manifest.json"), None, f"{name} of {Path(path).name} is {value!r}"
        )
    return float(value)


@dataclass(frozen=True)
class ControlSummary:
    """What ``data check`` says of a control: its range, its levels (None: more than ``MAX_LEVELS``
    distinct values) and how often it switches (level changes per second)."""

    name: str
    low: float
    high: float
    levels: tuple | None
    switches: int
    duration_s: float

    @property
    def constant(self) -> bool:
        return self.low == self.high

    @property
    def switching_rate(self) -> float:
        return self.switches / self.duration_s if self.duration_s > 0 else 0.0

    def text(self) -> str:
        unit = _split(self.name)[1]
        if self.constant:
            return f"control: {self.name} constant at {self.low:g} {unit}"
        if self.levels is not None:
            levels = ", ".join(f"{v:g}" for v in self.levels)
            how = f"{len(self.levels)} levels ({levels} {unit})"
        else:
            how = "varying continuously"
        return (
            f"control: {self.name} {self.low:g} … {self.high:g} {unit}, {how}, {self.switches} changes of level "
            f"({self.switching_rate:.3g} per s)"
        )


def summary(specimen) -> ControlSummary | None:
    """The ``ControlSummary`` of a specimen's control, or None when it has none."""
    u = specimen.control
    if u is None:
        return None
    u = np.asarray(u, dtype=float)
    distinct = np.unique(u)
    levels = tuple(float(v) for v in distinct) if len(distinct) <= MAX_LEVELS else None
    switches = (
        int(np.count_nonzero(np.diff(u) != 0.0))
        if levels is not None
        else int(np.count_nonzero(np.diff(np.sign(np.diff(u))) != 0))
    )
    return ControlSummary(
        specimen.control_name or "control", float(u.min()), float(u.max()), levels, switches, specimen.duration_s
    )


def level_of(specimen) -> float | None:
    """The one level of a test whose control is constant, else None (a varying control or none)."""
    u = specimen.control
    if u is None or np.ptp(u) != 0.0:
        return None
    return float(u[0])
