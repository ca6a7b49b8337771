"""Checks a study configuration shares between its tables and the command line: a count within its
stated maximum, a backend that exists, a backend's options resolved (each mistake one line)."""

from __future__ import annotations

import json

import bwbench.limits as limits
from bwbench.engine import registry
from bwbench.errors import UserError
from bwbench.problems.base import Fail


def canonical_json(value) -> str:
    """Sorted keys, no spaces: equal configurations give equal text (and hash)."""
    from bwbench.data import strict_json  # no NaN/Infinity token: null, as everywhere bwbench writes JSON

    return strict_json.dumps(value, canonical=True)


def bounded(fail, label: str, value: int, variable: str) -> int:
    """``value``, or ``fail`` if it is above the limit ``variable`` (``bwbench.limits``)."""
    try:
        limits.check(label, value, variable)
    except UserError as err:
        fail(str(err))
    return value


def check_backend(fail, label, optimizer) -> None:
    backends = registry.available()
    if optimizer not in backends:
        fail(f"{label}: unknown optimiser {optimizer!r}; available: {', '.join(backends)}")


def resolve_backend_options(fail: Fail, label, optimizer, options) -> dict:
    if not isinstance(options, dict):
        fail(f"{label} must be a table of options (use {{}} for the defaults)")
    try:  # the same check as `bwbench fit --option`: names, types and ranges, defaults merged in
        resolved = registry.resolve_options(optimizer, options, label=label)
    except UserError as err:
        fail(str(err))
    try:  # options are stored as JSON with every run: only plain values will do
        return json.loads(canonical_json(resolved))
    except (TypeError, ValueError):
        fail(f"{label}: options must be plain numbers, strings, booleans or lists of them")
