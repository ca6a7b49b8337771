"""From plain values to the problem of a fit: the one path ``bwbench fit`` (and ``simulate``,
``evaluate``, ``identifiability``), ``bwbench.fit`` and every run of a study take.

``setup_fit(data, model=..., formulation=..., ...)`` checks each setting with the command line's
words (``UserError``), reads the tests (paths, ``Specimen`` objects or DataFrames), refuses a file
named twice or one that cannot be fitted (``data check``'s refusals), chooses the formulation from
the data when none is asked (``data_formulation``), reads the bounds against the names of that
formulation, builds the problem (``formulations.make_problem``) and, for a user's bounds, probes
their box before any fit. It returns a ``FitSetup``: the problem and what the fit's output says of
how it was set up.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from bwbench.data.json_input import read_json_file
from bwbench.errors import InputFileError, UserError

WEIGHTINGS = ("equal", "samples")


@dataclass(frozen=True, eq=False)
class FitSetup:
    """``problem``: what is fitted (one file's problem, or a joint problem of several); ``specimens``:
    the tests read; ``settings``: model, formulation, state, excitation, fix_mass, offsets, weighting,
    bounds as the problem was built with them; ``synthetic``: every file is a manifest's synthetic
    specimen; ``formulation_reason``: which formulation and why, in one sentence; ``bounds_file``:
    the bounds file, if the bounds came from one; ``box_probe_s``: seconds spent probing the user's
    box (None: no box given)."""

    problem: object
    specimens: tuple
    settings: dict
    synthetic: bool
    formulation_reason: str
    bounds_file: str | None = None
    box_probe_s: float | None = None
    paths: tuple = field(default_factory=tuple)
    controlled: bool = False  # one model across a control range (``control``, ``laws``)


def checked_settings(
    *,
    model=None,
    formulation=None,
    state=None,
    excitation=None,
    fix_mass="auto",
    offsets=None,
    weighting=None,
) -> dict:
    """Each setting checked with the command line's words (``UserError``), before any file is read:
    model (a registered name), formulation (None: chosen from the data by ``setup_fit``), state,
    excitation, fix_mass ("auto", None or "fit", or a mass ≥ 0 in N·s²/mm), offsets, weighting."""
    from bwbench.models import registry
    from bwbench.problems.hysteresis.formulations import FORMULATIONS, resolve_formulation

    for flag, value, choices in (
        ("--model", model, None),
        ("--formulation", formulation, FORMULATIONS),
        ("--state", state, ("shared", "split")),
        ("--excitation", excitation, ("measured", "sine")),
        ("--weighting", weighting, WEIGHTINGS),
        ("--offsets", offsets, ("branch", "continuous")),
    ):
        if value is None:
            continue
        if not isinstance(value, str) or not value.strip() or (choices and value not in choices):
            allowed = f"one of {', '.join(map(repr, choices))}" if choices else "a model name (see `bwbench models`)"
            raise UserError(f"{flag} must be {allowed}, got {value!r}")
    chosen = registry.get(model or registry.DEFAULT)
    if state is not None and not chosen.states:
        raise UserError(f"--state does not apply to model {chosen.name!r} (no state convention to choose)")
    if formulation is not None:
        formulation = resolve_formulation(chosen, formulation)
    return {
        "model": chosen.name,
        "formulation": formulation,
        "state": state or "shared",
        "excitation": excitation or "measured",
        "fix_mass": fix_mass_value(fix_mass),
        "offsets": offsets,
        "weighting": weighting or "equal",
    }


def fix_mass_value(value, flag: str = "--fix-mass"):
    """ "auto", None ("fit": always fitted) or a mass ≥ 0 (N·s²/mm) of ``--fix-mass`` or ``fix_mass=``;
    ``UserError`` otherwise."""
    import math

    if value is None or value == "fit":
        return None
    if value == "auto":
        return "auto"
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        number = math.nan
    else:
        try:
            number = float(value)
        except ValueError:
            number = math.nan
    if not (math.isfinite(number) and number >= 0):
        raise UserError(f"{flag} must be 'auto', 'fit' or a mass ≥ 0 in N·s²/mm (1 N·s²/mm = 1 t), got {value!r}")
    return number


def check_fit_flags(settings: dict) -> None:
    """``UserError`` for a fit option that does nothing for the chosen model and formulation (as
    ``--state`` is for a model without states): a fixed mass without a solved mass, offsets without
    branches."""
    from bwbench.models import registry

    model = registry.get(settings["model"])
    identifiable = settings["formulation"] == "identifiable"
    layout = model.linear_layout(settings["state"] if model.states else None) if model.has_linear_part else None
    if settings["fix_mass"] != "auto":
        if not identifiable:
            raise UserError(
                f"--fix-mass applies to the identifiable formulation (the {settings['formulation']} "
                "formulation has no solved mass)"
            )
        if layout is None or not layout.mass:
            raise UserError(
                f"--fix-mass does not apply to model {model.name!r} (its identifiable formulation has no mass term)"
            )
    if settings["offsets"] is not None and (not identifiable or layout is None or not layout.branched):
        raise UserError(
            f"--offsets applies to the identifiable formulation of a model that switches its coefficients with "
            f"the direction (the switched model), not to {model.name!r} in the {settings['formulation']} formulation"
        )


def refuse_same_file(paths) -> None:
    """``UserError`` when two of ``paths`` are one file by any spelling (``./a.csv``, a symlink, a hard
    link): a joint fit would weigh it twice."""
    from bwbench.data.output_paths import same_file

    paths = [p for p in paths if isinstance(p, (str, Path))]
    for i, a in enumerate(paths):
        for b in paths[:i]:
            if same_file(a, b):
                spelled = "" if str(a) == str(b) else f" (as {b} and {a})"
                raise UserError(
                    f"{a}: a specimen is named twice{spelled}: a joint fit takes each file once (use "
                    "--weighting to weight)"
                )


def setup_fit(
    data,
    *,
    model=None,
    formulation=None,
    state=None,
    excitation=None,
    fix_mass="auto",
    offsets=None,
    weighting=None,
    bounds=None,
    name: str | None = None,
    force_needed: bool = True,
    log=None,
    control=None,
    control_levels: dict | None = None,
    laws=None,
    control_filter: bool = False,
    law_search: tuple | None = None,
    initial_state: str = "auto",
    warmup: float = 0.0,
) -> FitSetup:
    """The ``FitSetup`` of ``data`` (a path, ``Specimen`` or DataFrame, or a list of them: a joint fit)
    with these settings (see ``checked_settings``). ``bounds``: {name: (lower, upper)} or the path of
    a JSON file of them (searched names set the search box, solved coefficients bound the linear
    solve); a given box is probed at its corners before any fit, the probe announced on ``log``.
    ``force_needed``: refuse a file without force (a fit; not a simulation). ``initial_state`` ("auto",
    "rest", "pre-roll") and ``warmup`` (s): how every model starts each record and what the loss leaves
    out (``bwbench.models.start``). ``control`` (a column
    ``<quantity>_<unit>`` or ``COLUMN=VALUE``), ``control_levels`` ({file: level}), ``laws``
    ({parameter: law} or "auto"), ``control_filter``: one model across a control range
    (``problems.hysteresis.control``; ``law_search``: optimizer, budget, seed of ``auto``'s per-level
    fits). ``UserError`` for any bad setting or file, naming it, before any work."""
    from bwbench.data import bounds as bounds_mod
    from bwbench.data import manifest, plausibility
    from bwbench.data.specimen import Specimen
    from bwbench.data.specimen_input import as_specimen
    from bwbench.models import registry
    from bwbench.problems.hysteresis.formulations import bound_names, data_formulation, make_problem

    settings = checked_settings(
        model=model,
        formulation=formulation,
        state=state,
        excitation=excitation,
        fix_mass=fix_mass,
        offsets=offsets,
        weighting=weighting,
    )
    items = [d for item in _as_list(data) for d in _as_list(item)]
    if not items:
        raise UserError("a fit needs at least one test (a specimen CSV's path, a Specimen or a DataFrame)")
    if any(isinstance(d, (str, Path)) and not str(d).strip() for d in items):
        raise UserError("a specimen must be a path to a specimen CSV, a Specimen or a DataFrame, got ''")
    if bounds is not None and not isinstance(bounds, (str, Path, dict)):
        raise UserError(f"bounds must be a dict of name -> (lower, upper) or a JSON file, got {bounds!r}")
    paths = tuple(d.path if isinstance(d, Specimen) else d for d in items)
    refuse_same_file(paths)
    if len(items) == 1 and settings["weighting"] != "equal":
        raise UserError(
            f"--weighting {settings['weighting']} weighs the files of a joint fit; one file has nothing to weigh"
        )
    if len(items) > 1:
        from bwbench.data.input_files import refuse_same_content

        refuse_same_content([p for p in paths if isinstance(p, (str, Path)) and str(p)])  # a copy counted twice
    from bwbench.problems.hysteresis.control import setup as control_setup

    controlled = control_setup.wanted(control, laws, control_filter)
    if controlled:
        specimens, laws = control_setup.read_controlled(items, name, control, control_levels, laws, control_filter)
    else:
        specimens = tuple(as_specimen(d, name) for d in items)
    # data check's refusals (a dead channel; for a fit, no force), before any work; its warnings are
    # the fit's findings
    plausibility.screen(specimens, force_needed=force_needed, warn=False)
    chosen = registry.get(settings["model"])
    file_paths = [p for p in paths if isinstance(p, (str, Path)) and str(p)]
    chosen_from_data = settings["formulation"] is None
    if chosen_from_data:
        settings["formulation"], reason = data_formulation(chosen, file_paths if len(file_paths) == len(paths) else [])
    else:
        reason = f"{chosen.name} in the {settings['formulation']} formulation (asked for)"
    check_fit_flags(settings)
    bounds_file = None
    if bounds is not None:
        names = bound_names([settings["formulation"]], settings["state"], [settings["model"]])
        bounds_file = None if isinstance(bounds, dict) else str(bounds)
        table = None
        try:
            table = dict(bounds) if isinstance(bounds, dict) else read_json_file(Path(bounds))
            settings["bounds"] = bounds_mod.validate(table, names, bounds_file or "bounds")
        except InputFileError as err:
            raise _other_formulation_hint(err, table, chosen, settings, chosen_from_data) from None
    from bwbench.models import start as start_rule

    settings["initial_state"], settings["warmup_s"] = start_rule.check(initial_state, warmup)
    if controlled and settings["warmup_s"]:
        raise UserError("--warmup does not apply to a fit across a control yet: its files are scored whole")
    problem_settings = {k: v for k, v in settings.items() if v is not None or k == "fix_mass"}
    if problem_settings.get("offsets") is None:
        problem_settings.pop("offsets", None)
    if controlled:
        problem = control_setup.build_controlled(specimens, problem_settings, laws, control_filter, law_search, log)
    else:
        problem = make_problem(list(specimens) if len(specimens) > 1 else specimens[0], problem_settings)
    probe_s = None
    if "bounds" in settings:
        where = f"--bounds {bounds_file}" if bounds_file else "bounds"
        if log is not None:
            print(
                f"probing the search box of {where} ({bounds_mod.PROBE_CORNERS} corners, one evaluation each) …",
                file=log,
                flush=True,
            )
        start = time.perf_counter()
        bounds_mod.refuse_if_blows_up(problem, where)
        probe_s = time.perf_counter() - start
        if log is not None:
            print(f"probing the search box: done in {probe_s:.1f} s", file=log, flush=True)
    synthetic = bool(file_paths) and len(file_paths) == len(paths) and all(manifest.is_synthetic(p) for p in file_paths)
    return FitSetup(problem, specimens, settings, synthetic, reason, bounds_file, probe_s, paths, controlled)


def _other_formulation_hint(err, table, model, settings, chosen_from_data: bool):
    """``err`` with a hint when the bounds name parameters of the model's other formulation while the
    formulation was chosen from the data (a bounds file written for the paper's box, say)."""
    from bwbench.problems.hysteresis.formulations import bound_names

    if not chosen_from_data or not isinstance(table, dict):
        return err
    for other in model.formulations:
        if other == settings["formulation"]:
            continue
        if table and set(table) <= set(bound_names([other], settings["state"], [model.name])):
            flag = "paper" if other == model.direct_name and other in ("paper", "direct") else other
            return InputFileError(
                err.path,
                err.line,
                f"{err.problem}: these bounds name the {other} formulation's parameters, and for these data "
                f"the default is the {settings['formulation']} one; add --formulation {flag}",
            )
    return err


def _as_list(value) -> list:
    return list(value) if isinstance(value, (list, tuple)) else [value]
