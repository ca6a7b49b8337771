"""What `bwbench fit` states about a fitted switched model beyond its loss (README "Checks of a fit"):

- units of every reported parameter;
- linear branches: a branch of the identifiable formulation whose hysteretic variable w stays where
  its rate dw/dx varies by less than ``LINEAR_TOLERANCE`` over the branch's samples is linear in x
  ("no yield within the stroke"): its n and η are not determined by the data, only h/x_y (a stiffness);
- the energy the fitted model dissipates per cycle, ∮F·dx (N·mm), positive for a passive specimen
  under the README's sign convention; flagged when not (a note for manifest-synthetic data, whose
  loops run clockwise as the paper's identified parameters make them);
- when the velocity is estimated from the displacement: the force error that estimate is expected to
  cause at the fitted viscous coefficients, |∂F/∂ẋ| (the c of the branch active at each sample, RMS
  over the record) × the estimated RMS velocity error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.data.parameters import UNITS as PAPER_UNITS
from bwbench.data.plausibility import LOOP_SIGN_FRACTION, loop_work
from bwbench.problems.switched_vpp import identifiable as fm
from bwbench.problems.switched_vpp.linear_solve import LINEAR_NAMES, LINEAR_UNITS

# A branch is linear when c·|w/w_sat|^n (the relative change of dw/dx, see ``identifiable``) stays
# below this on all its samples: its loop differs from a straight line by less than 5 % of its slope.
LINEAR_TOLERANCE = 0.05
MASS_NOTE = "1 N·s²/mm = 1 t = 1000 kg"


@dataclass
class FitChecks:
    """``json``: entries for the result JSON; ``notes`` (stdout) and ``warnings`` (stderr): one line each;
    ``explained``: parameters on a box edge that a note accounts for (x_y on its cap of a linear branch)."""

    json: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    explained: set = field(default_factory=set)


def units(names) -> dict:
    """Unit of every parameter name a switched-model result can report (paper, identifiable, linear)."""
    table = {**PAPER_UNITS, **fm.HYSTERETIC_UNITS, **LINEAR_UNITS, "m": f"N·s²/mm ({MASS_NOTE})"}
    return {name: table[name] for name in names if name in table}


def viscous_coefficients(problem, params) -> tuple[float, float]:
    """(c₊, c₋) = ∂F/∂ẋ on each branch (N·s/mm) at ``params`` (the problem's own coordinates)."""
    params = np.asarray(params, dtype=float)
    if getattr(problem, "formulation", "paper") == "identifiable":
        linear = problem.linear(params)
        return float(linear[LINEAR_NAMES.index("c+")]), float(linear[LINEAR_NAMES.index("c-")])
    return float(2 * params[5] * params[6]), float(2 * params[12] * params[13])


def expected_force_error(problem, params) -> dict | None:
    """For an estimated velocity: its RMS error (mm/s), the RMS of ∂F/∂ẋ over the samples (N·s/mm) and
    their product, the expected force error (N); None when the velocity is recorded or a sine fit."""
    signal = problem.signal
    if not signal.velocity_estimated:
        return None
    c_plus, c_minus = viscous_coefficients(problem, params)
    c = np.where(signal.v >= 0, c_plus, c_minus)
    sensitivity = float(np.sqrt(np.nanmean(c**2)))
    error = signal.velocity_error()
    return {"velocity_error_mm_s": error, "sensitivity_N_s_per_mm": sensitivity,
            "expected_force_error_N": sensitivity * error}


def linear_branches(problem, params) -> dict:
    """{"+": bool, "-": bool} for the identifiable formulation (see the module docstring); {} otherwise."""
    if getattr(problem, "formulation", "paper") != "identifiable":
        return {}
    theta = np.asarray(params, dtype=float)
    w = problem.model.trajectories(theta[None, :])[0]
    if not np.all(np.isfinite(w)):
        return {}
    names = problem.param_names
    rho = theta[names.index("rho")] if "rho" in names else 1.0
    plus = problem.signal.v >= 0
    out = {}
    for b, mask, scale, direction in (("+", plus, 1.0, 1.0), ("-", ~plus, rho, -1.0)):
        if not mask.any():
            continue
        n, eta = theta[names.index(f"n{b}")], theta[names.index(f"eta{b}")]
        ws = w[mask] / scale
        c = np.where(ws * direction > 0, 1.0, eta)  # loading (moving away from w = 0) or unloading
        out[b] = bool(np.max(np.abs(c) * np.abs(ws) ** n) < LINEAR_TOLERANCE)
    return out


def energy_per_cycle(problem, params) -> tuple[float, float, float]:
    """(∮F·dx per cycle of the fitted model in N·mm, cycles, the size below which its sign is not called:
    ``LOOP_SIGN_FRACTION`` × 2·amplitude × force range, N·mm)."""
    force = problem.simulate(np.asarray(params, dtype=float))
    x = problem.signal.x
    if not np.all(np.isfinite(force)):
        return float("nan"), 0.0, 0.0
    per_cycle, cycles = loop_work(x, force)
    return per_cycle, cycles, LOOP_SIGN_FRACTION * float(np.ptp(x)) * float(np.ptp(force))


def check(problem, params, synthetic: bool = False, at_bound: dict | None = None) -> FitChecks:
    """Everything of the module docstring for the best parameters of a fit (problem coordinates);
    ``at_bound``: the fit's parameters on a box edge (``fitting.on_box_edge``)."""
    out = FitChecks()
    at_bound = at_bound or {}
    params = np.asarray(params, dtype=float)
    if not np.all(np.isfinite(params)):
        return out
    work, cycles, threshold = energy_per_cycle(problem, params)
    out.json["energy_per_cycle_Nmm"] = work
    if np.isfinite(work) and cycles >= 0.5:
        out.notes.append(f"energy dissipated per cycle by the fitted model: ∮F·dx = {work:.4g} N·mm ({work / 1000:.3g} J)")
        if work < -threshold:
            if synthetic:
                out.notes.append("note: the fitted loop runs clockwise (∮F·dx < 0), as the paper's identified "
                                 "parameters make the synthetic specimens run")
            else:
                out.warnings.append(f"the fitted model generates energy (∮F·dx = {work:.4g} N·mm per cycle < 0): a "
                                    "passive specimen dissipates it (force positive in tension, displacement positive "
                                    "in elongation): is the force or the displacement flipped?")
    for b, linear in linear_branches(problem, params).items():
        out.json.setdefault("linear_branches", {})[b] = linear
        if linear:
            out.notes.append(f"branch {b} is linear (no yield within the stroke): n{b} and eta{b} are not determined "
                             f"by these data, only h{b}/xy{b}")
            if at_bound.get(f"xy{b}") == "upper":
                out.explained.add(f"xy{b}")
    error = expected_force_error(problem, params)
    if error is not None:
        out.json["velocity_estimate"] = error
        out.notes.append(f"velocity estimated from the displacement: expected error {error['velocity_error_mm_s']:.2g} "
                         f"mm/s rms × ∂F/∂ẋ {error['sensitivity_N_s_per_mm']:.4g} N·s/mm (rms of the fitted c±) "
                         f"= {error['expected_force_error_N']:.3g} N rms of expected force error")
    return out
