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
  active at each sample, RMS over the record) × the estimated RMS velocity error;
- checks that can fail (``residual_checks``): the work of each branch and at the reversals against the
  measured (the total ∮F·dx the linear solve matches whatever the fit), and the residual's structure
  (RMSE against the force noise, its share at the reversals, its autocorrelation);
- physical limits (``Model.coefficient_limits``, ``Model.parameter_limits``): a solved coefficient held
  on its physical limit that the unbounded solve would put beyond it, and a searched parameter on a
  box edge that is a physical limit, are findings about the model or the data — not box warnings;
- plausibility of every fitted parameter with its physical meaning (``Model.plausibility``);
- how the record was started, the same for every model (``bwbench.models.start``).

Every check is of the samples in the loss: a warm-up left out of the loss is left out of them too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bwbench.data.plausibility import LOOP_SIGN_FRACTION, loop_work
from bwbench.problems.hysteresis.linear.bounds import VISCOUS_UNIT

MASS_NOTE = "1 N·s²/mm = 1 t = 1000 kg"


@dataclass
class FitChecks:
    """``json``: entries for the result JSON; ``notes`` (stdout) and ``warnings`` (stderr): one line each;
    ``explained``: parameters on a box edge that a note accounts for (x_y on its cap of a linear branch, a
    physical limit); ``findings`` (stdout, "finding:"): what the fit says about the model or the data
    (a physical limit the fit wants to leave, an implausible parameter, a check that failed)."""

    json: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    explained: set = field(default_factory=set)
    findings: list = field(default_factory=list)


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
    return {
        "velocity_error_mm_s": error,
        "sensitivity_N_s_per_mm": sensitivity,
        "expected_force_error_N": sensitivity * error,
    }


def linear_branches(problem, params) -> dict:
    """{branch: linear?} for the identifiable formulation (``Model.linear_branches``); {} otherwise."""
    if getattr(problem, "formulation", "") != "identifiable":
        return {}
    theta = np.asarray(params, dtype=float)
    w = problem.record_trajectories(theta)[0][problem.start.loss]
    return problem.model.linear_branches(theta, w, problem.loss_signal, problem.state)


def energy_per_cycle(problem, params) -> tuple[float, float, float]:
    """(∮F·dx per cycle of the fitted model in N·mm, cycles, the size below which its sign is not called:
    ``LOOP_SIGN_FRACTION`` × 2·amplitude × force range, N·mm)."""
    force = problem.simulate(np.asarray(params, dtype=float))[problem.start.loss]
    x = problem.loss_signal.x
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
    shape = record_protocol(problem)
    if shape is not None and not shape.periodic:
        out.json["periodic_checks"] = f"skipped: {shape.describe()}"
        out.notes.append(
            f"periodic-motion checks skipped (energy per cycle, its split by branch and reversal zone, the "
            f"residual's reversal statistics): the record is {shape.describe()}"
        )
    elif np.isfinite(work) and cycles >= 0.5:
        out.notes.append(
            f"energy dissipated per cycle by the fitted model: ∮F·dx = {work:.4g} N·mm ({work / 1000:.3g} J)"
        )
        if work < -threshold:
            if synthetic:
                out.notes.append(
                    "note: the fitted loop runs clockwise (∮F·dx < 0), as the paper's identified "
                    "parameters make the synthetic specimens run"
                )
            else:
                out.warnings.append(
                    f"the fitted model generates energy (∮F·dx = {work:.4g} N·mm per cycle < 0): a "
                    "passive specimen dissipates it (force positive in tension, displacement positive "
                    "in elongation): is the force or the displacement flipped?"
                )
    for b, linear in linear_branches(problem, params).items():
        out.json.setdefault("linear_branches", {})[b] = linear
        if linear:
            out.notes.append(
                f"branch {b} is linear (no yield within the stroke): n{b} and eta{b} are not determined "
                f"by these data, only h{b}/xy{b}"
            )
            if at_bound.get(f"xy{b}") == "upper":
                out.explained.add(f"xy{b}")
    physical_limit_findings(problem, params, at_bound, out)
    if hasattr(problem, "loss_batch"):  # a file of a joint fit cannot move the box: the joint problem does
        edge_findings(problem, params, at_bound, out)
    failing_checks(problem, params, out)
    plausibility_findings(problem, params, out)
    if hasattr(problem, "start"):
        out.json["initial_state"] = problem.start.describe()
        out.notes.append(f"initial state: {problem.start.describe()}")
    error = expected_force_error(problem, params)
    if error is not None:
        out.json["velocity_estimate"] = error
        out.notes.append(
            f"velocity estimated from the displacement: expected error {error['velocity_error_mm_s']:.2g} "
            f"mm/s rms × ∂F/∂ẋ {error['sensitivity_N_s_per_mm']:.4g} N·s/mm (rms of the fitted damping) "
            f"= {error['expected_force_error_N']:.3g} N rms of expected force error"
        )
    return out


