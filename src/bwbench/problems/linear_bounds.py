"""Bounds on the coefficients an identifiable formulation solves: which, and the bounded solve.

**Which bounds** (``physical_bounds``, the identifiable problems' default; a ``--bounds`` file or a
study's ``[bounds]`` may set any solved coefficient by name, e.g. ``{"m": [0, 0.01], "c+": [0, 50]}``):

- a fitted inertia m in [0, ``M_MAX``] = [0, 1] N·s²/mm (0 to 1 t): a negative mass is no mass, and
  no specimen or damper on a test machine moves a tonne (1 t is the paper's normalisation, m = 1);
- a viscous coefficient (unit N·s/mm: c± of the switched model, c₁ of Spencer's) ≥ 0 when the data
  follow the README's sign convention, i.e. the measured loops dissipate energy (∮F·dx > 0): a
  dashpot cannot push the way it moves. Data whose loops run the other way (the paper's synthetic
  specimens: its ξ₋ < 0 makes c₋ < 0) get no sign bound, and the design says so.

**The solve.** The unbounded least-squares solution of each row comes from the fast path
(``linear_solve``), together with its triangular factor: X = [Q | Q_w]·R, b = [Q | Q_w]ᵀ·y. A row
whose solution breaks a bound is re-solved by bounded least squares (scipy ``lsq_linear``, BVLS) on
the p × p system ‖R·β − b‖², which has the same minimiser as ‖X·β − y‖² and differs from it by the
constant RSS of the unbounded fit: O(p³) per bounded row (p ≤ 9), nothing per sample. Rows that
break no bound pay nothing beyond the check.
"""

from __future__ import annotations

import numpy as np

M_MAX = 1.0  # N·s²/mm (1 t): the largest inertia a solved m may take by default
VISCOUS_UNIT = "N·s/mm"


def physical_bounds(layout, signal, f, coefficient_units: dict) -> tuple[dict, list[str]]:
    """({coefficient: (lower, upper)}, notes) of the module docstring for one record (or a stacked
    set: ``signal`` with ``segments``) and its force ``f`` (N)."""
    from bwbench.data.plausibility import loop_work

    bounds, notes = {}, []
    if layout.mass:
        bounds[layout.mass] = (0.0, M_MAX)
    viscous = [n for n, unit in coefficient_units.items() if unit == VISCOUS_UNIT]
    if not viscous:
        return bounds, notes
    parts = getattr(signal, "segments", None) or (slice(0, len(f)),)
    x = np.asarray(getattr(signal, "x_recorded", None) if getattr(signal, "x_recorded", None) is not None
                   else signal.x, dtype=float)
    work = sum(loop_work(x[part], np.asarray(f, dtype=float)[part])[0] for part in parts)
    if work > 0:
        bounds.update({n: (0.0, np.inf) for n in viscous})
        notes.append(f"{', '.join(viscous)} ≥ 0: the measured loops dissipate energy (∮F·dx > 0), so a viscous "
                     "force opposes the motion")
    else:
        notes.append(f"{', '.join(viscous)} of either sign: the measured loops run clockwise (∮F·dx ≤ 0), against "
                     "the sign convention (force positive in tension, displacement positive in elongation)")
    return bounds, notes


def free_bounds(design) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds (arrays over ``design.free_names``) from ``design.bounds`` by name; a
    continuous offset takes the tightest of the bounds of the coefficients tied to it."""
    lower = np.full(len(design.free_names), -np.inf)
    upper = np.full(len(design.free_names), np.inf)
    for j, name in enumerate(design.free_names):
        sharing = [name] + [t for t, source in design.tied.items() if source == name]
        for n in sharing:
            lo, hi = design.bounds.get(n, (-np.inf, np.inf))
            lower[j], upper[j] = max(lower[j], lo), min(upper[j], hi)
    return lower, upper


def apply_bounds(design, out, Zw, qwy, good) -> None:
    """Re-solve, in place in ``out`` (a ``LinearSolution``), every good row whose unbounded coefficients
    break ``design.lower``/``upper``. ``Zw``: the rows' w trajectories as the design saw them (weighted);
    ``qwy``: the kernel's Q_wᵀ·y per row."""
    from scipy.optimize import lsq_linear

    beta = out.coef_ls
    with np.errstate(invalid="ignore"):
        bad = good & np.any((beta < design.lower) | (beta > design.upper), axis=1)
    if not bad.any():
        return
    q = design.Q.shape[1]
    for i in np.flatnonzero(bad):
        b = np.concatenate([design.Qty, qwy[i]])
        R = out.R[i]
        fit = lsq_linear(R, b, bounds=(design.lower, design.upper), method="bvls")
        new = np.clip(fit.x, design.lower, design.upper)
        extra = float(np.sum((R @ new - b) ** 2))
        rss = out.rss_ls[i] + extra
        out.mse[i] = rss / design.L
        out.coef[i, design.free_index] = new
        design._tie(out.coef[i:i + 1])
        out.bound_active[i] = True
        if out.residual is not None:
            delta = new - beta[i]
            change = design.G @ delta[:q]
            for k in range(len(design.w_names)):
                change += delta[q + k] * np.where(design._col == k, Zw[i], 0.0)
            out.residual[i] += change if design.sw is None else change / design.sw
