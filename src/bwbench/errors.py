"""Errors a user can cause and fix; the CLI turns them into one line and exit status 2."""

from __future__ import annotations


class UserError(Exception):
    """A mistake in the user's input: printed as one line, never as a traceback."""


class InputFileError(UserError, ValueError):
    """A malformed input file. ``str()`` is ``FILE:LINE: what is wrong``."""

    def __init__(self, path, line: int | None, problem: str):
        self.path = str(path)
        self.line = line
        self.problem = problem
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {problem}")


class BudgetExhausted(Exception):
    """Raised by an objective asked for an evaluation beyond its budget."""
