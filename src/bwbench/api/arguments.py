"""Checks of the Python API's keyword arguments: a bad one is a ``UserError`` naming it, as the command
line names its flag."""

from __future__ import annotations

import numbers

from bwbench.errors import UserError


def count(label: str, value, what: str, minimum: int = 1) -> int:
    """``value`` if it is an integer ≥ ``minimum`` (not a bool), else ``UserError`` naming ``label``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise UserError(f"{label} must be {what}, got {value!r}")
    return int(value)
