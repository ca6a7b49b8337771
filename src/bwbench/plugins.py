"""The one registry class and failure policy of bwbench's three plug-in registries: optimiser backends
(``bwbench.engine.registry``), problems (``bwbench.problems``) and models (``bwbench.models.registry``).

An installed plug-in that fails to load (a missing module, an exception at import, a value of the
wrong type) breaks only itself: its registry keeps the others working, and whoever asks for it by
name gets one line naming the plug-in, its entry point and the error (docs/plugins.md), e.g.
``model plug-in 'x' (entry point 'pkg:MODEL' of group 'bwbench.models') failed to load:
ModuleNotFoundError: No module named 'pkg'``.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import os
import sys
import threading
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Callable, Generic, NamedTuple, TypeVar

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
        """Load every installed plug-in of the group once; a broken one is recorded, never raised. The
        modules loaded from files (``load_files``) that hold this registry's ``attribute`` are read too."""
        with self.lock:
            self._read_files()
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

    def _read_files(self) -> None:
        """Register what the plug-in files loaded so far (``file_modules``) give this registry, once each."""
        modules = file_modules()  # a backend's file registers itself as it is imported
        if self.read is None or self.attribute is None:
            return
        seen = self.__dict__.setdefault("files_read", set())
        for path, module in modules.items():
            if path in seen or not hasattr(module, self.attribute):
                continue
            seen.add(path)
            ep = _FileEntry(Path(path).stem, path, self.group)
            try:
                self.from_entry_points.add(self.read(ep, module))
            except Exception as err:  # refused by register(): the file's fault, named
                raise UserError(f"plug-in file {path}: {type(err).__name__}: {err}") from None

    def only_in_this_process(self, name: str) -> bool:
        """True for a thing ``register``-ed in this process that is neither built in nor an installed
        plug-in: a fresh process (a spawned worker, a Dask worker) would not find it."""
        self.load_plugins()
        with self.lock:
            return name in self.items and name not in self.builtin and name not in self.from_entry_points


# Plug-ins from files: ``--plugin path/to/model.py`` (or a study TOML's ``plugins = [...]``) imports a
# module that defines a ``MODEL`` or a ``PROBLEM_TYPE``, or registers a backend with
# ``bwbench.engine.registry.register``, without installing it. The paths travel to spawned workers in
# this environment variable (they inherit it), so a study's workers load the same files.
FILES_VARIABLE = "BWBENCH_PLUGIN_FILES"
_FILE_MODULES: dict[str, Any] = {}
_FILES_LOCK = threading.RLock()


class _FileEntry(NamedTuple):
    """What a registry's ``read`` needs of an entry point, for a module loaded from a file."""

    name: str
    value: str
    group: str


def load_files(paths, where: str = "--plugin") -> list[str]:
    """Import each plug-in file of ``paths`` once (absolute paths; ``where`` names the option or key in a
    mistake) and declare them to this process's future workers; ``UserError`` naming the file for one
    that is missing or fails to import. Returns the absolute paths."""
    out = []
    for given in paths or ():
        path = Path(given).expanduser()
        if path.suffix != ".py" or not path.is_file():
            raise UserError(f"{where} {given}: not a Python file (give the path of the plug-in's .py module)")
        out.append(str(path.resolve()))
    with _FILES_LOCK:
        for name in out:
            _import_file(name, where)
        declared = [p for p in os.environ.get(FILES_VARIABLE, "").split(os.pathsep) if p]
        os.environ[FILES_VARIABLE] = os.pathsep.join(dict.fromkeys(declared + out))
    return out


def file_modules() -> dict[str, Any]:
    """{path: module} of the plug-in files loaded in this process, the environment's (``FILES_VARIABLE``,
    a spawned worker's inheritance) imported first."""
    with _FILES_LOCK:
        for path in os.environ.get(FILES_VARIABLE, "").split(os.pathsep):
            if path and path not in _FILE_MODULES:
                _import_file(path, FILES_VARIABLE)
        return dict(_FILE_MODULES)


def _import_file(path: str, where: str) -> None:
    if path in _FILE_MODULES:
        return
    name = f"bwbench_plugin_{Path(path).stem}_{hashlib.sha256(path.encode()).hexdigest()[:8]}"
    try:
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise ImportError("not an importable module")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # dataclasses and pickling look modules up by name
        _FILE_MODULES[path] = module  # before executing it: a registry it imports must not load it again
        spec.loader.exec_module(module)
    except Exception as err:  # the plug-in's own fault, whatever it is: named, never a traceback
        _FILE_MODULES.pop(path, None)
        sys.modules.pop(name, None)
        raise UserError(f"{where} {path}: failed to load: {type(err).__name__}: {err}") from None
