"""What ``bwbench fit`` prints beside a fit's loss, for Python: the notes of the linear solve and of the
fit's checks, and the warnings (a parameter on an edge of its box, a model that generates energy).

``bwbench.fit`` issues each through Python's ``warnings`` with the category ``FitWarning``, so a
notebook shows them under the cell and a script can filter them::

    import warnings, bwbench
    warnings.simplefilter("ignore", bwbench.FitWarning)     # or "error" to stop at the first
"""

from __future__ import annotations

import warnings


class FitWarning(UserWarning):
    """A note or warning about a fit (``FitResult.notes``): what the data do not determine, a parameter
    on the edge of its search box, a loop that generates energy."""


# The energy a model dissipates, a passed energy check and the state a record starts from are facts for
# the report, not something to be warned about.
_QUIET = ("energy dissipated per cycle", "initial state:", "energy check passed")


def notes(fit) -> list[str]:
    """Every note and warning the command line prints for ``fit`` (a ``FitResult``), one line each."""
    from bwbench.optimize.fitting import edge_warnings

    checks = fit.checks
    out = [f"linear solve: {n}" for n in getattr(fit.problem, "notes", [])]
    out += list(checks.notes) if checks else []
    if fit.success:
        out += edge_warnings(fit.problem, fit.result, checks.explained if checks else ())
    out += list(checks.warnings) if checks else []
    return out


def issue(fit, stacklevel: int = 3) -> None:
    """Each of ``notes(fit)`` but the report-only ones as a ``FitWarning`` (``stacklevel``: the caller's
    caller, the user's line)."""
    for text in notes(fit):
        if not any(quiet in text for quiet in _QUIET):  # a joint fit's notes start with the file's name
            warnings.warn(text, FitWarning, stacklevel=stacklevel)
