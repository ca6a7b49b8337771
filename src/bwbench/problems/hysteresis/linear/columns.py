"""The columns of the linear solve's design matrix, and the names of the coefficients they carry.

A model's ``LinearLayout`` says which coefficients multiply a signal of the excitation (x, ẋ, ẍ or
1) and which multiplies the θ-dependent column w. A branched layout (the switched Bouc-Wen) has a
'+' copy of each column where ẋ ≥ 0 and a '−' copy where ẋ < 0; the coefficient names carry the
suffix ("c+", "f-"); the inertia coefficient (``layout.mass``) is one for both branches.
"""

from __future__ import annotations

import numpy as np

OFFSETS = ("branch", "continuous", "none")  # the constant force: one per branch, one for both, none


def offsets_mode(offsets) -> str:
    """ "branch", "continuous" or "none" from a mode name or a bool (True: per branch, False: none)."""
    if offsets is True:
        return "branch"
    if offsets is False or offsets is None:
        return "none"
    if offsets not in OFFSETS:
        raise ValueError(f"offsets must be one of {OFFSETS} or a bool, got {offsets!r}")
    return offsets


def branch_masks(layout, v) -> dict:
    """{suffix: samples of that branch}: '+' (ẋ ≥ 0) and '−' for a branched layout, else one ''."""
    if not layout.branched:
        return {"": np.ones(len(v), dtype=bool)}
    plus = np.asarray(v) >= 0.0
    return {"+": plus, "-": ~plus}


def coefficient_names(layout) -> tuple:
    """Every coefficient of ``layout``, the mass first, then per branch in the layout's order."""
    suffixes = ("+", "-") if layout.branched else ("",)
    return tuple(n for n in layout.names if n == layout.mass) + tuple(
        f"{n}{b}" for b in suffixes for n in layout.names if n != layout.mass
    )


def coefficient_units(layout) -> dict:
    names = coefficient_names(layout)
    return {n: layout.units[n.rstrip("+-") if layout.branched else n] for n in names}


def signal_column(signal, name, mask):
    """The signal ``name`` ("x", "v", "a" or "1") where ``mask`` holds, 0 elsewhere."""
    if name == "1":
        return mask.astype(float)
    return np.where(mask, np.asarray(getattr(signal, name), dtype=float), 0.0)


def fixed_columns(signal, layout, masks, offsets=True):
    """Names and columns (L,) of the w-independent per-branch columns of present branches.

    ``offsets`` (``offsets_mode``): "continuous" gives the constant force one column for both
    branches, named after the first present branch (its other branch's coefficient is tied to it)."""
    mode = offsets_mode(offsets)
    names, cols = [], []
    present = [(b, mask) for b, mask in masks.items() if mask.any()]
    rates = getattr(signal, "rate_independent", False)  # a quasi-static record: no viscous or inertia term
    for b, mask in present:
        for name, source in layout.fixed:
            if source == "1" and (mode == "none" or (mode == "continuous" and b != present[0][0])):
                continue
            if rates and source in ("v", "a"):
                continue
            names.append(f"{name}{b}")
            whole = mode == "continuous" and source == "1"
            cols.append(signal_column(signal, source, np.ones_like(mask) if whole else mask))
    return names, cols


def tied_offsets(layout, masks, offsets) -> dict:
    """{tied name: the name it equals} for continuous offsets of a branched layout ({} otherwise)."""
    present = [b for b, mask in masks.items() if mask.any()]
    if offsets_mode(offsets) != "continuous" or len(present) < 2:
        return {}
    return {f"{name}{b}": f"{name}{present[0]}" for name, source in layout.fixed if source == "1" for b in present[1:]}


def linear_force(layout, coefficients: dict, signal, w, strict: bool = False) -> np.ndarray:
    """F = Σ β_j·g_j (N) on ``signal`` (t, x, v, a) with the coefficients by name (every one of
    ``coefficient_names(layout)``) and the θ-dependent column ``w`` (L,); +inf everywhere when it is
    not finite. A branch the record moves in whose coefficients are not finite (a fit's data never had
    it): ``UserError`` when ``strict``, else +inf. A quasi-static record (``signal.rate_independent``:
    no time) has no viscous or inertia force: those columns are left out."""
    from bwbench.errors import UserError

    F = np.zeros(len(signal.x))
    quasi = getattr(signal, "rate_independent", False)
    if layout.mass and not quasi:
        F += coefficients[layout.mass] * np.asarray(signal.a, dtype=float)
    for b, mask in branch_masks(layout, signal.v).items():
        if not mask.any():
            continue
        values = {name: coefficients[f"{name}{b}"] for name, _ in layout.fixed}
        values[layout.varying] = coefficients[f"{layout.varying}{b}"]
        unknown = [f"{n}{b}" for n, v in values.items() if not np.isfinite(v)]
        if unknown and strict:
            raise UserError(
                f"the record moves in branch {b} (ẋ {'≥' if b == '+' else '<'} 0), whose "
                f"coefficients ({', '.join(unknown)}) the fit's data never had"
            )
        for name, source in layout.fixed:
            if not (quasi and source in ("v", "a")):
                F += values[name] * signal_column(signal, source, mask)
        with np.errstate(invalid="ignore", over="ignore"):
            F += values[layout.varying] * np.where(mask, w, 0.0)
    return F if np.all(np.isfinite(F)) else np.full(len(F), np.inf)
