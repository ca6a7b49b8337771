"""Models as plug-ins: a ``Model`` under its name, as backends are registered (``bwbench models``).

The built-in models are modules with a ``MODEL``, imported only when asked for, so a fit of one
model does not pay for another's compilation. Other packages plug in theirs through the entry-point
group ``bwbench.models``: each entry point names a ``Model`` instance (or a module with a ``MODEL``);
``register`` adds one from code (a test, a notebook). A different model of an existing name is
refused. Entry points reach spawned workers and Dask workers because they load from the installed
package metadata, not from the parent process's memory.
"""

from __future__ import annotations

import importlib
import threading
from importlib.metadata import entry_points
from types import ModuleType

from bwbench import plugins
from bwbench.errors import UserError
from bwbench.models.base import Model

ENTRY_POINT_GROUP = "bwbench.models"
DEFAULT = "switched-bouc-wen"
BUILTIN = {
    "switched-bouc-wen": "bwbench.models.switched",
    "bouc-wen": "bwbench.models.classic_bouc_wen",
    "spencer": "bwbench.models.spencer",
}
_REGISTERED: dict[str, Model] = {}
_LOCK = threading.RLock()  # a Dask worker runs tasks in threads
_plugins_loaded = False
_FROM_ENTRY_POINTS: set[str] = set()  # names of the models the installed plug-ins gave
_BROKEN: dict[str, str] = {}  # entry point name -> why it failed to load


def register(model: Model) -> Model:
    """Register ``model`` under its ``name``; a different model of the same name is refused."""
    if not isinstance(model, Model):
        raise TypeError(f"a model plug-in must be a bwbench.models.base.Model instance, got {model!r}")
    with _LOCK:
        present = _REGISTERED.get(model.name)
        if present is not None and type(present) is not type(model):
            raise ValueError(f"a model named {model.name!r} is already registered")
        return _REGISTERED.setdefault(model.name, model)


def _as_model(loaded) -> Model:
    return loaded.MODEL if isinstance(loaded, ModuleType) else loaded


def _load_plugins() -> None:
    global _plugins_loaded
    with _LOCK:
        if _plugins_loaded:
            return
        for ep in entry_points(group=ENTRY_POINT_GROUP):
            # A broken plug-in (a missing module, a wrong value) must not take every model down with it.
            try:
                model = _as_model(plugins.load(ep, "model"))
                _FROM_ENTRY_POINTS.add(register(model).name)
            except plugins.PluginError as err:
                _BROKEN[ep.name] = str(err)
            except Exception as err:  # register() refused the value: still the plug-in's fault, named
                _BROKEN[ep.name] = str(plugins.failed(ep, "model", f"failed to load: {type(err).__name__}: {err}"))
        _plugins_loaded = True


def broken() -> dict[str, str]:
    """The installed model plug-ins that failed to load: entry point name -> the line naming it."""
    _load_plugins()
    with _LOCK:
        return dict(_BROKEN)


def get(name: str) -> Model:
    """The model registered as ``name``; ``UserError`` naming the known ones otherwise."""
    with _LOCK:
        if name in _REGISTERED:
            return _REGISTERED[name]
        if name in BUILTIN:
            return register(importlib.import_module(BUILTIN[name]).MODEL)
    _load_plugins()
    with _LOCK:
        if name in _REGISTERED:
            return _REGISTERED[name]
    if name in broken():
        raise plugins.PluginError(broken()[name])
    failed = "".join(f"; {line}" for line in broken().values())
    raise UserError(f"unknown model {name!r}; known: {', '.join(names())}{failed}")


def only_in_this_process(name: str) -> bool:
    """True for a model ``register``-ed in this process that is neither built in nor an installed
    plug-in: a fresh process (a spawned worker, a Dask worker) would not find it."""
    _load_plugins()
    with _LOCK:
        return name in _REGISTERED and name not in BUILTIN and name not in _FROM_ENTRY_POINTS


def names() -> list[str]:
    """Built-in models first, in their order, then the plugged-in ones by name."""
    _load_plugins()
    with _LOCK:
        return [*BUILTIN, *sorted(set(_REGISTERED) - set(BUILTIN))]


def available() -> dict[str, Model]:
    """Every model, built-in and plugged in, by name (built-ins first)."""
    return {name: get(name) for name in names()}