def physical_limit_findings(problem, params, at_bound: dict, out: FitChecks) -> None:
    """Solved coefficients held on a physical limit the unbounded solve would cross, and searched
    parameters on a box edge that is a physical limit (``Model.parameter_limits``): findings, and the
    latter taken out of the box-edge warnings (``explained``)."""
    limits = problem.model.parameter_limits(problem.state)
    for name, side in at_bound.items():
        why = limits.get(name, {}).get(side)
        if why:
            out.explained.add(name)
            out.json.setdefault("physical_limits", {})[name] = {"side": side, "meaning": why}
            out.findings.append(f"{name} on its {side} limit: {why}")
    design = getattr(problem, "design", None)
    if design is None or not hasattr(problem, "solve"):
        return
    coefficient = problem.model.coefficient_limits(problem.state)
    solution = problem.solve(np.asarray(params, dtype=float)[None, :])
    if not solution.bound_active[0]:
        return
    unbounded = dict(zip(solution.free_names, map(float, solution.coef_ls[0])))
    solved = dict(zip(solution.names, map(float, solution.coef[0])))
    rmse_free = float(np.sqrt(solution.rss_ls[0] / solution.n_data))
    rmse = float(np.sqrt(solution.mse[0]))
    units = getattr(problem, "linear_units", {})
    for name, (lo, hi) in design.bounds.items():
        if name not in unbounded or lo <= unbounded[name] <= hi:
            continue
        unit = units.get(name, "")
        why = (
            coefficient[name][2]
            if name in coefficient
            else f"{name} ≥ 0: a dashpot cannot push the way it moves"
            if unit == VISCOUS_UNIT and lo == 0
            else f"{name} in [{lo:g}, {hi:g}] N·s²/mm: a negative mass is no mass, and no damper or specimen on a "
            "test rig moves a tonne"
            if name == getattr(problem.model.linear_layout(problem.state), "mass", None)
            else f"{name} bounded to [{lo:g}, {hi:g}]"
        )
        entry = {
            "value": solved.get(name),
            "unbounded": unbounded[name],
            "bound": [lo, hi],
            "rmse_N": rmse,
            "rmse_unbounded_N": rmse_free,
            "meaning": why,
        }
        out.json.setdefault("physical_limits", {})[name] = entry
        gain = 1.0 - rmse_free / rmse if rmse > 0 else 0.0
        verdict = (
            f"the limit costs {gain:.1%} of the RMSE: the data barely ask for it ({name} is not determined "
            "by this test)"
            if gain < 0.01
            else f"the limit costs {gain:.1%} of the RMSE: the model or the data want what the damper cannot do "
            "physically (model error, or a sign or offset in the data)"
        )
        out.findings.append(
            f"{name} = {solved.get(name, float('nan')):.4g} {unit} held on its physical limit — {why}; "
            f"the data alone would put it at {unbounded[name]:.4g} {unit} (RMSE {rmse:.4g} N → "
            f"{rmse_free:.4g} N): {verdict}"
        )


def edge_findings(problem, params, at_bound: dict, out: FitChecks) -> None:
    """The box edges no other check explains, classified (``edges.classify``): an undetermined one is a
    note, not a "widen" warning; a box too small keeps its warning."""
    from bwbench.problems.hysteresis import edges

    for edge in edges.classify(problem, params, {n: s for n, s in at_bound.items() if n not in out.explained}):
        out.json.setdefault("edges", {})[edge.name] = edge.to_json()
        if edge.kind == edges.UNDETERMINED:
            out.explained.add(edge.name)
            out.notes.append(edge.text)
        elif edge.kind == edges.MODEL_LIMIT:
            out.explained.add(edge.name)
            out.findings.append(edge.text)


