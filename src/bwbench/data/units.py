"""Declared units: a specimen column named ``<quantity>_<unit>`` is converted on reading to bwbench's
mm, N and s (docs/file-formats.md#declared-units).

``displacement_in``, ``velocity_in_s``, ``force_kip``, ``force_kN``, ``displacement_m``, ``time_ms``, …:
the quantity (time, displacement, velocity, acceleration, force) and a unit of ``UNITS``; the column
is read as the quantity's own column (``displacement_mm`` …) times the unit's factor. For a file whose
header cannot change, ``--units displacement=in,force=kip`` says what its numbers are in whatever the
header's names say (a header that declares another unit for the same quantity is refused: one of the
two is wrong). ``--rebuild-time`` rebuilds a time column printed with too few digits (``rounded_time``).

The command line declares both once per process (``declare``); ``read_specimen`` asks ``declared()``.
"""

from __future__ import annotations

from contextlib import contextmanager
from dataclasses import dataclass, field

from bwbench.errors import UserError

KIP_N = 4448.2216152605  # 1 kip = 1000 lbf (exact by the definition of the pound-force)
INCH_MM = 25.4
G_MM_S2 = 9806.65
# quantity -> (bwbench's column, {unit as written in a column name: factor to bwbench's unit})
UNITS = {
    "time": ("time_s", {"s": 1.0, "ms": 1e-3, "min": 60.0}),
    "displacement": ("displacement_mm", {"mm": 1.0, "m": 1e3, "cm": 10.0, "um": 1e-3, "in": INCH_MM}),
    "velocity": (
        "velocity_mm_s",
        {"mm_s": 1.0, "m_s": 1e3, "cm_s": 10.0, "in_s": INCH_MM, "mm_min": 1 / 60, "um_s": 1e-3},
    ),
    "acceleration": ("acceleration_mm_s2", {"mm_s2": 1.0, "m_s2": 1e3, "in_s2": INCH_MM, "g": G_MM_S2}),
    "force": ("force_N", {"N": 1.0, "kN": 1e3, "MN": 1e6, "kip": KIP_N, "lbf": KIP_N / 1000}),
}
# How a unit reads in a sentence.
SPOKEN = {"in": "inches", "in_s": "in/s", "in_s2": "in/s²", "kip": "kips", "lbf": "lbf", "um": "µm", "um_s": "µm/s"}


def _lookup(quantity: str, unit: str):
    """The unit's spelling in ``UNITS`` (case-insensitive where that is unambiguous), or None."""
    table = UNITS[quantity][1]
    if unit in table:
        return unit
    found = [u for u in table if u.lower() == unit.lower()]
    return found[0] if len(found) == 1 else None


def column(name: str):
    """(bwbench's column, unit, factor) of a column named ``<quantity>_<unit>``; None for any other name."""
    quantity, sep, unit = name.partition("_")
    if not sep or quantity not in UNITS:
        return None
    spelled = _lookup(quantity, unit)
    if spelled is None:
        return None
    return UNITS[quantity][0], spelled, UNITS[quantity][1][spelled]


def known(quantity: str) -> str:
    """The units a quantity may be declared in, for a message."""
    return ", ".join(f"{quantity}_{u}" for u in UNITS[quantity][1])


def parse_option(text: str | None) -> dict:
    """{quantity: unit} of ``--units displacement=in,force=kip``; ``UserError`` naming what is wrong."""
    out: dict = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        quantity, sep, unit = (s.strip() for s in item.partition("="))
        if not sep or quantity not in UNITS:
            raise UserError(
                f"--units {text}: {item.strip()!r} is not QUANTITY=UNIT with a quantity of {', '.join(UNITS)} "
                "(e.g. --units displacement=in,force=kip)"
            )
        spelled = _lookup(quantity, unit.replace("/", "_"))
        if spelled is None:
            raise UserError(f"--units {text}: {quantity} cannot be in {unit!r}; known: {', '.join(UNITS[quantity][1])}")
        out[quantity] = spelled
    return out


@dataclass(frozen=True)
class Reading:
    """What the command line declared about every specimen file it reads."""

    units: dict = field(default_factory=dict)  # quantity -> unit, from --units
    rebuild_time: bool = False


_DECLARED = Reading()


