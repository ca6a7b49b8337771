"""Specimen files: one force-displacement test as CSV (docs/design.md#data-formats).

Format::

    time_s,displacement_mm,force_N
    0.000,0.0000,-0.12
    0.025,0.0031,0.87
    ...

- Line 1 is the header: the three names, in any order (columns are matched by name, so a
  re-ordered export still reads correctly); whitespace around names and a UTF-8 BOM are allowed.
  Optionally also ``velocity_mm_s`` (mm/s) and ``acceleration_mm_s2`` (mm/s²), what a test machine
  logs beside the displacement (commanded or measured): when present they drive the model instead
  of being estimated from the displacement (docs/design.md#signals). No other columns.
- If the header contains ``;`` the file is a European spreadsheet export: cells are separated by
  ``;`` and a decimal comma (``1,25``) is read as a decimal point.
- One row per sample, at least ``MIN_SAMPLES`` rows, time strictly increasing and uniformly
  sampled (steps within ``SAMPLING_TOLERANCE`` of the median step), every value finite, and the
  displacement must actually move. Blank lines are ignored.

Every malformed file raises ``InputFileError(path, line, problem)`` with the 1-based line of the
first offending line (line 1 = header). A file that cannot be opened has no line (``line=None``).
"""

from __future__ import annotations

import io
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bwbench.data import units
from bwbench.errors import InputFileError

COLUMNS = ("time_s", "displacement_mm", "force_N")
OPTIONAL_COLUMNS = ("velocity_mm_s", "acceleration_mm_s2")
MIN_SAMPLES = 20
# Steps may differ from the median by this fraction (timestamps printed with a few decimals); more is a
# gap or a change of rate. Refused rather than resampled: a velocity and acceleration estimated from the
# displacement assume an even grid, and resampling silently would change the data the loss is computed on.
SAMPLING_TOLERANCE = 0.01
# Below this the test did not move: no hysteresis loop to fit, and velocities are pure noise.
MIN_DISPLACEMENT_RANGE_MM = 1e-6

# What a cell may contain. Stricter than float(), which would also take "1_000" and non-ASCII digits.
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?", re.ASCII)
_NAN = {"nan", "+nan", "-nan"}
_INF = {"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity"}


@dataclass(frozen=True, eq=False)  # eq=False: comparing/hashing ndarray fields would raise
class Specimen:
    """One specimen: sample times (s), displacement (mm) and force (N), all the same length; the
    velocity (mm/s) and acceleration (mm/s²) the file records, or None when it has no such column."""

    path: str
    name: str
    t: np.ndarray
    x: np.ndarray
    f: np.ndarray
    v: np.ndarray | None = None
    a: np.ndarray | None = None
    # The control (current, voltage, underpressure: ``bwbench.data.control``) at each sample, and its
    # column name ``<quantity>_<unit>``; None for a test without one.
    control: np.ndarray | None = None
    control_name: str | None = None
    # What reading did to the file's numbers (declared units converted, a rounded time rebuilt), in words.
    reading_notes: tuple = ()
    # No time column: a quasi-static (rate-independent) test read as a sequence of points, t the point's
    # index (docs/file-formats.md#quasi-static-tests); a model sees the displacement path and its direction.
    quasi_static: bool = False

    @property
    def measured_signals(self) -> tuple[str, ...]:
        """Which of "velocity" and "acceleration" the file records (the others are estimated)."""
        return tuple(name for name, values in (("velocity", self.v), ("acceleration", self.a)) if values is not None)

    @property
    def n_samples(self) -> int:
        return int(self.t.size)

    @property
    def duration_s(self) -> float:
        return float(self.t[-1] - self.t[0])


