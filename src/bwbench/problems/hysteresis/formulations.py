"""Models and formulations: which problem object a study, a fit or an analysis builds.

A study (or a command) names one or more models (``bwbench models``; default: the paper's switched
Bouc-Wen) and one or more formulations: the model's direct one (its own parameters in its box:
"paper" for the switched model, "direct" for the others; either word is accepted for any model)
and, for models with coefficients that enter the force linearly, "identifiable" (symmetry-free
parameters searched, linear coefficients solved). Every (model, formulation) pair is a variant,
compared side by side; its label is what differs between the variants.
"""

from __future__ import annotations

from bwbench.data import bounds as bounds_mod
from bwbench.models import registry
from bwbench.problems.base import choice
from bwbench.problems.hysteresis.edges import refuse_past_limits

FORMULATIONS = ("paper", "direct", "identifiable")


def resolve_formulation(model, formulation: str | None) -> str:
    """The model's own name of ``formulation`` ("paper" and "direct" both mean its direct one; None its
    default); ``UserError`` naming what it has when it has no such formulation."""
    from bwbench.errors import UserError

    if formulation is None:
        return model.default_formulation
    if formulation in ("paper", "direct"):
        return model.direct_name
    if formulation not in model.formulations:
        raise UserError(
            f"model {model.name!r} has no formulation {formulation!r}; it has {', '.join(model.formulations)}"
        )
    return formulation


def data_formulation(model, paths) -> tuple[str, str]:
    """(formulation, why in one sentence) of ``model`` when none is asked: the switched model's paper
    formulation only for the paper's own synthetic specimens (its Table 5 box was identified on them),
    the identifiable formulation for every other file (its box is scaled from the data), and a
    model's only or default formulation otherwise."""
    from pathlib import Path

    from bwbench.data import manifest

    name = model.name
    if "identifiable" not in model.formulations:
        return model.default_formulation, f"{name} in its {model.default_formulation} formulation (its only one)"
    if model.default_formulation == "identifiable":
        return "identifiable", f"{name} in the identifiable formulation (the model's default)"
    if paths and all(isinstance(p, (str, Path)) and manifest.is_paper_data(p) for p in paths):
        return (
            model.default_formulation,
            f"{name} in the {model.default_formulation} formulation: the default for the paper's synthetic "
            "specimens (its Table 5 box was identified on them)",
        )
    return (
        "identifiable",
        f"{name} in the identifiable formulation: the default for data that are not the paper's synthetic "
        "specimens (its box is scaled from the data; --formulation paper for the paper's box)",
    )


def variants(models, formulations=None, paths=None) -> list[tuple[str, str, str]]:
    """(label, model, formulation) of every variant: each model in each formulation (None: each
    model's formulation for the data at ``paths``, ``data_formulation``; without paths its default
    one). The label names what differs: the formulation when one model is compared in several, the
    model when several are fitted in one formulation each, else both."""
    pairs = []
    for name in models:
        model = registry.get(name)
        for formulation in formulations or (None,):
            if formulation is None and paths is not None:
                formulation = data_formulation(model, paths)[0]
            pair = (name, resolve_formulation(model, formulation))
            if pair not in pairs:
                pairs.append(pair)
    several_models = len({m for m, _ in pairs}) > 1
    several_formulations = any(sum(m == n for n, _ in pairs) > 1 for m, _ in pairs)

    def label(m, f):
        if several_models and several_formulations:
            return f"{m} {f}"
        return m if several_models else f

    return [(label(m, f), m, f) for m, f in pairs]


