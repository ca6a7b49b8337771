"""The switched model's formulations: which problem object a study, a fit or an analysis builds.

``paper``: the 14 parameters of the paper in the Table 5 box (``problem.SwitchedBoucWenProblem``);
``identifiable``: symmetry-free hysteretic parameters in a box scaled from the data, linear
coefficients solved (``identifiable_problem.IdentifiableProblem``).
"""

from __future__ import annotations

from bwbench.data import bounds as bounds_mod
from bwbench.models import switched_bouc_wen as model
from bwbench.problems.base import choice

FORMULATIONS = ("paper", "identifiable")


def make_problem(specimen, settings: dict):
    """The problem of one specimen for settings with model (default: the switched model), state,
    excitation and optionally formulation (default: the model's own), fix_mass and bounds (names
    the formulation does not have are left to the other one)."""
    from bwbench.models import registry
    from bwbench.problems.model_problem import DirectProblem, IdentifiableProblem

    model = registry.get(settings.get("model", registry.DEFAULT))
    formulation = settings.get("formulation", model.default_formulation)
    state = settings.get("state") if model.states else None
    excitation = settings.get("excitation", "measured")
    if formulation not in model.formulations:
        raise ValueError(f"model {model.name!r} has no formulation {formulation!r}; it has {model.formulations}")
    if formulation == "identifiable":
        problem = IdentifiableProblem(model, specimen, state, excitation, fix_mass=settings.get("fix_mass", "auto"))
    else:
        problem = DirectProblem(model, specimen, state, excitation)
    box = {k: tuple(v) for k, v in settings.get("bounds", {}).items() if k in problem.param_names}
    problem.lower, problem.upper = bounds_mod.apply(problem.lower, problem.upper, problem.param_names, box)
    return problem


def bound_names(formulations, state: str) -> tuple:
    """The parameter names a search box may set for these formulations."""
    from bwbench.models.switched_identifiable import hysteretic_names

    names = list(model.PARAM_NAMES) if "paper" in formulations else []
    if "identifiable" in formulations:
        names += [n for n in hysteretic_names(state) if n not in names]
    return tuple(names)


def parse(fail, value) -> tuple:
    values = [value] if isinstance(value, str) else value
    if not isinstance(values, list) or not values or not all(isinstance(v, str) for v in values):
        fail(f"formulation must be one of {', '.join(map(repr, FORMULATIONS))} or a list of them, got {value!r}")
    for v in values:
        choice(fail, "formulation", v, FORMULATIONS)
    if len(set(values)) != len(values):
        fail("formulation lists a formulation twice")
    return tuple(values)


