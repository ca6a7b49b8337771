"""Failed runs: which failures are results (recorded, not retried) and which are not, and the summary.

Every run is fully seeded (``bwbench.study.tasks.task_seed``): the same task computes the same
numbers on any machine and any retry. So an exception raised by the backend or the problem code
(``ValueError``, ``ArithmeticError``, ``RuntimeError``, a library's own error, ...) recurs on every
retry: it is *deterministic*, a result of that configuration, recorded with status "error" and not
retried. A fault of the environment is *transient*: ``OSError`` (a file not there yet, a
permission, a network or a disk problem), ``MemoryError`` (a machine busy with other work),
``ImportError`` (a cluster worker missing a package), a dead worker, a lost cluster. Such a run is
not a result: it is not recorded and the next call runs it again. Rows recorded as errors by
versions that did not tell the two apart are classified by the error's type name (the text before
the first colon) and retried when transient.
"""

from __future__ import annotations

from collections import defaultdict

from bwbench.database.reader import TRANSIENT

SHOWN_KEYS = 6  # keys listed per distinct error; the rest are counted
SHOWN_TEXT = 160  # characters of an error's text shown in the summary


def is_transient(err: BaseException) -> bool:
    """True for a fault of the environment (retry the run), False for the run's own result."""
    return isinstance(err, TRANSIENT)


def one_line(err: BaseException) -> str:
    """``"TypeName: message"`` on one line (whitespace, newlines included, collapsed)."""
    return " ".join(f"{type(err).__name__}: {err}".split()) or type(err).__name__


def key_text(key) -> str:
    """A run's key as the user knows it: ``(specimen, backend, seed N)``, posterior runs marked."""
    kind, specimen, optimizer, replicate = key
    return f"{'posterior ' if kind == 'posterior' else ''}({specimen}, {optimizer}, seed {replicate})"


def summarize(recorded, transient) -> list[str]:
    """Lines for the failed runs of a study: ``recorded`` [(key, error)] are the deterministic errors in
    the database (not retried), ``transient`` [(key, why)] the runs this call could not finish
    (retried on the next call). One line per distinct error, most frequent first; [] if none."""
    if not recorded and not transient:
        return []
    n = len(recorded) + len(transient)
    lines = [f"error: {n} run{'s' if n != 1 else ''} failed:"]
    for failures, what in (
        (recorded, "recorded as an error, not retried (it would fail the same way)"),
        (transient, "not recorded (a fault of the environment; run the same command again to retry)"),
    ):
        groups = defaultdict(list)
        for key, error in failures:
            groups[_first_line(error)].append(key)
        for text, keys in sorted(groups.items(), key=lambda item: (-len(item[1]), item[0])):
            shown = ", ".join(key_text(k) for k in sorted(keys)[:SHOWN_KEYS])
            more = f" and {len(keys) - SHOWN_KEYS} more" if len(keys) > SHOWN_KEYS else ""
            runs = f"{len(keys)} run{'s' if len(keys) != 1 else ''}"
            lines.append(f'  {runs}: "{text}", {what}: {shown}{more}')
    return lines


def _first_line(error: str | None) -> str:
    # Stored errors are one line (newlines collapsed): show its start, enough to tell errors apart.
    text = error.splitlines()[0] if error else "unknown error"
    if text.startswith("OptionError: "):  # a backend's own check of its options against the problem
        text = "its options do not suit this problem: " + text.removeprefix("OptionError: ")
    return text if len(text) <= SHOWN_TEXT else text[: SHOWN_TEXT - 3] + "..."
