"""Everything a fit says beside its numbers, as one list (``fit_findings``).

``bwbench fit`` prints it, ``bwbench.fit`` issues each item as a ``FitWarning`` of its severity's
class and keeps the list on the result (``FitResult.findings``), ``FitResult.report()`` lists it.
Nothing is said in one place and not in the others.

Severities, mildest first:

- ``info``: a fact for the record (the formulation chosen and why, the initial state, the energy the
  model dissipates, a passed check): printed and reported, not issued as a warning;
- ``note``: what the fit did or the data do not determine (the linear solve, an early stop);
- ``finding``: what the fit says about the model or the data (a failed check, a physical limit);
- ``warning``: something to act on (a parameter on its box's edge, a file that looks mis-scaled);
- ``failure``: the fit failed — no finite loss, or a fit further from the data than the best
  constant force. ``FitResult.ok`` is False and ``bwbench fit`` exits 1.

A script filters them by class::

    import warnings, bwbench
    warnings.simplefilter("ignore", bwbench.FitWarning)       # all of them
    warnings.simplefilter("error", bwbench.FitFailure)        # stop at a failed fit
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

SEVERITIES = ("info", "note", "finding", "warning", "failure")


class FitWarning(UserWarning):
    """Something a fit says about itself or its data (``FitResult.findings``).

    The base class of one class per severity: ``FitNote``, ``FitFinding``, ``FitBoxWarning``,
    ``FitFailure`` (the "info" facts are not issued).

    Examples
    --------
    >>> import warnings
    >>> warnings.simplefilter("ignore", bwbench.FitWarning)   # all of them
    """


class FitNote(FitWarning):
    """What the fit did, or what the data do not determine.

    Examples
    --------
    >>> import warnings
    >>> warnings.simplefilter("ignore", bwbench.FitNote)
    """


class FitFinding(FitWarning):
    """What the fit says about the model or the data: a failed check, a physical limit.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     fit = bwbench.fit("mytest.csv")
    >>> [w.message for w in caught if issubclass(w.category, bwbench.FitFinding)]
    """


class FitBoxWarning(FitWarning):
    """Something to act on: a parameter on its box's edge, a file that looks mis-scaled.

    Examples
    --------
    >>> import warnings
    >>> warnings.simplefilter("error", bwbench.FitBoxWarning)   # stop at a parameter on its box's edge
    """


class FitFailure(FitWarning):
    """The fit failed: no finite loss, or further from the data than the best constant force.

    Examples
    --------
    >>> import warnings
    >>> warnings.simplefilter("error", bwbench.FitFailure)   # stop at a failed fit
    """


CATEGORIES = {"note": FitNote, "finding": FitFinding, "warning": FitBoxWarning, "failure": FitFailure}


@dataclass(frozen=True)
class Finding:
    """One thing a fit says; ``str()`` of it is its text.

    Parameters
    ----------
    severity : str
        One of ``SEVERITIES``: "info", "note", "finding", "warning", "failure" (mildest first).
    text : str
        What it says, in one line.

    Examples
    --------
    >>> Finding("warning", "k on its box's upper edge").line
    "warning: k on its box's upper edge"
    """

    severity: str
    text: str

    def __str__(self) -> str:
        return self.text

    @property
    def line(self) -> str:
        """How ``bwbench fit`` prints it (without the file name a warning or failure is given).

        Returns
        -------
        str
            The text, prefixed "finding: ", "warning: " or "error: " by severity.
        """
        prefix = {"finding": "finding: ", "warning": "warning: ", "failure": "error: "}.get(self.severity, "")
        return prefix + self.text


# Checks' notes that are facts for the record, not something to be warned about.
_FACTS = ("energy dissipated per cycle", "initial state:", "energy check passed", "the residual is close to the noise")


def fit_findings(fit) -> list[Finding]:
    """Every finding of a fit, in the order ``bwbench fit`` prints them.

    Parameters
    ----------
    fit : FitResult
        The fit.

    Returns
    -------
    list of Finding

    Examples
    --------
    >>> for finding in fit_findings(bwbench.fit("mytest.csv")):
    ...     print(finding.severity, finding.text)
    """
    out: list[Finding] = []
    reason = fit.extra.get("formulation_reason")
    if reason:
        out.append(Finding("info", reason))
    failures = failure_reasons(fit)
    out += [Finding("failure", f) for f in failures]  # a failed fit says so first
    if fit.budget and fit.nfev < fit.budget:
        out.append(Finding("note", f"{fit.result.message} ({fit.nfev} of {fit.budget} evaluations)"))
    stops = fit.result.extras.get("step_budget_stops")
    if stops:
        out.append(
            Finding(
                "note",
                f"{stops} evaluations stopped at the simulation's step budget: parameter sets in stiff corners of "
                "the search box, whose simulation would have needed more integration steps than the model allows "
                "(docs/models.md); their loss counted as +inf and the search moved away from them — harmless "
                "while the fit ends inside the box",
            )
        )
    out += [Finding("note", f"linear solve: {n}") for n in getattr(fit.problem, "notes", [])]
    checks = fit.checks
    if checks is not None:
        out += [Finding("info" if any(f in n for f in _FACTS) else "note", n) for n in checks.notes]
        out += [Finding("finding", n) for n in checks.findings]
    if fit.success:
        from bwbench.engine.fitting import edge_warnings

        out += [
            Finding("warning", w) for w in edge_warnings(fit.problem, fit.result, checks.explained if checks else ())
        ]
    if checks is not None and not failures:
        # the fitted model's energy or shape says nothing of the data's sign when the fit itself failed
        out += [Finding("warning", w) for w in checks.warnings]
    out += [Finding("warning", w) for w in data_warnings(fit)]
    return out


def failure_reasons(fit) -> list[str]:
    """Why a fit failed, one sentence per reason.

    No evaluation gave a finite force, or a file whose fitted force is further from the measured one
    than the best constant force is (RMSE above the force's standard deviation, N), with the likely
    cause.

    Parameters
    ----------
    fit : FitResult
        The fit.

    Returns
    -------
    list of str
        The reasons; [] for a fit that did not fail.

    Examples
    --------
    >>> failure_reasons(bwbench.fit("mytest.csv"))
    []
    """
    if not fit.success:
        return [
            f"none of the {fit.nfev} evaluations gave a finite force: the model blows up everywhere in the "
            "search box on these data (check the units: mm, N, s; and the bounds)"
        ]
    out = []
    parts = getattr(fit.problem, "parts", None) or [fit.problem]
    for part, row in zip(parts, fit.files):
        f = np.asarray(getattr(part, "f_loss", part.specimen.f), dtype=float)  # the samples the RMSE is of
        spread = float(np.std(f))
        if row["rmse_N"] > spread:
            hint = (
                "try --formulation identifiable (its box is scaled from the data), or another --model "
                "(`bwbench models`)"
                if part.formulation != "identifiable"
                else "try another --model (`bwbench models`), a larger --budget, or check the units and sign of "
                "the force"
            )
            out.append(
                f"{part.specimen.path or part.specimen.name}: the fit is worse than a constant force (RMSE "
                f"{row['rmse_N']:.4g} N, the measured force's standard deviation {spread:.4g} N): "
                f"{part.model.name} in the {part.formulation} formulation did not fit these data; {hint}"
            )
    return out


def data_warnings(fit) -> list[str]:
    """``data check``'s warnings about the fitted files.

    Parameters
    ----------
    fit : FitResult
        The fit.

    Returns
    -------
    list of str
        A flipped or mis-scaled signal, a time column in ms, ..., each naming its file.

    Examples
    --------
    >>> data_warnings(bwbench.fit("mytest.csv"))
    """
    from bwbench.data import plausibility

    synthetic = fit.synthetic
    out = []
    for spec in fit.specimens:
        for text in plausibility.all_warnings(spec, synthetic):
            if not text.startswith("note:"):
                out.append(f"{spec.path or spec.name}: {text}")
    return out


def issue(findings, stacklevel: int = 3) -> None:
    """Issue each finding but the ``info`` ones as a warning of its severity's class.

    Parameters
    ----------
    findings : iterable of Finding
        The findings.
    stacklevel : int, default 3
        Passed to ``warnings.warn``: the caller's caller, the user's line.

    Warns
    -----
    FitWarning
        ``FitNote``, ``FitFinding``, ``FitBoxWarning`` or ``FitFailure`` by severity.

    Examples
    --------
    >>> issue([Finding("note", "linear solve: mass fitted")])
    """
    for finding in findings:
        category = CATEGORIES.get(finding.severity)
        if category is not None:
            warnings.warn(finding.text, category, stacklevel=stacklevel)
