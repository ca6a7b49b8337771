"""One thread per process by default: numba's parallel loops and the BLAS/OpenMP pools alike.

Why: a numba parallel loop waits at its end for its slowest thread. On a machine whose cores are busy
with other processes (a study's other workers, another user's job) every loop then waits for a thread
that has no core: ``bwbench fit`` of an MR-damper test took 73 s beside two busy processes with numba's
default of one thread per core, and 6 s with one thread — the same result. A study's workers already
fill the cores, and a BLAS-heavy backend's result must not depend on the thread count. ``--threads N``
(``fit``, ``compare``) opts in to more on a machine you know is quiet.
"""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager

from bwbench.errors import UserError


def check(threads: int, flag: str = "--threads") -> int:
    """``threads``, or ``UserError`` unless 1 ≤ threads ≤ the cores of this machine."""
    cores = os.cpu_count() or 1
    if not 1 <= threads <= cores:
        raise UserError(f"{flag} must be 1 to {cores} (the cores of this machine), got {threads}")
    return threads


@contextmanager
def for_workers(problem, workers: int):
    """Within the block, one fit of ``problem`` uses ``workers`` threads for the independent parts of an
    evaluation: a joint problem's files (each file's kernel on one thread: numba's pool must not be
    entered from two threads at once), else numba's pool (and BLAS) for the points of a batch
    (``limited``). Restored after."""
    joint = hasattr(problem, "workers")
    if joint:
        problem.workers = workers
    try:
        with limited(1 if joint else workers):
            yield
    finally:
        if joint:
            problem.workers = 1


@contextmanager
def limited(threads: int = 1):
    """Within the block, numba and the BLAS/OpenMP libraries use at most ``threads`` threads; the
    previous settings are restored after."""
    import numba

    previous = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))  # type: ignore[attr-defined]
    blas = blas_limits(threads)
    try:
        yield
    finally:
        blas.restore_original_limits()
        numba.set_num_threads(previous)


_CONTROLLER: list = []  # [threadpoolctl's ThreadpoolController, len(sys.modules) when it was made]


def blas_limits(threads: int, user_api: str | None = None):
    """``threadpoolctl.threadpool_limits(limits=threads, user_api=user_api)`` (a context manager, or
    call ``restore_original_limits()``) from a controller kept between calls: each new one reads every
    library the process has loaded (a fit asks three times). It is made again once modules were imported since:
    a new BLAS or OpenMP pool arrives with the extension module that loads it."""
    from threadpoolctl import ThreadpoolController

    if not _CONTROLLER or _CONTROLLER[1] != len(sys.modules):
        _CONTROLLER[:] = [ThreadpoolController(), len(sys.modules)]
    return _CONTROLLER[0].limit(limits=threads, user_api=user_api)


# Read by each library once, when it loads: numba's pool, OpenMP, OpenBLAS, MKL.
VARIABLES = ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def check_environment(environ=None) -> None:
    """``UserError`` naming the variable when a thread variable of ``VARIABLES`` is set to anything but a
    whole number from 1 to the cores of this machine (the range of ``--threads``): numba refuses 0 with a
    traceback at import, and the others silently ignore or oversubscribe. An empty value is unset."""
    environ = os.environ if environ is None else environ
    cores = os.cpu_count() or 1
    for name in VARIABLES:
        text = environ.get(name, "").strip()
        if not text:
            continue
        try:
            value = int(text)
        except ValueError:
            value = 0
        if not 1 <= value <= cores:
            raise UserError(
                f"{name}={environ[name]!r} in the environment: it must be a whole number of threads from "
                f"1 to {cores} (the cores of this machine); unset it (bwbench uses 1) or fix it"
            )


@contextmanager
def environment(threads: int = 1):
    """Within the block, the thread variables a user has not set say ``threads``, so the libraries this
    process loads later (and the workers it spawns) start no more threads than that; restored after.
    An invalid ``threads`` changes nothing (the command's own check refuses it)."""
    if not 1 <= threads <= (os.cpu_count() or 1):
        yield
        return
    added = [name for name in VARIABLES if name not in os.environ]
    if "NUMBA_NUM_THREADS" in added and _numba_pool_started():
        added.remove("NUMBA_NUM_THREADS")  # numba's pool exists: its size is fixed; ``limited`` caps its use
    os.environ.update({name: str(threads) for name in added})
    _numba_reread()
    try:
        yield
    finally:
        for name in added:
            # Numba re-reads its variables at every compilation and refuses a pool size other than the
            # one its pool started with: once started, the variable stays as it was started with.
            if not (name == "NUMBA_NUM_THREADS" and _numba_pool_started()):
                os.environ.pop(name, None)


def _numba_pool_started() -> bool:
    # numba's own flag: no public call says whether the pool started without starting it
    parallel = sys.modules.get("numba.np.ufunc.parallel")
    return bool(getattr(parallel, "_is_initialized", False))


def _numba_reread() -> None:
    """An already imported numba read its variables at import: make it read them now, before its pool
    starts (else it starts with the old size and refuses the new one at its next compilation)."""
    if "numba" in sys.modules and not _numba_pool_started():
        from numba.core import config

        config.reload_config()


def settle_numba_environment() -> None:
    """Make ``NUMBA_NUM_THREADS`` in the environment say the size numba's running pool has. Numba re-reads
    the variable at every compilation and raises if it differs from the launched pool's; a library
    imported late compiles at import (ArviZ), so call this before importing one. Nothing when the pool
    has not started or the two agree."""
    if not _numba_pool_started():
        return
    from numba.core import config

    size = str(config.NUMBA_NUM_THREADS)  # type: ignore[attr-defined]
    if os.environ.get("NUMBA_NUM_THREADS", size) != size:
        os.environ["NUMBA_NUM_THREADS"] = size
