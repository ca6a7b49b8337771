"""The local process pool of a study: a dead worker costs only its own run, and no worker outlives it.

Each worker is a spawned process with a pipe of its own, sent one task at a time, so the pool knows
which run a worker had when it died. ``concurrent.futures.ProcessPoolExecutor`` cannot: one worker
killed (by the OOM killer, by hand) breaks it whole and fails every pending run of the call. Here the
dead worker is replaced and its run tried again; the others never notice.

A worker must not outlive a killed study either: it would block forever on its pipe and keep the
multiprocessing resource tracker alive (every spawned worker inherits the tracker's pipe, and the
tracker only exits when the last holder has closed it). So on Linux each worker asks the kernel to
SIGKILL it when the study process dies (``PR_SET_PDEATHSIG``), and so does every process a worker
forks with ``os.fork`` (``subprocess`` children are not covered: no backend starts one). When the
study stops early (an exception, Ctrl-C, SIGTERM) the workers are killed at once instead of being
waited for: a run in flight is not a result anyway, and a posterior run can take minutes.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from collections import Counter, deque
from contextlib import contextmanager
from multiprocessing.connection import wait

from bwbench.errors import UserError
from bwbench.study.tasks import run_task

_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


def die_with_parent(parent_pid: int) -> None:
    """Have the kernel SIGKILL this process when its parent dies (Linux; elsewhere a no-op).

    ``parent_pid``: the parent as the parent saw itself; if it is already gone (it died before this
    call), exit now. Also applied to every child this process forks (``os.fork``) from now on.
    """
    if not sys.platform.startswith("linux"):
        return
    import ctypes

    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
        return  # no prctl (an exotic libc): the pool still works, only without this guarantee
    if os.getppid() != parent_pid:  # the parent died before the prctl: the signal will never come
        os._exit(1)
    # The setting is cleared in a forked child: re-arm it there (a backend that forks, or a
    # multiprocessing "fork" pool inside a worker), so the chain study -> worker -> child holds.
    os.register_at_fork(after_in_child=lambda: libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0))


def _init_worker(parent_pid: int) -> None:
    die_with_parent(parent_pid)
    # Ctrl-C and a closed terminal (SIGHUP) reach the whole foreground process group: the study
    # process alone handles them (it kills the workers and keeps the finished runs), rather than every
    # worker printing its own KeyboardInterrupt traceback or dying with its run.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGHUP, signal.SIG_IGN)


# Tries of one run whose worker died under it, in one call: a SIGKILL from outside or the OOM killer
# takes one, a run that kills its worker every time (a crash in a library) is left after the second.
TRIES = 2


class WorkersCannotStart(UserError):
    """The study's worker processes die before their first run: not a run's failure but the set-up's
    (their own error is on stderr above the line this prints)."""


_READY = "ready"  # a worker's first message: it has started (imports done) and takes tasks


class _Worker:
    """One spawned worker process and the pipe to it; ``task`` is the run it has, or None;
    ``started``: the worker said it is ready (a death before that is a start-up failure)."""

    def __init__(self, context, threads: int, run):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_serve, args=(child, os.getpid(), threads, run))
        with _main_hidden():
            self.process.start()
        child.close()  # the worker holds the only other end: a dead worker reads as end-of-file
        self.task = None
        self.started = False

    def kill(self) -> None:
        try:
            self.process.kill()
            self.process.join(timeout=5)
        except (OSError, ValueError, AssertionError):  # already gone, closed, or never started
            pass
        self.conn.close()


@contextmanager
def _main_hidden():
    """Within the block, the ``__main__`` module names no file or module. A spawned process runs the
    parent's main script again (as ``__mp_main__``) before its target, unless there is none: a script
    read from standard input has no file to run ("<stdin>": every worker died), and one without an
    ``if __name__ == "__main__":`` guard would start the study again in every worker. bwbench's
    workers need nothing from it: their tasks are bwbench's, and a plug-in registered only in the
    main script is refused before any run (``refuse_plugins_only_here``)."""
    main = sys.modules.get("__main__")
    saved = {k: main.__dict__[k] for k in ("__file__", "__spec__") if main is not None and k in main.__dict__}
    for name in saved:
        setattr(main, name, None) if name == "__spec__" else delattr(main, name)
    try:
        yield
    finally:
        for name, value in saved.items():
            setattr(main, name, value)


def _serve(conn, parent_pid: int, threads: int, run) -> None:
    """A worker's loop: run each task it is sent, send back the outcome; stop at None or end-of-file."""
    from bwbench.threads import limited

    _init_worker(parent_pid)
    with limited(threads):  # imports numba: a worker numba refuses dies here, before it says it started
        conn.send(_READY)
        while True:
            try:
                task = conn.recv()
            except EOFError:
                return
            if task is None:
                return
            try:
                outcome = run(task, threads)
            except Exception as err:  # run_task records a run's own failure: this is the infrastructure's
                outcome = {"key": task.key, "lost": " ".join(f"{type(err).__name__}: {err}".split())}
            conn.send(outcome)


