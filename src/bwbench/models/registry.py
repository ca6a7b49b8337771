"""Models as plug-ins: a ``Model`` under its name, as backends are registered (``bwbench models``).

The built-in models are modules with a ``MODEL``, imported only when asked for, so a fit of one
model does not pay for another's compilation. Other packages plug in theirs through the entry-point
group ``bwbench.models``: each entry point names a ``Model`` instance (or a module with a ``MODEL``);
``register`` adds one from code (a test, a notebook). A different model of an existing name is
refused. Entry points reach spawned workers and Dask workers because they load from the installed
package metadata, not from the parent process's memory.
"""

from __future__ import annotations

from types import ModuleType

import bwbench.plugins as plugins
from bwbench.models.base import Model

ENTRY_POINT_GROUP = "bwbench.models"
DEFAULT = "switched-bouc-wen"
BUILTIN = {
    "switched-bouc-wen": "bwbench.models.switched.model",
    "bouc-wen": "bwbench.models.classic_bouc_wen",
    "spencer": "bwbench.models.spencer.model",
    "bwbn": "bwbench.models.bwbn.model",
}


def register(model: Model) -> Model:
    """Register ``model`` under its ``name``; a different model of the same name is refused."""
    if not isinstance(model, Model):
        raise TypeError(f"a model plug-in must be a bwbench.models.base.Model instance, got {model!r}")
    return REGISTRY.add(model.name, model, same=lambda a, b: type(a) is type(b))


def _read(ep, loaded) -> str:
    """An entry point's model (an instance, or a module with a ``MODEL``), registered; its name."""
    return register(loaded.MODEL if isinstance(loaded, ModuleType) else loaded).name


REGISTRY: plugins.Registry[Model] = plugins.Registry("model", ENTRY_POINT_GROUP, BUILTIN, attribute="MODEL", read=_read)


def broken() -> dict[str, str]:
    """The installed model plug-ins that failed to load: entry point name -> the line naming it."""
    REGISTRY.load_plugins()
    return dict(REGISTRY.broken)


def get(name: str) -> Model:
    """The model registered as ``name``; ``UserError`` naming the known ones otherwise."""
    return REGISTRY.lookup(name, names)


def only_in_this_process(name: str) -> bool:
    """True for a model ``register``-ed in this process that is neither built in nor an installed
    plug-in: a fresh process (a spawned worker, a Dask worker) would not find it."""
    return REGISTRY.only_in_this_process(name)


def names() -> list[str]:
    """Built-in models first, in their order, then the plugged-in ones by name."""
    REGISTRY.load_plugins()
    with REGISTRY.lock:
        return [*BUILTIN, *sorted(set(REGISTRY.items) - set(BUILTIN))]


def available() -> dict[str, Model]:
    """Every model, built-in and plugged in, by name (built-ins first)."""
    return {name: get(name) for name in names()}
