"""How the report writes numbers: significant figures, p-values, evaluation counts, durations."""

from __future__ import annotations

import math

import numpy as np


def number(x, digits: int = 4) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if isinstance(x, float) and math.isinf(x):
        return "∞"
    return f"{x:.{digits}g}"


def unit_of(setting: str) -> str:
    """Unit of a generator setting, from its name's suffix (amplitude_mm, speed_mm_per_min, ...)."""
    for suffix, unit in (
        ("_frac", "fraction"),
        ("_mm_per_min", "mm/min"),
        ("_mm_per_s", "mm/s"),
        ("_mm_s", "mm/s"),
        ("_mm", "mm"),
        ("_hz", "Hz"),
        ("_n_per_mm", "N/mm"),
        ("_s", "s"),
        ("_n", "N"),
        ("_v", "V"),
    ):
        if setting.lower().endswith(suffix):
            return unit
    return ""


def join(items) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def evals_text(x) -> str:
    """An evaluation count (ERT): whole numbers with thousands separators, ∞ for never."""
    if x is None or np.isnan(x):
        return "–"
    return "∞" if np.isinf(x) else f"{x:,.0f}"


def p_text(x) -> str:
    if x is None or not np.isfinite(x):
        return "–"
    return f"{x:.2g}" if x >= 1e-3 else f"{x:.1e}"


def seconds_text(x) -> str:
    """A duration: '0.42 ms', '3.1 s', '2.5 min'; ∞ for never, – for unknown."""
    if x is None or np.isnan(x):
        return "–"
    if np.isinf(x):
        return "∞"
    if x < 0.1:
        return f"{x * 1000:.2g} ms"
    if x < 10:
        return f"{x:.2g} s"
    return f"{x:,.0f} s" if x < 120 else f"{x / 60:,.1f} min"


def files_text(paths, shown: int = 3) -> str:
    """Several files named in a line of bounded length: "a.csv + b.csv", or "46 files (a.csv, b.csv,
    c.csv and 43 more)"."""
    paths = [str(p) for p in paths]
    if len(paths) <= shown:
        return " + ".join(paths)
    return f"{len(paths)} files ({', '.join(paths[:shown])} and {len(paths) - shown} more)"
