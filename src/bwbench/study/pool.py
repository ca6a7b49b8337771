"""The local process pool of a study, whose workers never outlive it.

A worker of a plain ``ProcessPoolExecutor`` outlives a killed parent: it blocks forever on its call
queue, whose write end it holds itself, and it keeps the multiprocessing resource tracker alive
too, because every spawned worker inherits the tracker's pipe (``tracker_fd``) and the tracker only
exits when the last holder of that pipe has closed it. So on Linux each worker asks the kernel to
SIGKILL it when the study process dies (``PR_SET_PDEATHSIG``), and so does every process a worker
forks with ``os.fork`` (``subprocess`` children are not covered: no backend starts one); once the
workers are gone the tracker reads end-of-file and exits on its own. When the study stops early
(an exception, Ctrl-C, SIGTERM) the workers are killed at once instead of being waited for: a run
in flight is not a result anyway, and a posterior run can take minutes.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed

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
    # Ctrl-C reaches the whole foreground process group: the study process alone handles it (it
    # kills the workers), rather than every worker printing its own KeyboardInterrupt traceback.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def in_pool(tasks, workers: int):
    """Yield ``run_task(task)`` of every task as it finishes, on ``workers`` spawned processes.

    A task whose worker died yields ``{"key": ..., "lost": why}``. Closing the generator early (or
    an exception while it waits) kills the workers rather than waiting for the runs in flight.
    """
    # spawn, not fork: numba's OpenMP threading layer kills a child forked from a process that has
    # already run parallel code (a test session, a notebook). It costs each worker ~2.5 s of imports.
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=_init_worker, initargs=(os.getpid(),))
    finished = False
    try:
        futures = {pool.submit(run_task, t): t for t in tasks}
        for future in as_completed(futures):
            yield result_or_lost(future, futures.pop(future))  # pop: don't keep every result
        finished = True
    finally:
        if not finished:
            kill_workers(pool)
        pool.shutdown(wait=True, cancel_futures=True)


def kill_workers(pool: ProcessPoolExecutor) -> None:
    """SIGKILL every worker of ``pool`` now (its runs in flight are lost; the pool becomes broken)."""
    kill = getattr(pool, "kill_workers", None)  # Python 3.14+
    if kill is not None:
        kill()
        return
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        try:
            process.kill()
        except (OSError, ValueError):  # already gone, or already closed
            pass


def result_or_lost(future, task) -> dict:
    """The future's result; or, if the infrastructure failed it (a dead worker, a lost cluster),
    ``{"key": task.key, "lost": why}``: not a result, left for the next call."""
    # run_task never raises for a failed run: an exception here is the infrastructure's.
    try:
        return future.result()
    except Exception as err:
        return {"key": task.key, "lost": " ".join(f"{type(err).__name__}: {err}".split()) or type(err).__name__}
