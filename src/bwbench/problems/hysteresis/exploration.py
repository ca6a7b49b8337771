"""A cheaper copy of a fit's problem for its exploring local searches (``lsq-trf`` with the fit's early
stop): the same data, box and linear solve, the model simulated at a looser integration tolerance
(``model.exploring()``, e.g. ``Spencer.exploring``). The searches find and agree on the optimum there;
the best end is then polished on the problem itself, so the reported fit is the model's own numbers."""

from __future__ import annotations

import copy


def exploration(problem):
    """A copy of ``problem`` (one file or joint) whose model is ``problem.model.exploring()``; None
    when the model has no cheaper simulation."""
    exploring = getattr(problem.model, "exploring", None)
    if not callable(exploring):
        return None
    cheaper = copy.copy(problem)
    cheaper.model = exploring()
    if hasattr(problem, "parts"):  # a joint problem: its files' problems simulate too (direct formulation)
        cheaper.parts = [exploration(part) for part in problem.parts]
    return cheaper


def exploration_note(problem) -> str:
    """What the exploring copy changes, in words ("" when there is none)."""
    return str(getattr(problem.model, "exploration_note", ""))
