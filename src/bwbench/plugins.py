"""The one registry class and failure policy of bwbench's three plug-in registries: optimiser backends
(``bwbench.engine.registry``), problems (``bwbench.problems``) and models (``bwbench.models.registry``).

An installed plug-in that fails to load (a missing module, an exception at import, a value of the
wrong type) breaks only itself: its registry keeps the others working, and whoever asks for it by
name gets one line naming the plug-in, its entry point and the error (docs/plugins.md), e.g.
``model plug-in 'x' (entry point 'pkg:MODEL' of group 'bwbench.models') failed to load:
ModuleNotFoundError: No module named 'pkg'``.
"""

from __future__ import annotations

import importlib
import threading
from importlib.metadata import entry_points
from typing import Any, Callable, Generic, TypeVar

from bwbench.errors import UserError

T = TypeVar("T")


class PluginError(UserError):
    """A plug-in that failed to load, named with its entry point and its error (one line)."""


def describe(ep, kind: str) -> str:
    """``KIND plug-in 'NAME' (entry point 'VALUE' of group 'GROUP')``."""
    return f"{kind} plug-in {ep.name!r} (entry point {ep.value!r} of group {ep.group!r})"


def failed(ep, kind: str, why: str) -> PluginError:
    return PluginError(f"{describe(ep, kind)} {why}")


def load(ep, kind: str):
    """``ep.load()``; any exception it raises becomes a ``PluginError`` naming the plug-in and the error."""
    try:
        return ep.load()
    except Exception as err:  # the plug-in's own fault, whatever it is: named, never a traceback
        raise failed(ep, kind, f"failed to load: {type(err).__name__}: {err}") from None


class Registry(Generic[T]):
    """Named things of one kind (models, problems, optimiser backends), from three sources: built-in
    modules imported on first use (``builtin``: name -> module), installed plug-ins (the entry points
    of ``group``, loaded once, all together) and ``register`` from code (a test, a notebook).

    ``read(ep, loaded)`` registers what a loaded entry point gives and returns its name (checking it; a
    ``PluginError`` from ``failed`` refuses it), and ``attribute`` names what a built-in module holds
    (``MODEL``, ``PROBLEM_TYPE``); without them a module registers its own things when imported (the
    optimiser backends' decorator). The failure policy above is this class's: a broken plug-in is kept
    in ``broken`` and named when asked for; the others keep working."""

    def __init__(
        self,
        kind: str,
        group: str,
        builtin: dict[str, str],
        *,
        attribute: str | None = None,
        read: Callable[[Any, Any], str] | None = None,
        known: str = "known",
    ):
        self.kind = kind
        self.group = group
        self.builtin = builtin
        self.attribute = attribute
        self.read = read
        self.known = known  # the word before the list of names in "unknown ...": "known", "available"
        self.items: dict[str, T] = {}
        self.broken: dict[str, str] = {}  # entry point name -> the line naming it and its error
        self.from_entry_points: set[str] = set()  # names the installed plug-ins gave
        self.plugins_loaded = False
        self.lock = threading.RLock()  # a Dask worker runs tasks in threads: never a half-loaded registry

    def add(self, name: str, value: T, same: Callable[[T, T], bool]) -> T:
        """Register ``value`` as ``name``; a different one of the same name (``same`` says) is refused."""
        with self.lock:
            present = self.items.get(name)
            if present is not None and not same(present, value):
                raise ValueError(
                    f"a{'n' if self.kind[0] in 'aeiou' else ''} {self.kind} named {name!r} is already registered"
                )
            return self.items.setdefault(name, value)

    def installed(self) -> set[str]:
        """The names of the installed plug-ins' entry points, none loaded (a broken one included)."""
        return {ep.name for ep in entry_points(group=self.group)}

    def load_plugins(self) -> None:
        """Load every installed plug-in of the group once; a broken one is recorded, never raised."""
        with self.lock:
            if self.plugins_loaded:
                return
            for ep in entry_points(group=self.group):
                try:
                    loaded = load(ep, self.kind)
                    if self.read is not None:
                        self.from_entry_points.add(self.read(ep, loaded))
                except PluginError as err:
                    self.broken[ep.name] = str(err)
                except Exception as err:  # refused by register(): still the plug-in's fault, named
                    self.broken[ep.name] = str(failed(ep, self.kind, f"failed to load: {type(err).__name__}: {err}"))
            self.plugins_loaded = True

    def lookup(self, name: str, names: Callable[[], list[str]]) -> T:
        """The thing registered as ``name``: a built-in by importing its module only, else after loading
        the plug-ins; ``PluginError`` for a broken plug-in, ``UserError`` naming the ``names()`` otherwise."""
        with self.lock:
            if name in self.items:
                return self.items[name]
            if name in self.builtin:
                module = importlib.import_module(self.builtin[name])
                if self.attribute is not None:
                    return self.items.setdefault(name, getattr(module, self.attribute))
                if name in self.items:
                    return self.items[name]
        self.load_plugins()
        with self.lock:
            if name in self.items:
                return self.items[name]
            if name in self.broken:
                raise PluginError(self.broken[name])
        failures = "".join(f"; {line}" for line in self.broken.values())
        raise UserError(f"unknown {self.kind} {name!r}; {self.known}: {', '.join(names())}{failures}")

    def only_in_this_process(self, name: str) -> bool:
        """True for a thing ``register``-ed in this process that is neither built in nor an installed
        plug-in: a fresh process (a spawned worker, a Dask worker) would not find it."""
        self.load_plugins()
        with self.lock:
            return name in self.items and name not in self.builtin and name not in self.from_entry_points
