"""What the Python API takes as one test: a specimen CSV's path, a ``Specimen``, or a pandas DataFrame
with the file's column names (``time_s``, ``displacement_mm``, ``force_N``; optionally
``velocity_mm_s`` and ``acceleration_mm_s2``), checked as a file is (``bwbench.data.specimen``): an
evenly sampled, strictly increasing time, finite values, a displacement that moves. A mistake is a
``UserError`` naming the data and the row (row 0 is the first data row).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from bwbench.errors import UserError


def as_specimen(data, name: str | None = None):
    """A ``Specimen`` of ``data`` (path, ``Specimen`` or DataFrame); ``name`` for a DataFrame (default:
    its ``attrs["name"]``, else "data")."""
    from bwbench.data.specimen import Specimen, read_specimen

    if isinstance(data, Specimen):
        return data
    if isinstance(data, (str, Path)):
        return read_specimen(data)
    if type(data).__name__ == "DataFrame" and hasattr(data, "columns"):
        return from_frame(data, name)
    raise UserError(f"a test is a specimen CSV's path, a Specimen or a pandas DataFrame, got {type(data).__name__}")


def from_frame(frame, name: str | None = None):
    """The ``Specimen`` of a DataFrame with the specimen file's columns (see the module docstring)."""
    from bwbench.data.specimen import COLUMNS, OPTIONAL_COLUMNS, Specimen, check_values

    name = str(name or frame.attrs.get("name") or "data")
    where = f"DataFrame {name!r}"
    from bwbench.data import units

    try:
        columns, scale, said = units.factors([str(c).strip() for c in frame.columns])
    except ValueError as err:
        raise UserError(f"DataFrame {name!r}: {err}") from None
    missing = [c for c in COLUMNS if c not in columns]
    if missing:
        raise UserError(
            f"{where}: no column {', '.join(missing)}; the columns are {', '.join(COLUMNS)} "
            f"(optionally {', '.join(OPTIONAL_COLUMNS)}), got {', '.join(columns) or 'none'}"
        )
    twice = next((c for c in columns if columns.count(c) > 1), None)
    if twice is not None:
        raise UserError(f"{where}: column {twice} appears twice: which one is meant? drop the other")
    other = [c for c in columns if c not in COLUMNS + OPTIONAL_COLUMNS]
    if other:
        raise UserError(
            f"{where}: unknown column {other[0]!r}; the columns are {', '.join(COLUMNS)} "
            f"(optionally {', '.join(OPTIONAL_COLUMNS)})"
        )
    values = {}
    for column, original in zip(columns, frame.columns):
        if np.iscomplexobj(frame[original].to_numpy()):  # float() would drop the imaginary part silently
            raise UserError(f"{where}: column {column} holds complex numbers: every value must be real")
        try:
            array = np.asarray(frame[original], dtype=float)
        except (TypeError, ValueError):
            raise UserError(f"{where}: column {column} is not numeric") from None
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise UserError(
                f"{where}, row {int(bad[0])}: {column} is {float(array[bad[0]])}: every value must be finite"
            )
        array = np.ascontiguousarray(array * scale.get(column, 1.0))
        array.flags.writeable = False
        values[column] = array

    def line_of(row: int) -> int:
        return row

    try:
        check_values(where, values["time_s"], values["displacement_mm"], line_of)
    except UserError as err:  # "DataFrame 'x':12: ..." reads better as a row
        text = str(err)
        if getattr(err, "line", None) is not None:
            text = f"{where}, row {err.line}: {err.problem}"  # type: ignore[attr-defined]
        raise UserError(text) from None
    return Specimen(
        path=where,
        name=name,
        t=values["time_s"],
        x=values["displacement_mm"],
        f=values["force_N"],
        v=values.get("velocity_mm_s"),
        a=values.get("acceleration_mm_s2"),
        reading_notes=tuple(said),
    )
