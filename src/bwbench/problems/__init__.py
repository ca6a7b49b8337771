"""Problems as plug-ins: a ``ProblemType`` under the name a study TOML gives.

The built-in ones are modules with a ``PROBLEM_TYPE``, imported only when asked for (``get``), so a
command that needs one problem does not pay for the other's imports (and they need not import this
registry). Another module (a test, a package) adds its own with ``register``.
"""

from __future__ import annotations

import importlib
import threading

from bwbench.errors import UserError
from bwbench.problems.base import Problem, ProblemSetup, ProblemType, SpecimenEntry

__all__ = ["Problem", "ProblemSetup", "ProblemType", "SpecimenEntry", "DEFAULT", "get", "names", "register"]

DEFAULT = "switched-bouc-wen"
_BUILTIN = {
    "switched-bouc-wen": "bwbench.problems.switched_vpp.study",
    "bouc-wen-benchmark": "bwbench.problems.noel_schoukens.study",
}
_REGISTERED: dict[str, ProblemType] = {}
_LOCK = threading.Lock()  # a Dask worker runs tasks in threads


def register(problem_type: ProblemType) -> ProblemType:
    """Register ``problem_type`` under its ``name``; a different one of the same name is refused."""
    with _LOCK:
        present = _REGISTERED.get(problem_type.name)
        if present is not None and type(present) is not type(problem_type):
            raise ValueError(f"a problem named {problem_type.name!r} is already registered")
        return _REGISTERED.setdefault(problem_type.name, problem_type)


def names() -> list[str]:
    """Built-in problems first, in their order, then the others by name."""
    return [*_BUILTIN, *sorted(set(_REGISTERED) - set(_BUILTIN))]


def get(name: str) -> ProblemType:
    """The problem type registered as ``name``; ``UserError`` naming the known ones otherwise."""
    with _LOCK:
        found = _REGISTERED.get(name)
    if found is not None:
        return found
    if name not in _BUILTIN:
        raise UserError(f"unknown problem {name!r}; known: {', '.join(names())}")
    return register(importlib.import_module(_BUILTIN[name]).PROBLEM_TYPE)