def record_protocol(problem):
    """The loading protocol (``models.protocol``) of a one-file problem's displacement; None for a joint one."""
    if not hasattr(problem, "specimen") or not hasattr(problem, "signal"):
        return None
    from bwbench.models.protocol import protocol

    return protocol(problem.signal.x)


def failing_checks(problem, params, out: FitChecks) -> None:
    """The energy split and the residual structure of ``residual_checks`` (one file; a joint fit: each
    file's own), as JSON and, where they fail, findings."""
    from bwbench.problems.hysteresis import residual_checks
    from bwbench.problems.hysteresis.inertia_rule import force_noise

    if not hasattr(problem, "simulate") or not hasattr(problem, "specimen"):
        return
    force = problem.simulate(np.asarray(params, dtype=float))[problem.start.loss]
    if not np.all(np.isfinite(force)):
        return
    signal, measured = problem.loss_signal, np.asarray(problem.f_loss, dtype=float)
    shape = record_protocol(problem)
    if shape is not None and not shape.periodic:  # per-cycle quantities of an irregular record mean nothing
        structure = residual_checks.residual_structure(
            signal.t, signal.x, force - measured, force_noise(measured), None
        )
        out.json["residual_structure"] = structure
        text = (
            f"residual: RMSE {structure['rmse_N']:.3g} N = {structure['rmse_over_noise']:.2g} × the force noise "
            f"{structure['noise_N']:.3g} N; autocorrelation {structure['autocorrelation']:.2f} at 1 sample"
        )
        if structure["model_error_dominates"]:
            out.findings.append(f"{text}: model error, not noise, dominates the residual")
        else:
            out.notes.append(f"{text}: the residual is close to the noise")
        return
    energy = residual_checks.energy_split(signal.x, signal.v, force, measured)
    out.json["energy_check"] = energy
    if not energy["passed"]:
        parts = ", ".join(
            f"{name} {part['mismatch']:.1%}"
            for name, part in energy["parts"].items()
            if part["mismatch"] > energy["tolerance"]
        )
        out.findings.append(
            f"energy check failed: the fitted model's work misses the measured one by {parts} of the "
            f"loop energy (tolerance {energy['tolerance']:.0%}): the loop's shape is wrong where the "
            "total ∮F·dx (which a least-squares fit matches closely) cannot tell"
        )
    else:
        out.notes.append(
            f"energy check passed: work per branch and at the reversals within "
            f"{energy['worst_mismatch']:.2%} of the measured loop energy (tolerance {energy['tolerance']:.0%})"
        )
    _, cycles = loop_work(signal.x, measured)
    cycle_s = float(signal.t[-1] - signal.t[0]) / cycles if cycles >= 0.5 else None
    structure = residual_checks.residual_structure(signal.t, signal.x, force - measured, force_noise(measured), cycle_s)
    out.json["residual_structure"] = structure
    text = (
        f"residual: RMSE {structure['rmse_N']:.3g} N = {structure['rmse_over_noise']:.2g} × the force noise "
        f"{structure['noise_N']:.3g} N; {structure['reversal_error_share']:.0%} of the squared error at the reversals "
        f"({structure['reversal_sample_share']:.0%} of the samples); autocorrelation {structure['autocorrelation']:.2f} "
        f"at {structure['lag_samples']} sample{'s' if structure['lag_samples'] > 1 else ''}"
    )
    if structure["reversals_missed"]:
        out.findings.append(f"{text}: the model misses the reversals")
    elif structure["model_error_dominates"]:
        out.findings.append(f"{text}: model error, not noise, dominates the residual")
    else:
        out.notes.append(f"{text}: the residual is close to the noise")


def plausibility_findings(problem, params, out: FitChecks) -> None:
    """``Model.plausibility`` of the fit's parameters: the table in the JSON, a finding per implausible one."""
    values = problem.parameters(np.asarray(params, dtype=float)) if hasattr(problem, "parameters") else {}
    rows = problem.model.plausibility(values, problem.signal, problem.state) if hasattr(problem, "signal") else []
    if not rows:
        return
    out.json["plausibility"] = {
        name: {"value": value, "unit": unit, "meaning": meaning, "flag": verdict or None}
        for name, value, unit, meaning, verdict in rows
    }
    for name, value, unit, meaning, verdict in rows:
        if verdict:
            unit = "" if unit in ("-", "") else f" {unit}"
            out.findings.append(f"{name} = {value:.4g}{unit} ({meaning}): {verdict}")