def make_problem(specimen, settings: dict):
    """The problem of one specimen, or the joint problem of a list of them (``joint_problem``), for
    settings with model (default: the switched model), state, excitation and optionally formulation
    (default: the model's own), fix_mass, offsets, weighting (joint fits), bounds (names of the
    searched parameters set the search box, names of solved coefficients bound the linear solve;
    names the formulation does not have are left to the other one), initial_state ("auto", "rest" or
    "pre-roll") and warmup_s (s): how every model starts each record (``bwbench.models.start``)."""
    from bwbench.problems.hysteresis.model_problem import DirectProblem, IdentifiableProblem

    if isinstance(specimen, (list, tuple)):
        if len(specimen) > 1:
            return _joint_problem(specimen, settings)
        specimen = specimen[0]
    model = registry.get(settings.get("model", registry.DEFAULT))
    formulation = resolve_formulation(model, settings.get("formulation"))
    state = settings.get("state") if model.states else None
    excitation = settings.get("excitation", "measured")
    bounds = settings.get("bounds", {})
    start = {"initial_state": settings.get("initial_state", "auto"), "warmup_s": settings.get("warmup_s", 0.0)}
    problem: DirectProblem | IdentifiableProblem
    if formulation == "identifiable":
        solved = solved_bounds(model, state, bounds)
        problem = IdentifiableProblem(
            model,
            specimen,
            state,
            excitation,
            fix_mass=settings.get("fix_mass", "auto"),
            offsets=settings.get("offsets", True),
            coefficient_bounds=solved,
            **start,
        )
    else:
        problem = DirectProblem(model, specimen, state, excitation, **start)
    box = {k: tuple(v) for k, v in bounds.items() if k in problem.param_names}
    refuse_past_limits(model, problem.state, problem.param_names, problem.lower, problem.upper, box)
    problem.lower, problem.upper = bounds_mod.apply(problem.lower, problem.upper, problem.param_names, box)
    return problem


def solved_bounds(model, state, bounds: dict) -> dict:
    """The entries of ``bounds`` that name a solved coefficient of the model's identifiable formulation."""
    from bwbench.problems.hysteresis.linear.columns import coefficient_names

    names = coefficient_names(model.linear_layout(state)) if model.has_linear_part else ()
    return {k: tuple(v) for k, v in bounds.items() if k in names}


def _joint_problem(specimens, settings: dict):
    from bwbench.problems.hysteresis.joint_problem import JointProblem

    one = {k: v for k, v in settings.items() if k != "bounds"}  # the box is set once, on the envelope
    parts = [make_problem(s, one) for s in specimens]
    model, state = parts[0].model, parts[0].state
    bounds = settings.get("bounds", {})
    problem = JointProblem(
        parts,
        settings.get("weighting", "equal"),
        fix_mass=settings.get("fix_mass", "auto"),
        offsets=settings.get("offsets", True),
        coefficient_bounds=solved_bounds(model, state, bounds),
    )
    box = {k: tuple(v) for k, v in bounds.items() if k in problem.param_names}
    refuse_past_limits(model, problem.state, problem.param_names, problem.lower, problem.upper, box)
    problem.lower, problem.upper = bounds_mod.apply(problem.lower, problem.upper, problem.param_names, box)
    return problem


def bound_names(formulations, state, models=(registry.DEFAULT,), paths=None) -> tuple:
    """The parameter names a bounds file may set for these models and formulations (None: those of
    the data at ``paths``, ``variants``): the searched parameters (the search box) and, in the
    identifiable formulation, the solved coefficients (bounds of the linear solve)."""
    from bwbench.problems.hysteresis.linear.columns import coefficient_names

    names = []
    for _, name, formulation in variants(models, formulations, paths):
        model = registry.get(name)
        own_state = state if model.states else None
        if formulation == "identifiable":
            parameters = [p.name for p in model.hysteretic_parameters(own_state)]
            parameters += list(coefficient_names(model.linear_layout(own_state)))
        else:
            parameters = [p.name for p in model.direct_parameters(own_state)]
        names += [p for p in parameters if p not in names]
    return tuple(names)


def parse(fail, value) -> tuple:
    """A formulation or a list of them, each checked against ``FORMULATIONS``."""
    return _names(fail, "formulation", value, FORMULATIONS)


def parse_models(fail, value) -> tuple:
    """A model or a list of them, each a registered model (``bwbench models``)."""
    from bwbench.errors import UserError

    names = _names(fail, "model", value, None)
    for name in names:
        try:
            registry.get(name)
        except UserError as err:
            fail(str(err))
    return names


def check_pairs(fail, models, formulations) -> list:
    """``variants`` with a model that lacks a formulation refused through ``fail``."""
    from bwbench.errors import UserError

    try:
        return variants(models, formulations)
    except UserError as err:
        fail(str(err))
        raise  # not reached: ``fail`` raises


def _names(fail, key, value, choices) -> tuple:
    values = [value] if isinstance(value, str) else value
    if not isinstance(values, list) or not values or not all(isinstance(v, str) for v in values):
        allowed = f"one of {', '.join(map(repr, choices))}" if choices else "a name"
        fail(f"{key} must be {allowed} or a list of them, got {value!r}")
    if choices:
        for v in values:
            choice(fail, key, v, choices)
    if len(set(values)) != len(values):
        fail(f"{key} lists a {key} twice")
    return tuple(values)
