"""The control part of a fit's set-up (``problems.hysteresis.setup.setup_fit``'s ``control=``, ``laws=``):
the tests read with their control, the laws checked, ``--law auto``'s per-level fits, the problem."""

from __future__ import annotations

from pathlib import Path

from bwbench.errors import UserError


def wanted(control, laws, control_filter) -> bool:
    return bool(control) or bool(laws) or bool(control_filter)


def read_controlled(items, name, control, control_levels, laws, control_filter):
    """(the specimens of ``items`` (paths, ``Specimen`` objects, DataFrames) each with its control, the
    laws: {parameter: law} or "auto"); ``UserError`` for a missing or doubled control, a bad law."""
    from bwbench.data import control as control_mod
    from bwbench.data.specimen import Specimen
    from bwbench.data.specimen_input import as_specimen
    from bwbench.problems.hysteresis.control import laws as laws_mod

    texts = control if isinstance(control, (list, tuple)) else ([control] if control else [])
    spec = control_mod.parse_all(texts)
    if spec is None:
        raise UserError(
            "--law and --control-filter need the control: --control COLUMN (e.g. current_A) or COLUMN=VALUE"
        )
    parsed = laws_mod.parse(laws) if laws else {}  # none: constants, each file's level recorded
    if parsed == "auto" and control_filter:
        raise UserError(
            "--law auto fits each control level alone: it needs files of constant control, not --control-filter"
        )
    levels = control_mod.levels_of(control_levels, spec)
    out = []
    for item in items:
        if isinstance(item, (str, Path)):
            level = levels.get(str(item), levels.get(Path(item).name, levels.get(Path(item).stem)))
            out.append(control_mod.read(item, spec, level))
            continue
        if isinstance(item, Specimen):
            specimen = item
        elif hasattr(item, "columns") and spec.name in [str(c).strip() for c in item.columns]:
            specimen = _frame_with_control(item, name, spec)
        else:
            specimen = as_specimen(item, name)
        out.append(control_mod.attach(specimen, spec, levels.get(specimen.name)))
    return tuple(out), parsed


def build_controlled(specimens, settings: dict, laws, control_filter: bool, law_search=None, log=None):
    """The ``ControlledProblem``; for ``laws="auto"`` each level fitted alone first (``law_search``:
    optimizer, budget, seed of those fits), the choices printed on ``log`` and kept on the problem
    (``law_choices``) with the per-level values (``law_points``, for the figure)."""
    from bwbench.problems.hysteresis.control import auto
    from bwbench.problems.hysteresis.control.problem import build

    choices: list = []
    points: dict = {}
    if laws == "auto":
        optimizer, budget, seed = law_search or ("lsq-trf", 4100, 0)
        levels = sorted({float(s.control[0]) for s in specimens})
        if log is not None:
            print(
                f"--law auto: fitting each of the {len(levels)} {specimens[0].control_name} levels alone …",
                file=log,
                flush=True,
            )
        fits = auto.per_level_fits(specimens, settings, optimizer, budget, seed)
        first = fits[levels[0]]
        choices = auto.choose_laws(fits, specimens[0].control_name, first[0].units(list(first[2])))
        for c in choices:
            if log is not None:
                print(f"  {c.parameter}: {c.law} — {c.reason}", file=log, flush=True)
        laws = {c.parameter: c.law for c in choices if c.law != "constant"}
        points = {n: [(lv, v[n][0], v[n][1]) for lv, (_, _, v) in fits.items() if n in v] for n in first[2]}
    problem = build(list(specimens), settings, laws, control_filter=control_filter)
    problem.law_choices = tuple(choices)
    problem.law_points = points
    return problem


def _frame_with_control(frame, name, spec):
    """The ``Specimen`` of a DataFrame that carries the control column: the column checked (numeric, every
    value finite, its row named), the rest read as any DataFrame is."""
    import dataclasses

    import numpy as np

    from bwbench.data.specimen_input import as_specimen

    column = next(c for c in frame.columns if str(c).strip() == spec.name)
    label = f"DataFrame {str(name or frame.attrs.get('name') or 'data')!r}"
    try:
        u = np.asarray(frame[column], dtype=float)
    except (TypeError, ValueError):
        raise UserError(f"{label}: column {spec.name} is not numeric") from None
    bad = np.flatnonzero(~np.isfinite(u))
    if bad.size:
        raise UserError(f"{label}, row {int(bad[0])}: {spec.name} is {float(u[bad[0]])}: every value must be finite")
    specimen = as_specimen(frame.drop(columns=[column]), name)
    u = np.ascontiguousarray(u)
    u.flags.writeable = False
    return dataclasses.replace(specimen, control=u, control_name=spec.name)
