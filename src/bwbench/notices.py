"""Warnings in the project's own words, one line each.

``assume(text)`` says what bwbench assumed about an input it accepted (a ``manifest.json`` of another
program beside the specimens, ignored). Python shows it under a notebook's cell; the command line
prints it as ``warning: ...``. The command line also turns the libraries' warnings it knows into
bwbench's words, silences those that mean nothing to a user, and prints any other as one line.
"""

from __future__ import annotations

import os
import sys
import warnings
from contextlib import contextmanager


class BwbenchWarning(UserWarning):
    """An assumption bwbench made about an input it accepted (said once per input)."""


_said: set[str] = set()


def assume(text: str) -> None:
    """Warn ``text`` (a ``BwbenchWarning``) once per process."""
    if text not in _said:
        _said.add(text)
        warnings.warn(text, BwbenchWarning, stacklevel=3)


# (category, start of the library's message) -> bwbench's words; None: it means nothing here, say nothing
KNOWN = {
    (UserWarning, "More chains"): (
        "the posterior has more chains than draws per chain: its R̂ and ESS are unreliable (give it a larger budget)"
    ),
    (RuntimeWarning, "Degrees of freedom <= 0"): None,  # a spread of one value: shown as "–" already
    (RuntimeWarning, "Mean of empty slice"): None,
    # numpy's floating-point notes: a model that blows up is a loss of +inf by design, said in the results
    (RuntimeWarning, "invalid value encountered"): None,
    (RuntimeWarning, "divide by zero encountered"): None,
    (RuntimeWarning, "overflow encountered"): None,
}
# Loggers of libraries whose messages the report already says in its own words (ArviZ's "shape
# validation failed" for a posterior too short to diagnose: the posterior section says it did not converge).
QUIET_LOGGERS = ("arviz",)


def words(message, category) -> str | None:
    """The line the command line prints for a warning, or None to print nothing."""
    text = " ".join(str(message).split())
    for (kind, start), said in KNOWN.items():
        if issubclass(category, kind) and text.startswith(start):
            return None if said is None else f"warning: {said}"
    if issubclass(category, BwbenchWarning) or category.__name__ == "FitWarning":
        return f"warning: {text}"
    return f"warning: {text} ({category.__name__} of {_library(category)})"


def _library(category) -> str:
    module = getattr(category, "__module__", "") or ""
    return module.split(".")[0] if module not in ("builtins", "") else "a library"


@contextmanager
def command_line_warnings():
    """Within the block, warnings print as ``words`` (once each), not as Python's two-line format."""
    shown: set[str] = set()
    previous = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        text = words(message, category)
        if text is None or text in shown:
            return
        shown.add(text)
        try:
            print(text, file=file or sys.stderr)
        except (OSError, ValueError):  # a closed terminal: nothing to say it on
            pass

    import logging

    loggers = [logging.getLogger(name) for name in QUIET_LOGGERS]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL)
    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = previous
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)


def writable_matplotlib_folder() -> None:
    """Point matplotlib at a temporary folder when its own (under HOME, or MPLCONFIGDIR) cannot be
    written (a read-only HOME, a container): it would do the same after a five-line message that asks
    the user to set a variable; bwbench's figures need no configuration kept between runs."""
    import tempfile

    configured = os.environ.get("MPLCONFIGDIR")
    home = os.path.expanduser("~")
    folders = (
        [configured]
        if configured
        else [
            os.environ.get("XDG_CONFIG_HOME") or os.path.join(home, ".config"),
            os.environ.get("XDG_CACHE_HOME") or os.path.join(home, ".cache"),
        ]
    )
    for folder in folders:
        probe = folder
        while probe and not os.path.exists(probe):  # the nearest folder that exists decides
            probe = os.path.dirname(probe.rstrip(os.sep)) if probe != os.sep else ""
        if not probe or not (os.path.isdir(probe) and os.access(probe, os.W_OK | os.X_OK)):
            os.environ["MPLCONFIGDIR"] = tempfile.mkdtemp(prefix="bwbench-matplotlib-")
            return
