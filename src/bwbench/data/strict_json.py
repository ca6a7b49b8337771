"""The one JSON writer of bwbench: strict JSON (RFC 8259), never a NaN or Infinity token.

Python's ``json`` writes ``NaN``, ``Infinity`` and ``-Infinity`` by default, which strict readers
(JavaScript's ``JSON.parse``, jq, Go, Rust's serde) refuse; with ``allow_nan=False`` it raises
instead ("Out of range float values are not JSON compliant"). Here a value that is not finite is
written as ``null``, and a document whose top level is an object also says why: a ``"not_finite"``
object maps the JSON pointer (RFC 6901) of each such value to what it was and, when the caller
knows, the reason, e.g. ``{"mse": null, ..., "not_finite": {"/mse": "+inf: the model blows up"}}``.

The store's JSON columns (``canonical``: sorted keys, no spaces) hold null alone: their keys are the
names of parameters and metrics, and null there means "not finite" (the run's message says why).

Every JSON document bwbench writes (a fit's result, ``simulate``/``evaluate``/``identifiability``
output, a study's stored columns, the synthetic data set's manifest) goes through ``dumps``.
"""

from __future__ import annotations

import json
import math
import numbers
from pathlib import Path

NOT_FINITE_KEY = "not_finite"


def finite_or_null(value, found: dict | None = None, pointer: str = ""):
    """``value`` with every float that is not finite (recursively; numpy scalars and arrays become
    plain Python values) replaced by None; ``found`` (if given) collects {JSON pointer: "+inf" |
    "-inf" | "nan"} of what was replaced."""
    if isinstance(value, dict):
        return {k: finite_or_null(v, found, f"{pointer}/{_escape(k)}") for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [finite_or_null(v, found, f"{pointer}/{i}") for i, v in enumerate(value)]
    if isinstance(value, (bool, str)) or value is None:
        return value
    if type(value).__module__ == "numpy" and hasattr(value, "tolist"):  # arrays to lists, scalars to Python
        return finite_or_null(value.tolist(), found, pointer)
    if isinstance(value, numbers.Integral):
        return int(value)
    if not isinstance(value, numbers.Real):
        return value  # not a number: json says whether it can write it
    number = float(value)
    if math.isfinite(number):
        return number
    if found is not None:
        found[pointer] = "nan" if math.isnan(number) else "+inf" if number > 0 else "-inf"
    return None


def _escape(key) -> str:
    return str(key).replace("~", "~0").replace("/", "~1")


def dumps(value, *, why: str | dict | None = None, canonical: bool = False, indent: int | None = None) -> str:
    """Strict JSON text of ``value`` (see the module docstring).

    ``why``: the reason a value is not finite, one text for all or {top-level key: text}; added to the
    ``"not_finite"`` entries of an object. ``canonical``: sorted keys, no spaces, UTF-8 kept, and no
    ``"not_finite"`` entry (the store's columns). Raises ``ValueError`` if an object already has a
    ``"not_finite"`` key that this would overwrite, ``TypeError`` for a value JSON cannot hold.
    """
    found: dict = {}
    clean = finite_or_null(value, found)
    if found and isinstance(clean, dict) and not canonical:
        if NOT_FINITE_KEY in clean:
            raise ValueError(f"cannot note the values that are not finite: the object has a {NOT_FINITE_KEY!r} key")
        clean[NOT_FINITE_KEY] = {where: _reason(where, kind, why) for where, kind in found.items()}
    if canonical:
        return json.dumps(clean, sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False)
    return json.dumps(clean, indent=indent, allow_nan=False)


def _reason(pointer: str, kind: str, why) -> str:
    text = why.get(pointer.split("/")[1], None) if isinstance(why, dict) else why
    return f"{kind}: {text}" if text else kind


def write(path, value, *, why: str | dict | None = None, indent: int | None = 2) -> None:
    """Write ``dumps(value, why=why, indent=indent)`` and a newline to ``path`` (UTF-8); nothing is
    written if the value cannot be (the text is made before the file is opened)."""
    from bwbench.data.output_paths import replaced_whole

    text = dumps(value, why=why, indent=indent) + "\n"
    with replaced_whole(path) as partial:  # Ctrl-C while writing leaves the old file or none, not half
        Path(partial).write_text(text, encoding="utf-8")


def loads(text: str):
    """Parse strict JSON: ``ValueError`` on a NaN, Infinity or -Infinity token (which ``json.loads``
    accepts). For tests and for reading what another tool wrote."""

    def refuse(token):
        raise ValueError(f"not strict JSON: {token} token")

    return json.loads(text, parse_constant=refuse)