def in_pool(tasks, workers: int, threads: int = 1, run=run_task):
    """Yield ``run(task, threads)`` (default ``run_task``, a module-level function) of every task as it
    finishes, on ``workers`` spawned processes of ``threads`` threads each.

    A worker that dies (SIGKILL, the OOM killer, a crash) costs only the run it had: a new worker
    takes its place, the other runs go on, and the run is tried again in this call (yielding
    ``{"key": ..., "retried": why}`` to say so); after ``TRIES`` deaths it yields
    ``{"key": ..., "lost": why}`` (left for the next call). Closing the generator
    early (or an exception while it waits) kills the workers rather than waiting for the runs in flight.
    """
    # spawn, not fork: numba's OpenMP threading layer kills a child forked from a process that has
    # already run parallel code (a test session, a notebook). Each worker pays the imports again.
    context = multiprocessing.get_context("spawn")
    pending, deaths = deque(tasks), Counter[tuple]()
    pool: list[_Worker] = []
    finished = False
    unstarted, ever_started = 0, False
    try:
        while pending or any(w.task is not None for w in pool):
            while len(pool) < min(workers, len(pool) + len(pending)):
                pool.append(_Worker(context, threads, run))
            for worker in pool:
                _give(worker, pending)
            ready = set(wait([w.conn for w in pool if w.task is not None] + [w.process.sentinel for w in pool]))
            for worker in list(pool):
                outcome = _outcome(worker) if worker.conn in ready or worker.process.sentinel in ready else None
                if outcome == _READY:
                    worker.started = ever_started = True
                    outcome = _outcome(worker)  # its result may already be behind it
                if outcome is not None:
                    worker.task = None
                    _give(worker, pending)  # before the caller records the outcome: no worker waits for it
                    yield outcome
                elif worker.process.sentinel in ready:  # dead with no result: replace it, retry its run
                    pool.remove(worker)
                    worker.process.join(timeout=5)  # reaped: its exit code is known
                    task, why = worker.task, _death(worker.process)
                    worker.kill()
                    if not worker.started:
                        unstarted += 1
                        if unstarted >= TRIES and not any(w.started for w in pool) and not ever_started:
                            raise WorkersCannotStart(
                                f"the study's worker processes cannot start ({unstarted} died before their "
                                f"first run, {why}; their error is above): check that bwbench imports in a "
                                "fresh Python process, or run on one process (--workers 1, workers=1)"
                            )
                    if task is None:
                        continue
                    deaths[task.key] += 1
                    if deaths[task.key] < TRIES:
                        pending.appendleft(task)
                        yield {"key": task.key, "retried": why}
                    else:
                        yield {"key": task.key, "lost": f"its worker died {TRIES} times ({why})"}
        finished = True
    finally:
        for worker in pool:
            if finished:  # idle: let it leave on its own
                try:
                    worker.conn.send(None)
                    worker.process.join(timeout=10)
                except OSError:
                    pass
            worker.kill()


def _give(worker: _Worker, pending: deque) -> None:
    """Send an idle worker the next pending task, if any."""
    if worker.task is not None or not pending:
        return
    worker.task = pending.popleft()
    try:
        worker.conn.send(worker.task)
    except OSError:  # it died while idle: it is replaced when its sentinel is seen, the run is not charged
        pending.appendleft(worker.task)
        worker.task = None


def _outcome(worker: _Worker):
    """The outcome the worker has sent, or None (nothing there, or the pipe is closed)."""
    try:
        return worker.conn.recv() if worker.conn.poll() else None
    except (EOFError, OSError):
        return None


def _death(process) -> str:
    code = process.exitcode
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


def result_or_lost(future, task) -> dict:
    """The future's result; or, if the infrastructure failed it (a dead worker, a lost cluster),
    ``{"key": task.key, "lost": why}``: not a result, left for the next call."""
    # run_task never raises for a failed run: an exception here is the infrastructure's.
    try:
        return future.result()
    except Exception as err:
        return {"key": task.key, "lost": " ".join(f"{type(err).__name__}: {err}".split()) or type(err).__name__}