def read_specimen(path, control: str | None = None) -> Specimen:
    """Read and validate a specimen CSV; raise ``InputFileError`` for anything malformed. ``control``: the
    name of a control column (``bwbench.data.control``) the file may carry: read into ``control`` when
    the header has it."""
    path = str(path)
    data = _read_bytes(path)
    text = _decode(path, data)
    if not text or text.isspace():
        raise InputFileError(path, 1, "empty file: expected the header " + ",".join(COLUMNS))

    if "\r" in text.partition("\n")[0].rstrip("\r"):  # a CR inside the first line: lines end in CR only
        raise InputFileError(
            path,
            1,
            "lines end in a carriage return (CR) only, as old Mac exports do: save the "
            "file with LF or CRLF line endings",
        )
    header, _, rest = text.partition("\n")
    try:
        header, scale, said = units.header(header)
    except ValueError as err:
        raise InputFileError(path, 1, str(err)) from None
    sep, order, n_columns = _parse_header(path, header, (control,) if control else ())
    if not rest or rest.isspace():
        raise InputFileError(path, 1, "header only, no data rows")

    # Fast path: the C parser over the bytes after the header. It is only an optimisation: if it
    # fails or yields anything non-finite, the line-by-line pass below decides what is wrong and
    # on which line (it also accepts the rare valid file the C parser refuses).
    values = _fast_parse(data[data.index(b"\n") + 1 :], sep, n_columns)
    line_nos = None
    if values is None or not np.isfinite(values).all():
        values, line_nos = _slow_parse(path, text, sep)

    def line_of(row: int) -> int:
        nonlocal line_nos
        if line_nos is None:  # only needed for an error: pay for the slow pass then
            line_nos = _slow_parse(path, text, sep)[1]
        return int(line_nos[row])

    quasi_static = order[0] is None
    if quasi_static:  # no time: the sample index orders the path (docs/file-formats.md#quasi-static-tests)
        values = np.column_stack([values, np.arange(len(values), dtype=float)])
        order = [values.shape[1] - 1, *order[1:]]
    t, x, f = (np.ascontiguousarray(values[:, j]) for j in order[:3])  # always there
    v, a = (None if j is None else np.ascontiguousarray(values[:, j]) for j in order[3:])
    named = dict(zip(COLUMNS + OPTIONAL_COLUMNS, (t, x, f, v, a)))
    for name, factor in scale.items():
        named[name] *= factor
    if units.declared().rebuild_time and units.rounded_time(t) is not None and _uneven(t) is not None:
        fs, worst = units.rounded_time(t)
        t = units.rebuilt_time(t)
        said.append(f"time rebuilt as t₀ + k/fs, fs = {fs:.6g} Hz (--rebuild-time; it was up to {worst:.2g} s off)")
    check_values(path, t, x, line_of)
    names = [n.strip().strip('"').strip() for n in header.strip().split(sep)]
    u = np.ascontiguousarray(values[:, names.index(control)]) if control in names else None
    for column in (t, x, f, v, a, u):
        if column is not None:
            column.flags.writeable = False  # a frozen Specimen should not change under its users
    return Specimen(
        path=path,
        name=Path(path).stem,
        t=t,
        x=x,
        f=f,
        v=v,
        a=a,
        control=u,
        control_name=None if u is None else control,
        reading_notes=tuple(said),
        quasi_static=quasi_static,
    )


def _read_bytes(path: str) -> bytes:
    # Only a regular file, up to a stated size: a FIFO would block, /dev/zero would never end.
    from bwbench.data.input_files import read_bytes

    return read_bytes(path, "BWBENCH_MAX_INPUT_MB")


