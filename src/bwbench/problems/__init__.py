"""Problems as plug-ins: a ``ProblemType`` under the name a study TOML gives.

The built-in ones are modules with a ``PROBLEM_TYPE``, imported only when asked for (``get``), so a
command that needs one problem does not pay for the other's imports (and they need not import this
registry). Other packages plug in theirs through the entry-point group ``bwbench.problems``: the
entry point's name is the problem's name and its value a ``ProblemType`` instance or a module with a
``PROBLEM_TYPE``, e.g. in the package's ``pyproject.toml``::

    [project.entry-points."bwbench.problems"]
    toy-decay = "bwbench_toy_problem:PROBLEM_TYPE"

Only the entry point of the name asked for is loaded, so a broken plug-in breaks only itself. An
installed plug-in reaches every process of a study (spawned workers, Dask workers) because each
loads it from the installed package's metadata. ``register`` adds one from code (a test, a
notebook): that one exists only in the process that registered it, so a study using it runs in that
process only (``only_in_this_process`` tells; the study runner refuses it with more workers).
"""

from __future__ import annotations

import importlib
import threading
from importlib.metadata import entry_points
from types import ModuleType

from bwbench import plugins
from bwbench.errors import UserError
from bwbench.problems.base import Problem, ProblemSetup, ProblemType, SpecimenEntry

__all__ = ["Problem", "ProblemSetup", "ProblemType", "SpecimenEntry", "DEFAULT", "ENTRY_POINT_GROUP", "get",
           "names", "only_in_this_process", "register"]

ENTRY_POINT_GROUP = "bwbench.problems"
DEFAULT = "switched-bouc-wen"
_BUILTIN = {
    "switched-bouc-wen": "bwbench.problems.switched_vpp.study",
    "bouc-wen-benchmark": "bwbench.problems.noel_schoukens.study",
}
_REGISTERED: dict[str, ProblemType] = {}
_LOCK = threading.RLock()  # a Dask worker runs tasks in threads


def register(problem_type: ProblemType) -> ProblemType:
    """Register ``problem_type`` under its ``name``; a different one of the same name is refused."""
    if not isinstance(problem_type, ProblemType):
        raise TypeError(f"a problem plug-in must be a bwbench.problems.ProblemType instance, got {problem_type!r}")
    with _LOCK:
        present = _REGISTERED.get(problem_type.name)
        if present is not None and type(present) is not type(problem_type):
            raise ValueError(f"a problem named {problem_type.name!r} is already registered")
        return _REGISTERED.setdefault(problem_type.name, problem_type)


def _entry_points() -> dict:
    """The installed plug-ins' entry points by name (the first of a name wins, as importlib lists them)."""
    found: dict = {}
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        found.setdefault(ep.name, ep)
    return found


def names() -> list[str]:
    """Built-in problems first, in their order, then the plugged-in and registered ones by name."""
    with _LOCK:
        registered = set(_REGISTERED)
    return [*_BUILTIN, *sorted((registered | set(_entry_points())) - set(_BUILTIN))]


def only_in_this_process(name: str) -> bool:
    """True for a problem ``register``-ed in this process that is neither built in nor an installed
    plug-in: a fresh process (a spawned worker, a Dask worker) would not find it."""
    with _LOCK:
        registered = name in _REGISTERED
    return registered and name not in _BUILTIN and name not in _entry_points()


def get(name: str) -> ProblemType:
    """The problem type registered as ``name``: a built-in one by importing its module, a plug-in by
    loading its entry point. ``UserError`` naming the known ones if there is none, or naming the
    plug-in if it fails to load."""
    with _LOCK:
        if name in _REGISTERED:
            return _REGISTERED[name]
        if name in _BUILTIN:
            return register(importlib.import_module(_BUILTIN[name]).PROBLEM_TYPE)
        ep = _entry_points().get(name)
        if ep is None:
            raise UserError(f"unknown problem {name!r}; known: {', '.join(names())}")
        return register(_load(ep))


def _load(ep) -> ProblemType:
    """The entry point's problem type, or ``PluginError`` naming it (the policy of ``bwbench.plugins``)."""
    loaded = plugins.load(ep, "problem")
    problem_type = loaded.PROBLEM_TYPE if isinstance(loaded, ModuleType) else loaded
    if not isinstance(problem_type, ProblemType):
        raise plugins.failed(ep, "problem", f"gives {problem_type!r}, not a bwbench.problems.ProblemType instance "
                             "(or a module with a PROBLEM_TYPE)")
    if problem_type.name != ep.name:
        raise plugins.failed(ep, "problem", f"gives a problem named {problem_type.name!r}: the entry point's name "
                             "must be the problem's")
    return problem_type
