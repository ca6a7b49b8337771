"""The 14 parameters: names, Table 5 search bounds, unit-cube mapping and JSON files."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bwbench.data import manifest, strict_json
from bwbench.data.json_input import read_json_file
from bwbench.errors import InputFileError
from bwbench.models.switched.kernel import PARAM_NAMES

# Paper Table 5. ξ₋ is printed "−23 to −575"; stored as lower −575, upper −23 (docs/design.md#parameters).
TABLE5 = {
    "A+": (0.001, 0.025),
    "n+": (0.43, 10.75),
    "alpha+": (0.07, 1.75),
    "beta+": (0.1, 2.5),
    "gamma+": (0.3, 7.5),
    "xi+": (20.0, 500.0),
    "wn+": (0.3, 7.5),
    "A-": (0.05, 1.25),
    "n-": (0.2, 5.0),
    "alpha-": (0.0055, 0.1375),
    "beta-": (0.001, 0.025),
    "gamma-": (0.2, 5.0),
    "xi-": (-575.0, -23.0),
    "wn-": (1.8, 45.0),
}
LOWER = np.array([TABLE5[name][0] for name in PARAM_NAMES])
UPPER = np.array([TABLE5[name][1] for name in PARAM_NAMES])

# Units with x and z in mm, t in s, F in N and the paper's implicit mass 1 N·s²/mm: ωn in rad/s, ξ, α,
# A and n dimensionless (dz/dx = A − (β + γ·sign(z·dx))·|z|^n has no unit), so β and γ carry mm^-n of
# their own branch's n (β₊ in mm^-n₊).
UNITS = {
    name: ("rad/s" if name.startswith("wn") else f"mm^-n{name[-1]}" if name[:-1] in ("beta", "gamma") else "-")
    for name in PARAM_NAMES
}
LABELS = {
    "A+": "A₊",
    "n+": "n₊",
    "alpha+": "α₊",
    "beta+": "β₊",
    "gamma+": "γ₊",
    "xi+": "ξ₊",
    "wn+": "ωn₊",
    "A-": "A₋",
    "n-": "n₋",
    "alpha-": "α₋",
    "beta-": "β₋",
    "gamma-": "γ₋",
    "xi-": "ξ₋",
    "wn-": "ωn₋",
}


def to_dict(params) -> dict[str, float]:
    return {name: float(value) for name, value in zip(PARAM_NAMES, params)}


def from_dict(values: dict, source: str = "parameters", names=PARAM_NAMES) -> np.ndarray:
    missing = [name for name in names if name not in values]
    if missing:
        raise InputFileError(source, None, f"missing parameter(s): {', '.join(missing)}")
    out = []
    for name in names:
        value = values[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise InputFileError(source, None, f"parameter {name!r} must be a finite number, got {value!r}")
        out.append(float(value))
    return np.array(out)


def read_json(path, names=PARAM_NAMES) -> np.ndarray:
    """A parameters JSON: an object with the ``names`` (default the paper's 14), or a fit result with
    a ``params`` object; values in the order of ``names``."""
    path = Path(path)
    data = read_json_file(path)
    if isinstance(data, dict) and isinstance(data.get("params"), dict):
        data = data["params"]
    if not isinstance(data, dict):
        raise InputFileError(path, 1, "expected a JSON object with the parameter names")
    return from_dict(data, str(path), names)


def write_json(path, params) -> None:
    strict_json.write(path, to_dict(params))


def truth_params(specimen_path) -> np.ndarray | None:
    """The truth of one of the paper's specimens as a 14-vector (the switched model's), or None."""
    found = manifest.truth(specimen_path)
    if found is None or found[0] != "switched-bouc-wen":
        return None
    return np.array([found[1][name] for name in PARAM_NAMES])
