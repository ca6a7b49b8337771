"""Why a study stops before its end, and SIGTERM as an exception the runner can unwind from."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager


class StudyStopped(Exception):
    """The study stopped for a reason outside its runs (the database, the cluster); the runs finished
    so far are in the database. ``str()`` is the one line to show; ``status`` the exit status."""

    def __init__(self, message: str, status: int):
        super().__init__(message)
        self.status = status


class Interrupted(BaseException):
    """A termination signal (SIGTERM, SIGHUP) as an exception, like ``KeyboardInterrupt`` for SIGINT.

    A ``BaseException``: a run's ``except Exception`` must not record it as the run's error.
    """

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum

    @property
    def status(self) -> int:
        return 128 + self.signum  # what a shell reports for a process killed by that signal


# The signals received while a command ran (``signals_raise``), oldest first. A library may catch the
# exception a signal raises (a bare ``except``, C code clearing the error); the command's exit status
# still says it was stopped.
received: list[int] = []
# What a command has finished so far, for the line a stop prints (``fit --each``: the fits written).
kept: list[str] = []


@contextmanager
def signals_raise(signums=(signal.SIGTERM, signal.SIGHUP)):
    """Within the block, the first of ``signums`` raises ``Interrupted`` (``KeyboardInterrupt`` for
    SIGINT) in the main thread and is noted in ``received``; a second one has its default effect (a
    user who insists is not kept waiting by the clean-up). A signal already ignored stays ignored
    (``nohup`` ignores SIGHUP, a shell's background job SIGINT); outside the main thread, a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    handled = [s for s in signums if signal.getsignal(s) is not signal.SIG_IGN]

    def handler(signum, frame):
        received.append(signum)
        for s in handled:
            signal.signal(s, signal.SIG_DFL)
        if signum == signal.SIGINT:
            raise KeyboardInterrupt
        raise Interrupted(signum)

    previous = {s: signal.signal(s, handler) for s in handled}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)


def say(text: str, stream=None) -> None:
    """Print a line on stderr (default) if it can be: after a hangup the terminal is gone, and the line
    must not turn a clean stop into a traceback."""
    import sys

    try:
        print(text, file=stream or sys.stderr, flush=True)
    except (OSError, ValueError):  # EIO on a closed terminal, a closed stream
        pass
