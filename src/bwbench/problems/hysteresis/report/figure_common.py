"""What the switched model's figures share: axis labels of both coordinate systems, a study's
truth and synthetic flag, the problem a run was fitted in, and where the displacement reverses."""

from __future__ import annotations

import numpy as np

from bwbench.data import manifest
from bwbench.models.switched import identifiable as fm
from bwbench.models.switched import parameters as switched_parameters
from bwbench.models.switched.parameters import LABELS, UNITS
from bwbench.render.labels import split_label

EDGE = 0.06  # values beyond a parameter's Table 5 range are drawn this far beyond it (fraction of the range)


def edge_bands(ax) -> None:
    """y from just below 0 to just above 1 (positions in the Table 5 range), with grey bands beyond
    the bounds where ``np.clip(value, -EDGE, 1 + EDGE)`` puts the values outside the range."""
    ax.set_ylim(-EDGE - 0.03, 1 + EDGE + 0.03)
    for band in ((-EDGE - 0.03, 0.0), (1.0, 1 + EDGE + 0.03)):
        ax.axhspan(*band, color="0.9", lw=0, zorder=0)


def pretty_unit(unit: str) -> str:
    """A unit as figures and tables print it: "–" for none, "mm^-n+" as "mm^(−n₊)"."""
    if unit == "-":
        return "–"
    return unit.replace("^-n+", "^(−n₊)").replace("^-n-", "^(−n₋)")


def axis_label(name: str) -> str:
    """``"ωn₊ (rad/s)"``: symbol and unit of a paper, identifiable or linear parameter."""
    from bwbench.models.switched.model import LAYOUT
    from bwbench.problems.hysteresis.linear.columns import coefficient_units

    LINEAR_UNITS = coefficient_units(LAYOUT)
    if name in LABELS:
        return f"{LABELS[name]} ({pretty_unit(UNITS[name])})"
    if name in LINEAR_UNITS:
        return f"{name} ({LINEAR_UNITS[name]})"
    label = fm.LABELS.get(name, name)
    return f"{label} ({pretty_unit(fm.HYSTERETIC_UNITS.get(name, '-'))})"


def synthetic(study, specimens) -> str:
    """The mark of synthetic data for a figure of ``specimens`` ("SYNTHETIC DATA (generated from
    <source>)"), '' for measured data."""
    sources = list(dict.fromkeys(filter(None, (manifest.synthetic_source(study.specimen_path(s)) for s in specimens))))
    return f"SYNTHETIC DATA (generated from {' and '.join(sources)})" if sources else ""


def conditions(problem) -> str:
    """ "shared state, measured excitation, start from rest" (no state for a model without state
    conventions; the start as the common rule resolved it, ``bwbench.models.start``)."""
    out = (f"{problem.state} state, " if problem.state else "") + f"{problem.excitation} excitation"
    start = getattr(problem, "start", None)
    if start is not None:
        out += ", start after a pre-roll" if start.resolved == "pre-roll" else ", start from rest"
        out += f", warm-up {start.warmup_s:g} s" if start.warmup else ""
    return out


def truth(study, specimen):
    """The paper 14-vector the specimen was generated from, or None (measured data)."""
    return switched_parameters.truth_params(study.specimen_path(specimen))


def study_variants(study) -> list[tuple[str, str, str]]:
    """(label, model, formulation) of every variant of the study (one when it compares none)."""
    from bwbench.models.registry import DEFAULT
    from bwbench.problems.hysteresis.formulations import variants

    s = study.settings
    models = s.get("model", DEFAULT)
    formulations = s.get("formulation")
    return variants(
        [models] if isinstance(models, str) else list(models),
        None if formulations is None else [formulations] if isinstance(formulations, str) else list(formulations),
    )


def variant_of(study, label: str) -> tuple[str, str, str]:
    """(variant label, model, formulation) a run label was fitted in: its ``[variant]``, else the
    study's only one."""
    _, variant = split_label(label)
    pairs = study_variants(study)
    return next((p for p in pairs if p[0] == variant), pairs[0])


def formulation_of(study, label: str) -> str:
    """The formulation a run label was fitted in."""
    return variant_of(study, label)[2]


def model_of(study, label: str) -> str:
    """The model a run label was fitted with."""
    return variant_of(study, label)[1]


def problem_for(study, specimen: str, which: str = "paper", cache: dict | None = None):
    """The problem object of ``specimen`` for ``which``: a run label (its model and formulation), or
    a formulation name (the study's first variant in it, else the first model's); built once per
    pair with ``cache``."""
    pairs = study_variants(study)
    pair = next((p for p in pairs if p[2] == which), None) or (
        pairs[0][:2] + (which,) if which in ("paper", "direct", "identifiable") else variant_of(study, which)
    )
    key = (specimen, pair[1], pair[2])
    if cache is not None and key in cache:
        return cache[key]
    from bwbench.problems import SpecimenEntry

    settings = {**study.settings, "model": pair[1], "formulation": pair[2]}
    problem = study.problem_type.make_problem(settings, SpecimenEntry(specimen, str(study.specimen_path(specimen))))
    if cache is not None:
        cache[key] = problem
    return problem


def reversals(x, fraction: float = 0.05) -> np.ndarray:
    """Indices where the displacement ``x`` turns round: extremes after which it moves back by more
    than ``fraction`` of its range (noise does not count as a reversal)."""
    x = np.asarray(x, dtype=float)
    threshold = fraction * float(np.ptp(x)) if x.size else 0.0
    out, direction, extreme = [], 0, 0
    for i in range(1, x.size):
        if direction == 0:
            if abs(x[i] - x[0]) > threshold:
                direction, extreme = (1 if x[i] > x[0] else -1), i
        elif direction * (x[i] - x[extreme]) > 0:
            extreme = i
        elif direction * (x[extreme] - x[i]) > threshold:
            out.append(extreme)
            direction, extreme = -direction, i
    return np.array(out, dtype=int)


def travel_arrows(ax, x, f, turns, colour, per_stroke: int = 1) -> None:
    """Arrows along the curve (x, f) in its direction of travel, ``per_stroke`` per stroke between
    reversals (``turns``), placed mid-stroke where the branch is straight."""
    edges = np.concatenate([[0], turns, [len(x) - 1]])
    step = max(len(x) // 200, 1)
    for a, b in zip(edges[:-1], edges[1:]):
        for k in range(1, per_stroke + 1):
            i = a + (b - a) * k // (per_stroke + 1)
            j = min(i + step, len(x) - 1)
            if i >= j or (x[i] == x[j] and f[i] == f[j]):
                continue
            ax.annotate(
                "",
                xy=(x[j], f[j]),
                xytext=(x[i], f[i]),
                zorder=6,
                arrowprops={
                    "arrowstyle": "-|>",
                    "color": colour,
                    "lw": 1.4,
                    "mutation_scale": 16,
                    "shrinkA": 0,
                    "shrinkB": 0,
                },
            )
