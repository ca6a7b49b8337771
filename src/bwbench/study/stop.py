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


@contextmanager
def signals_raise(signums=(signal.SIGTERM, signal.SIGHUP)):
    """Within the block, the first of ``signums`` raises ``Interrupted`` (in the main thread); a second
    one has its default effect (a user who insists is not kept waiting by the clean-up). A signal
    already ignored stays ignored (``nohup`` ignores SIGHUP); outside the main thread, a no-op."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    handled = [s for s in signums if signal.getsignal(s) is not signal.SIG_IGN]

    def handler(signum, frame):
        for s in handled:
            signal.signal(s, signal.SIG_DFL)
        raise Interrupted(signum)

    previous = {s: signal.signal(s, handler) for s in handled}
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
