"""The registry of optimiser backends.

A backend is one function ``minimize(objective, *, rng, **options) -> dict | None`` registered
by name with the ``register`` decorator. It calls ``objective(u)`` or ``objective.batch(U)`` in
unit coordinates until it is done or the objective raises ``BudgetExhausted``; the bookkeeping
(best point, trace, counts, timing) lives in the objective and in ``bwbench.optimize.fitting``, so a
backend knows nothing of Bouc-Wen and nothing of budgets. It may return a dict of extras
(e.g. an MCMC chain) to keep with the result; the key ``message`` becomes the result's message.

Built-in backends live in ``bwbench.optimizers``; other packages plug in their own through the
entry-point group ``bwbench.optimizers`` (each entry point names a module to import, whose
``register`` calls add its backends).
"""

from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from importlib.metadata import entry_points
from typing import Callable

ENTRY_POINT_GROUP = "bwbench.optimizers"


@dataclass(frozen=True)
class Backend:
    name: str
    family: str
    description: str
    minimize: Callable
    defaults: dict = field(default_factory=dict)
    # Draws many points per call to objective.batch (population/ensemble methods).
    batched: bool = True


_REGISTRY: dict[str, Backend] = {}
_loaded = False


def register(name: str, *, family: str, description: str, defaults: dict | None = None, batched: bool = True):
    """Decorator: register ``minimize`` under ``name``; a second backend of the same name is refused."""

    def decorate(minimize: Callable) -> Callable:
        if name in _REGISTRY and _REGISTRY[name].minimize is not minimize:
            raise ValueError(f"an optimiser named {name!r} is already registered")
        _REGISTRY[name] = Backend(name, family, description, minimize, dict(defaults or {}), batched)
        return minimize

    return decorate


def _load() -> None:
    global _loaded
    if _loaded:
        return
    _loaded = True
    import bwbench.optimizers as builtin

    for module in pkgutil.iter_modules(builtin.__path__):
        importlib.import_module(f"{builtin.__name__}.{module.name}")
    for ep in entry_points(group=ENTRY_POINT_GROUP):
        ep.load()


def available() -> dict[str, Backend]:
    """Every registered backend, built-in and plugged in, by name (sorted)."""
    _load()
    return dict(sorted(_REGISTRY.items()))


def get(name: str) -> Backend:
    backends = available()
    if name not in backends:
        from bwbench.errors import UserError

        raise UserError(f"unknown optimiser {name!r}; available: {', '.join(backends)}")
    return backends[name]
