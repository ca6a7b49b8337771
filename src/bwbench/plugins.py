"""The one failure policy of bwbench's three plug-in registries: optimiser backends
(``bwbench.optimize.registry``), problems (``bwbench.problems``) and models (``bwbench.models.registry``).

An installed plug-in that fails to load (a missing module, an exception at import, a value of the
wrong type) breaks only itself: its registry keeps the others working, and whoever asks for it by
name gets one line naming the plug-in, its entry point and the error (docs/plugins.md), e.g.
``model plug-in 'x' (entry point 'pkg:MODEL' of group 'bwbench.models') failed to load:
ModuleNotFoundError: No module named 'pkg'``.
"""

from __future__ import annotations

from bwbench.errors import UserError


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