def _line_at(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _decode(path: str, data: bytes) -> str:
    # Spreadsheets are the usual source of wrong files: say what to do, not just "bad byte".
    if data.startswith(b"PK\x03\x04"):
        raise InputFileError(path, 1, "binary file (a ZIP/.xlsx workbook?): export the sheet as CSV")
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise InputFileError(path, 1, "UTF-16 text: save the file as UTF-8 CSV")
    nul = data.find(b"\x00")
    if nul >= 0:
        raise InputFileError(path, _line_at(data, nul), "binary file (contains NUL bytes), not CSV text")
    try:
        return data.decode("utf-8-sig")  # -sig: drops a leading BOM, as Excel writes one
    except UnicodeDecodeError as err:
        bad = data[err.start]
        raise InputFileError(
            path, _line_at(data, err.start), f"not UTF-8 text (byte 0x{bad:02x}): save the file as UTF-8 CSV"
        ) from None


def _parse_header(path: str, header: str, allowed: tuple = ()) -> tuple[str, list, int]:
    """Separator, the index of each of COLUMNS + OPTIONAL_COLUMNS in a row (None for an absent optional
    column), and the number of columns. ``allowed``: other column names the caller reads (a control)."""
    sep = ";" if ";" in header else ","
    names = [name.strip().strip('"').strip() for name in header.strip().split(sep)]
    for name in names:
        quantity, _, unit = name.partition("_")
        if quantity in units.UNITS and re.fullmatch(r"\w+", unit, re.ASCII) and name not in COLUMNS + OPTIONAL_COLUMNS:
            raise InputFileError(path, 1, f"column {name!r}: unknown unit; {quantity} may be {units.known(quantity)}")
    missing = [c for c in COLUMNS if c not in names]
    if missing == ["time_s"] and not any(c in names for c in OPTIONAL_COLUMNS):
        missing = []  # a quasi-static test: the displacement path and its force (``read_specimen``)
    if missing:
        found = header.strip()
        found = found if len(found) <= 60 else found[:57] + "..."
        which = ", ".join(repr(c) for c in missing)
        raise InputFileError(
            path,
            1,
            f"missing column{'s' if len(missing) > 1 else ''} {which} in header "
            f"(expected {','.join(COLUMNS)}, found {found!r})",
        )
    extra = [n for n in names if n not in COLUMNS + OPTIONAL_COLUMNS + tuple(allowed)]
    if extra:
        raise InputFileError(
            path,
            1,
            f"unexpected column {extra[0]!r} in header (expected {','.join(COLUMNS)}, "
            f"optionally also {' and '.join(OPTIONAL_COLUMNS)}; a control column is read when named with "
            "--control)",
        )
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup is not None:
        raise InputFileError(path, 1, f"column {dup!r} appears twice in header")
    return sep, [names.index(c) if c in names else None for c in COLUMNS + OPTIONAL_COLUMNS], len(names)


def _fast_parse(body: bytes, sep: str, n_columns: int) -> np.ndarray | None:
    if sep == ";":
        body = body.replace(b",", b".")  # with ';' as separator a comma can only be a decimal mark
    # numpy's C reader (not pandas: importing it would slow every command, docs/speed.md); a quoted
    # number or a comment is refused by the slow pass too, so none is accepted here.
    try:
        values = np.loadtxt(io.BytesIO(body), delimiter=sep, dtype=np.float64, ndmin=2, comments=None, encoding="utf-8")
    except ValueError:
        return None
    return values if values.ndim == 2 and values.shape[1] == n_columns else None


def _slow_parse(path: str, text: str, sep: str) -> tuple[np.ndarray, np.ndarray]:
    """Line-by-line parse: the reference for what is valid, and the source of error line numbers."""
    header = [n.strip().strip('"').strip() for n in text.partition("\n")[0].strip().split(sep)]
    lines = text.split("\n")  # kept as written, for error messages
    numeric = text.replace(",", ".").split("\n") if sep == ";" else lines
    # float() is the quick test; it is looser than _NUMBER only on non-ASCII digits and '_'
    # (screened here) and on nan/inf (caught by the isfinite check below).
    screen = not text.isascii() or "_" in text
    flat: list[float] = []
    line_nos: list[int] = []
    for line_no in range(2, len(lines) + 1):
        raw = numeric[line_no - 1]
        cells = raw.split(sep)
        if len(cells) != len(header):
            if not raw.strip():
                continue  # blank line
            raise InputFileError(
                path,
                line_no,
                f"{len(cells)} cell{'s' if len(cells) != 1 else ''} on this row, "
                f"expected {len(header)} separated by {sep!r}",
            )
        try:
            if screen and (not raw.isascii() or "_" in raw):
                raise ValueError
            flat.extend(map(float, cells))
        except ValueError:
            _refuse_row(path, line_no, lines[line_no - 1], header, sep)
        line_nos.append(line_no)
    values = np.array(flat, dtype=np.float64).reshape(-1, len(header))
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        line_no = line_nos[bad[0]]
        _refuse_row(path, line_no, lines[line_no - 1], header, sep)  # names the NaN or inf
    return values, np.array(line_nos)


def _refuse_row(path: str, line_no: int, line: str, header: list[str], sep: str) -> None:
    for cell, column in zip(line.split(sep), header):
        _parse_cell(path, line_no, cell, column, sep)  # raises with the precise reason
    raise InputFileError(path, line_no, "unreadable row")  # not reached: a safety net


def _parse_cell(path: str, line_no: int, cell: str, column: str, sep: str) -> float:
    text = cell.strip()
    if not text:
        raise InputFileError(path, line_no, f"empty cell in column {column}")
    number = text.replace(",", ".") if sep == ";" else text
    if number.lower() in _NAN:
        raise InputFileError(path, line_no, f"NaN in column {column}: {text!r}")
    if number.lower() in _INF:
        raise InputFileError(path, line_no, f"infinite value in column {column}: {text!r}")
    if not _NUMBER.fullmatch(number):
        raise InputFileError(path, line_no, f"not a number in column {column}: {text!r}")
    value = float(number)
    if not np.isfinite(value):  # e.g. 1e999
        raise InputFileError(path, line_no, f"value too large in column {column}: {text!r} (overflows to infinity)")
    return value


def _uneven(t: np.ndarray) -> int | None:
    """The row of the first time step off the median step by more than ``SAMPLING_TOLERANCE``, or None."""
    dt = np.diff(t)
    step = float(np.median(dt))
    uneven = np.flatnonzero(np.abs(dt - step) > SAMPLING_TOLERANCE * step)
    return int(uneven[0]) + 1 if uneven.size else None


def check_values(path: str, t: np.ndarray, x: np.ndarray, line_of) -> None:
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise InputFileError(path, line_of(i), f"time not strictly increasing: {t[i]:.9g} s after {t[i - 1]:.9g} s")
    if t.size < MIN_SAMPLES:
        raise InputFileError(path, line_of(t.size - 1), f"too few samples: {t.size}, need at least {MIN_SAMPLES}")
    row = _uneven(t)
    if row is not None:
        dt = np.diff(t)
        step = float(np.median(dt))
        rounded = units.rounded_time(t)
        advice = (
            f"the time column is an even grid printed with too few digits (every time within {rounded[1]:.2g} s "
            f"of t₀ + k/fs, fs = {rounded[0]:.6g} Hz): rebuild it as t = t₀ + k/fs, or add --rebuild-time"
            if rounded is not None
            else "bwbench needs uniformly sampled data (resample it first, e.g. numpy.interp onto an even time grid)"
        )
        raise InputFileError(
            path,
            line_of(row),
            f"time step {dt[row - 1]:.6g} s here, but the file is sampled every {step:.6g} s: {advice}",
        )
    span = float(x.max() - x.min())
    if span < MIN_DISPLACEMENT_RANGE_MM:
        raise InputFileError(
            path,
            line_of(0),
            f"no motion: displacement_mm stays at {x[0]:.9g} mm (range {span:.3g} mm, "
            f"need at least {MIN_DISPLACEMENT_RANGE_MM:g} mm)",
        )
