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
from bwbench.errors import InputFileError

# Where a value of the wrong sign makes the model meaningless rather than merely a bad fit: |z|^n with
# n ≤ 0 is infinite at z = 0.
POSITIVE = ("n+", "n-")


def validate(table, names, where: str) -> dict:
    """``{name: (lower, upper)}`` from a JSON/TOML table; ``InputFileError(where, None, ...)`` on any mistake."""
    if not isinstance(table, dict):
        raise InputFileError(where, None, "bounds must be an object of parameter name -> [lower, upper]")
    out = {}
    for name, pair in table.items():
        if name not in names:
            raise InputFileError(where, None, f"unknown parameter {name!r} in bounds; names: {' '.join(names)}")
        ok = (isinstance(pair, (list, tuple)) and len(pair) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in pair))
        if not ok:
            raise InputFileError(where, None, f"bounds of {name} must be [lower, upper], two finite numbers, got {pair!r}")
        lower, upper = float(pair[0]), float(pair[1])
        if not lower < upper:
            raise InputFileError(where, None, f"bounds of {name}: lower {lower:g} must be below upper {upper:g}")
        if name in POSITIVE and lower <= 0:
            raise InputFileError(where, None, f"bounds of {name}: lower must be > 0 (|z|^n is infinite at z = 0 "
                                              f"for n ≤ 0), got {lower:g}")
        out[name] = (lower, upper)
    return out


def read_json(path, names) -> dict:
    """The bounds in a JSON file (see the module docstring)."""
    path = Path(path)
    table = read_json_file(path)
    return validate(table, names, str(path))


def apply(lower, upper, names, bounds: dict) -> tuple[np.ndarray, np.ndarray]:
    """Copies of ``lower``/``upper`` with the given bounds put in by name."""
    lower, upper = np.array(lower, dtype=float), np.array(upper, dtype=float)
    for name, (lo, hi) in bounds.items():
        i = list(names).index(name)
        lower[i], upper[i] = lo, hi
    return lower, upper
