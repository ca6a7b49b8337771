"""What `bwbench fit` states about a fitted model beyond its loss (docs/fitting.md#checks-of-a-fit):

- units of every reported parameter;
- linear branches (models that have the notion, ``Model.linear_branches``): a branch of the
  identifiable formulation whose rate dw/dx varies by less than 5 % over its samples is linear in x
  ("no yield within the stroke"): its n and η are not determined by the data, only h/x_y (a stiffness);
- the energy the fitted model dissipates per cycle, ∮F·dx (N·mm), positive for a passive specimen
  under docs/file-formats.md's sign convention; flagged when not (a note for manifest-synthetic data, whose
  loops run clockwise as the paper's identified parameters make them);
- when the velocity is estimated from the displacement: the force error that estimate is expected to
  cause at the fitted viscous coefficients, |∂F/∂ẋ| (``Model.viscous_coefficients``, of the branch
  active at each sample, RMS over the record) × the estimated RMS velocity error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.data.plausibility import LOOP_SIGN_FRACTION, loop_work

MASS_NOTE = "1 N·s²/mm = 1 t = 1000 kg"


@dataclass
class FitChecks:
    """``json``: entries for the result JSON; ``notes`` (stdout) and ``warnings`` (stderr): one line each;
    ``explained``: parameters on a box edge that a note accounts for (x_y on its cap of a linear branch)."""

    json: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    explained: set = field(default_factory=set)


def units(problem, names) -> dict:
    """Unit of every parameter name a result of ``problem`` can report (searched, solved, direct)."""
    model, state = problem.model, problem.state
    table = {p.name: p.unit for p in model.direct_parameters(state)}
    table.update({p.name: p.unit for p in problem.parameter_list})
    table.update(getattr(problem, "linear_units", {}))
    layout_mass = model.linear_layout(state).mass if model.has_linear_part else None
    if layout_mass in table:
        table[layout_mass] = f"{table[layout_mass]} ({MASS_NOTE})"
    return {name: table[name] for name in names if name in table}


def viscous_coefficients(problem, params) -> dict | None:
    """∂F/∂ẋ per branch (N·s/mm) at ``params`` (the problem's own coordinates), from the model."""
    return problem.model.viscous_coefficients(problem.parameters(np.asarray(params, dtype=float)), problem.state)


def expected_force_error(problem, params) -> dict | None:
    """For an estimated velocity: its RMS error (mm/s), the RMS of ∂F/∂ẋ over the samples (N·s/mm) and
    their product, the expected force error (N); None when the velocity is recorded or a sine fit, or
    the model cannot say what ∂F/∂ẋ is."""
    signal = problem.signal
    if not signal.velocity_estimated:
        return None
    damping = viscous_coefficients(problem, params)
    if not damping:
        return None
    c = np.where(signal.v >= 0, damping.get("+", damping.get("")), damping.get("-", damping.get("")))
    sensitivity = float(np.sqrt(np.nanmean(np.asarray(c, dtype=float) ** 2)))
    error = signal.velocity_error()
    return {"velocity_error_mm_s": error, "sensitivity_N_s_per_mm": sensitivity,
            "expected_force_error_N": sensitivity * error}


def linear_branches(problem, params) -> dict:
    """{branch: linear?} for the identifiable formulation (``Model.linear_branches``); {} otherwise."""
    if getattr(problem, "formulation", "") != "identifiable":
        return {}
    theta = np.asarray(params, dtype=float)
    w = problem.model.trajectories(theta[None, :], problem.signal, problem.state)[0]
    return problem.model.linear_branches(theta, w, problem.signal, problem.state)


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
                         f"mm/s rms × ∂F/∂ẋ {error['sensitivity_N_s_per_mm']:.4g} N·s/mm (rms of the fitted damping) "
                         f"= {error['expected_force_error_N']:.3g} N rms of expected force error")
    return out
