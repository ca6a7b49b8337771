"""Problems as plug-ins: a ``ProblemType`` under the name a study TOML gives.

The built-in ones are modules with a ``PROBLEM_TYPE``, imported only when asked for (``get``), so a
command that needs one problem does not pay for the other's imports (and they need not import this
registry). Other packages plug in theirs through the entry-point group ``bwbench.problems``: the
entry point's name is the problem's name and its value a ``ProblemType`` instance or a module with a
``PROBLEM_TYPE``, e.g. in the package's ``pyproject.toml``::

    [project.entry-points."bwbench.problems"]
    toy-decay = "bwbench_toy_problem:PROBLEM_TYPE"

The installed plug-ins load together, once; a broken one breaks only itself (``bwbench.plugins``). An
installed plug-in reaches every process of a study (spawned workers, Dask workers) because each
loads it from the installed package's metadata. ``register`` adds one from code (a test, a
notebook): that one exists only in the process that registered it, so a study using it runs in that
process only (``only_in_this_process`` tells; the study runner refuses it with more workers).
"""

from __future__ import annotations

from types import ModuleType

import bwbench.plugins as plugins
from bwbench.problems.base import Problem, ProblemSetup, ProblemType, SpecimenEntry

__all__ = [
    "Problem",
    "ProblemSetup",
    "ProblemType",
    "SpecimenEntry",
    "DEFAULT",
    "ENTRY_POINT_GROUP",
    "get",
    "names",
    "only_in_this_process",
    "register",
]

ENTRY_POINT_GROUP = "bwbench.problems"
DEFAULT = "hysteresis"
_BUILTIN = {
    "hysteresis": "bwbench.problems.hysteresis.study",
    "bouc-wen-benchmark": "bwbench.problems.noel_schoukens.study",
}


def register(problem_type: ProblemType) -> ProblemType:
    """Register ``problem_type`` under its ``name``; a different one of the same name is refused."""
    if not isinstance(problem_type, ProblemType):
        raise TypeError(f"a problem plug-in must be a bwbench.problems.ProblemType instance, got {problem_type!r}")
    return REGISTRY.add(problem_type.name, problem_type, same=lambda a, b: type(a) is type(b))


def _read(ep, loaded) -> str:
    """The entry point's problem type registered (its name), or ``PluginError`` naming the entry point."""
    problem_type = loaded.PROBLEM_TYPE if isinstance(loaded, ModuleType) else loaded
    if not isinstance(problem_type, ProblemType):
        raise plugins.failed(
            ep,
            "problem",
            f"gives {problem_type!r}, not a bwbench.problems.ProblemType instance (or a module with a PROBLEM_TYPE)",
        )
    if problem_type.name != ep.name:
        raise plugins.failed(
            ep, "problem", f"gives a problem named {problem_type.name!r}: the entry point's name must be the problem's"
        )
    return register(problem_type).name


REGISTRY: plugins.Registry[ProblemType] = plugins.Registry(
    "problem", ENTRY_POINT_GROUP, _BUILTIN, attribute="PROBLEM_TYPE", read=_read
)


def names() -> list[str]:
    """Built-in problems first, in their order, then the installed and registered ones by name, without
    loading any plug-in (a broken one is named with its error when a study asks for it: ``get``)."""
    with REGISTRY.lock:
        registered = set(REGISTRY.items)
    return [*_BUILTIN, *sorted((registered | REGISTRY.installed()) - set(_BUILTIN))]


def only_in_this_process(name: str) -> bool:
    """True for a problem ``register``-ed in this process that is neither built in nor an installed
    plug-in: a fresh process (a spawned worker, a Dask worker) would not find it."""
    return REGISTRY.only_in_this_process(name)


# Names problem types had before: stored databases and TOML files that use them still read.
FORMER_NAMES = {"switched-bouc-wen": "hysteresis"}


def current_name(name: str) -> str:
    """``name``, or the name a problem type has now when ``name`` is one it had before."""
    return FORMER_NAMES.get(name, name)


def get(name: str) -> ProblemType:
    """The problem type registered as ``name`` (or under a former name, ``FORMER_NAMES``): a built-in
    one by importing its module, a plug-in by loading the installed plug-ins. ``UserError`` naming the
    known ones if there is none, or naming the plug-in if it fails to load."""
    return REGISTRY.lookup(current_name(name), names)
