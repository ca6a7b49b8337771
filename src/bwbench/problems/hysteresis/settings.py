"""The settings of a fit of a hysteresis model, checked with the command line's words: the CLI
(``fit``, ``compare``, ``simulate``) and the Python API (``bwbench.fit``) refuse the same things with
the same message (``UserError``)."""

from __future__ import annotations

from pathlib import Path


def checked_settings(model=None, formulation=None, state=None, excitation=None) -> dict:
    """The settings of a model, each checked with the command line's words (``UserError``): the CLI and
    the Python API (``bwbench.fit``) refuse the same things with the same message."""
    from bwbench.errors import UserError
    from bwbench.models import registry
    from bwbench.problems.hysteresis.formulations import FORMULATIONS, resolve_formulation

    for flag, value, choices in (
        ("--model", model, None),
        ("--formulation", formulation, FORMULATIONS),
        ("--state", state, ("shared", "split")),
        ("--excitation", excitation, ("measured", "sine")),
    ):
        if value is None:
            continue
        if not isinstance(value, str) or not value.strip() or (choices and value not in choices):
            allowed = f"one of {', '.join(map(repr, choices))}" if choices else "a model name (see `bwbench models`)"
            raise UserError(f"{flag} must be {allowed}, got {value!r}")
    chosen = registry.get(model or registry.DEFAULT)
    if state is not None and not chosen.states:
        raise UserError(f"--state does not apply to model {chosen.name!r} (no state convention to choose)")
    return {
        "model": chosen.name,
        "formulation": resolve_formulation(chosen, formulation),
        "state": state or "shared",
        "excitation": excitation or "measured",
    }


def check_fit_flags(settings: dict, fix_mass="auto", offsets=None, weighting=None) -> None:
    """``UserError`` for a fit option that does nothing for the chosen model and formulation (as
    ``--state`` is for a model without states): ``--fix-mass`` without a solved mass, ``--offsets``
    without branches; and for a ``--weighting`` that is no choice."""
    from bwbench.errors import UserError
    from bwbench.models import registry

    model = registry.get(settings["model"])
    identifiable = settings["formulation"] == "identifiable"
    layout = model.linear_layout(settings["state"] if model.states else None) if model.has_linear_part else None
    if fix_mass != "auto":
        if not identifiable:
            raise UserError(
                f"--fix-mass applies to the identifiable formulation (the {settings['formulation']} "
                "formulation has no solved mass)"
            )
        if layout is None or not layout.mass:
            raise UserError(
                f"--fix-mass does not apply to model {model.name!r} (its identifiable formulation has no mass term)"
            )
    if offsets is not None:
        if offsets not in ("branch", "continuous"):
            raise UserError(f"--offsets must be 'branch' or 'continuous', got {offsets!r}")
        if not identifiable or layout is None or not layout.branched:
            raise UserError(
                f"--offsets applies to the identifiable formulation of a model that switches its "
                f"coefficients with the direction (the switched model), not to {model.name!r} in the "
                f"{settings['formulation']} formulation"
            )
    if weighting is not None and weighting not in ("equal", "samples"):
        raise UserError(f"--weighting must be 'equal' or 'samples', got {weighting!r}")


def refuse_same_file(paths) -> None:
    """``UserError`` when two of ``paths`` are one file by any spelling (``./a.csv``, a symlink, a hard
    link): a joint fit would weigh it twice."""
    from bwbench.data.output_paths import same_file
    from bwbench.errors import UserError

    paths = [p for p in paths if isinstance(p, (str, Path))]
    for i, a in enumerate(paths):
        for b in paths[:i]:
            if same_file(a, b):
                spelled = "" if str(a) == str(b) else f" (as {b} and {a})"
                raise UserError(
                    f"{a}: a specimen is named twice{spelled}: a joint fit takes each file once (use "
                    "--weighting to weight)"
                )


def fix_mass_value(text, flag: str = "--fix-mass"):
    """ "auto" (None given), None ("fit") or a mass ≥ 0 (N·s²/mm) from the text of ``flag``; ``UserError``
    otherwise."""
    import math

    from bwbench.errors import UserError

    if text is None or text == "auto":
        return "auto"
    if text == "fit":
        return None
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0):
        raise UserError(f"{flag} must be 'auto', 'fit' or a mass ≥ 0 in N·s²/mm (1 N·s²/mm = 1 t), got {text!r}")
    return value