def declare(units: str | None = None, rebuild_time: bool = False) -> Reading:
    """Declare ``--units`` and ``--rebuild-time`` for this process (the command line, once)."""
    global _DECLARED
    _DECLARED = Reading(parse_option(units), bool(rebuild_time))
    return _DECLARED


def declared() -> Reading:
    return _DECLARED


@contextmanager
def declaring(units: str | None = None, rebuild_time: bool = False):
    """``declare`` for the ``with`` block only (the API, tests)."""
    global _DECLARED
    before = _DECLARED
    try:
        yield declare(units, rebuild_time)
    finally:
        _DECLARED = before


def factors(names: list[str], reading: Reading | None = None) -> tuple[list[str], dict, list[str]]:
    """(the names as bwbench's columns, {bwbench column: factor ≠ 1}, sentences saying what was converted)
    of a header's ``names``, with the declared ``--units`` over the header's; ``ValueError`` when the
    header and ``--units`` disagree."""
    reading = reading or _DECLARED
    out, scale, said = [], {}, []
    for name in names:
        found = column(name)
        if found is None:
            out.append(name)
            continue
        target, unit, factor = found
        quantity = name.partition("_")[0]
        given = reading.units.get(quantity)
        if given is not None and given != unit and unit != _native(quantity):
            raise ValueError(
                f"column {name} declares {quantity} in {_unit_text(unit)}, --units says {_unit_text(given)}: "
                "which is it?"
            )
        if given is not None:
            unit, factor = given, UNITS[quantity][1][given]
        out.append(target)
        if factor != 1.0:
            scale[target] = factor
            said.append(f"{quantity} in {_unit_text(unit)} (× {factor:.6g} → {_spoken(target)})")
    return out, scale, said


def _unit_text(unit: str) -> str:
    return SPOKEN.get(unit, unit.replace("_", "/"))


def _native(quantity: str) -> str:
    return UNITS[quantity][0].partition("_")[2]


def _spoken(target: str) -> str:
    unit = target.partition("_")[2]
    return {"mm_s": "mm/s", "mm_s2": "mm/s²"}.get(unit, unit)


def header(line: str, reading: Reading | None = None) -> tuple[str, dict, list[str]]:
    """A specimen file's header line with its declared-unit names as bwbench's columns, and ``factors``'s
    {column: factor} and sentences; names it does not know are left as written (the header check names them)."""
    sep = ";" if ";" in line else ","
    names = [n.strip().strip('"').strip() for n in line.strip().split(sep)]
    out, scale, said = factors(names, reading)
    return sep.join(out), scale, said


# A time column is "rounded" when every time lies within this fraction of a step of the even grid through
# its ends: printing t = k/fs with too few digits (3 kHz to 1e-5 s) leaves steps of 0.00033 and 0.00034 s,
# never a quarter-step off the grid, while a lost sample or a change of rate puts times half a step or more off.
ROUNDED_TIME_FRACTION = 0.25


def rounded_time(t):
    """(fs in Hz, the largest distance in s of a time from the even grid t₀ + k/fs) when ``t`` is an even
    grid printed with too few digits (``ROUNDED_TIME_FRACTION``); None otherwise."""
    import numpy as np

    t = np.asarray(t, dtype=float)
    if t.size < 3 or not t[-1] > t[0]:
        return None
    k = np.arange(t.size)
    step = (t[-1] - t[0]) / (t.size - 1)
    worst = float(np.max(np.abs(t - (t[0] + step * k))))
    if worst > ROUNDED_TIME_FRACTION * step:
        return None
    # The rate as it was set (3000 Hz, not the 2999.99 Hz the rounded ends give): the fewest digits whose
    # grid is as close to every printed time as the grid through the ends is.
    for digits in range(1, 10):
        fs = float(f"{1.0 / step:.{digits}g}")
        off = float(np.max(np.abs(t - (t[0] + k / fs))))
        if off <= 1.05 * worst:
            return fs, off
    return 1.0 / step, worst


def rebuilt_time(t):
    """t₀ + k/fs for a ``rounded_time`` column, else ``t`` itself."""
    import numpy as np

    found = rounded_time(t)
    if found is None:
        return t
    return t[0] + np.arange(len(t)) / found[0]
