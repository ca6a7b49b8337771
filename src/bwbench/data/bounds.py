"""A user's search box: ``--bounds FILE.json`` (fit, compare, identifiability) or ``[bounds]`` in a study TOML.

Both are an object of parameter name → [lower, upper] in physical units; names left out keep the
problem's default range (the paper's Table 5 for the paper formulation). Every mistake is one
``UserError`` naming the file (and the line, for JSON syntax) and the parameter.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from bwbench.data.json_input import read_json_file
from bwbench.errors import InputFileError, UserError

# Where a value of the wrong sign makes the model meaningless rather than merely a bad fit: |z|^n with
# n ≤ 0 is infinite at z = 0.
POSITIVE = ("n+", "n-")
PROBE_CORNERS = 32


def validate(table, names, where: str) -> dict:
    """``{name: (lower, upper)}`` from a JSON/TOML table; ``InputFileError(where, None, ...)`` on any mistake."""
    if not isinstance(table, dict):
        raise InputFileError(where, None, "bounds must be an object of parameter name -> [lower, upper]")
    out = {}
    for name, pair in table.items():
        if name not in names:
            raise InputFileError(where, None, f"unknown parameter {name!r} in bounds; names: {' '.join(names)}")
        ok = (
            isinstance(pair, (list, tuple))
            and len(pair) == 2
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pair)
        )
        if not ok:
            raise InputFileError(
                where, None, f"bounds of {name} must be [lower, upper], two finite numbers, got {pair!r}"
            )
        lower, upper = float(pair[0]), float(pair[1])
        if not lower < upper:
            raise InputFileError(where, None, f"bounds of {name}: lower {lower:g} must be below upper {upper:g}")
        if not math.isfinite(upper - lower):  # the unit cube maps to lower + u·(upper − lower)
            raise InputFileError(
                where,
                None,
                f"bounds of {name}: the width {upper:g} − ({lower:g}) overflows to "
                "infinity; give a box of physical size",
            )
        if name in POSITIVE and lower <= 0:
            raise InputFileError(
                where,
                None,
                f"bounds of {name}: lower must be > 0 (|z|^n is infinite at z = 0 for n ≤ 0), got {lower:g}",
            )
        out[name] = (lower, upper)
    return out


def read_json(path, names) -> dict:
    """The bounds in a JSON file (see the module docstring)."""
    path = Path(path)
    table = read_json_file(path)
    return validate(table, names, str(path))


def refuse_if_blows_up(problem, where: str, corners: int = PROBE_CORNERS) -> None:
    """``UserError`` if the model gives no finite loss at any of ``corners`` corners of ``problem``'s box
    (the two extreme ones and the rest drawn with a fixed seed): a search there would spend its whole
    budget on +inf. The default boxes keep 20 or more of 32 finite on every specimen we have tried."""
    rng = np.random.default_rng(0)
    unit = rng.integers(0, 2, size=(corners, problem.dim)).astype(float)
    unit[0], unit[-1] = 0.0, 1.0
    if np.isfinite(problem.loss_batch(problem.from_unit(unit))).any():
        return
    centre = float(problem.loss_batch(problem.from_unit(np.full((1, problem.dim), 0.5)))[0])
    inside = "" if not math.isfinite(centre) else " (its centre is finite: the box is far too wide)"
    raise UserError(
        f"{where}: the model blows up (force not finite) at every one of {corners} corners of this "
        f"search box{inside} on {problem.info.get('specimen', 'this specimen')}; shrink it"
    )


def apply(lower, upper, names, bounds: dict) -> tuple[np.ndarray, np.ndarray]:
    """Copies of ``lower``/``upper`` with the given bounds put in by name."""
    lower, upper = np.array(lower, dtype=float), np.array(upper, dtype=float)
    for name, (lo, hi) in bounds.items():
        i = list(names).index(name)
        lower[i], upper[i] = lo, hi
    return lower, upper
