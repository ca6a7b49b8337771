"""Running a study's tasks on a Dask cluster, and telling a lost scheduler from a failed run.

When the scheduler goes away (stopped, crashed, network gone) the client cancels every future with
the reason "scheduler-connection-lost" and tries to reconnect for 20 s. The runs in flight are then
lost but the finished ones are in the database, so the study stops at once with one line
(``SchedulerLost``) rather than recording hundreds of "lost" runs. ``distributed``'s own logging in
this process (the reconnection attempts, the failure to reconnect, every closed connection) is
silenced while the study uses the cluster: what matters is said by that one line.
"""

from __future__ import annotations

import logging
from contextlib import contextmanager

from bwbench.errors import UserError
from bwbench.study.pool import result_or_lost
from bwbench.study.tasks import missing_plugins, plugins_of, run_task

_LOST_REASON = "scheduler-connection-lost"


class SchedulerLost(Exception):
    """The study lost its Dask scheduler; ``address`` and ``why`` say which and how."""

    def __init__(self, address: str, why: str):
        super().__init__(f"lost the Dask scheduler at {address}: {why}")
        self.address, self.why = address, why


def on_cluster(tasks, address: str):
    """Yield ``run_task(task)`` of every task as it finishes on the Dask cluster at ``address``.

    A task whose worker died yields ``{"key": ..., "lost": why}``. Raises ``UserError`` if the
    scheduler cannot be reached or a worker cannot load a plug-in the tasks need (before any run),
    ``SchedulerLost`` if it goes away mid-study.
    """
    try:
        from distributed import Client
        from distributed import as_completed as dask_completed
    except ImportError:
        raise UserError("--scheduler needs the 'distributed' package (pip install distributed)") from None
    with quiet_distributed():
        wait = reach(address)
        try:
            client = Client(address, timeout=f"{wait}s")
        except (OSError, TimeoutError, ValueError) as err:
            raise UserError(f"cannot connect to the Dask scheduler at {address}: {err}") from None
        try:
            _check_plugins(client, address, tasks)
            futures = {client.submit(run_task, t, pure=False): t for t in tasks}
            for future in dask_completed(futures):
                task = futures.pop(future)
                if future.status != "finished":
                    why = _lost_scheduler(client, future)
                    if why:
                        raise SchedulerLost(address, why)
                outcome = result_or_lost(future, task)
                future.release()
                yield outcome
        finally:
            _close(client)


def reach(address: str) -> int:
    """Connect to ``address`` and exchange Dask's handshake, within ``BWBENCH_SCHEDULER_WAIT_S`` seconds
    (returned); ``UserError`` in one line if that fails. ``distributed`` bounds the connection but not
    the handshake after it: a port that accepts and never answers (a dead proxy, a stopped process)
    would keep ``Client`` waiting forever, and a server of another protocol (HTTP) sends an answer it
    reads as a frame of terabytes (``MemoryError``)."""
    import asyncio

    import bwbench.limits as limits

    try:
        from distributed.comm import connect
    except ImportError:
        raise UserError("--scheduler needs the 'distributed' package (pip install distributed)") from None

    wait = limits.maximum("BWBENCH_SCHEDULER_WAIT_S")
    where = f"cannot connect to the Dask scheduler at {address}"

    async def handshake():
        comm = await asyncio.wait_for(connect(address, timeout=wait), wait)
        await comm.close()

    try:
        from distributed.comm import get_address_host_port

        get_address_host_port(address)  # a malformed address: distributed's words for it
    except (ValueError, TypeError) as err:
        raise UserError(f"{where}: {' '.join(str(err).split())}") from None
    except Exception:  # an address without a host and port (inproc://): left to distributed
        pass
    try:
        _knock(address, wait)  # a refused port is said at once (distributed retries until its timeout)
        _run_coroutine(handshake)
    except (TimeoutError, asyncio.TimeoutError):
        raise UserError(
            f"{where}: no answer within {wait} s (is a Dask scheduler listening there? raise the wait "
            f"with BWBENCH_SCHEDULER_WAIT_S=60 bwbench ...)"
        ) from None
    except (MemoryError, ValueError, TypeError, KeyError):  # an answer that is not Dask's protocol
        raise UserError(f"{where}: what listens there does not speak Dask's protocol (an HTTP server?)") from None
    except ConnectionRefusedError:
        raise UserError(f"{where}: the connection was refused (no scheduler listens on that port)") from None
    except OSError as err:
        raise UserError(f"{where}: {err.strerror or err}") from None
    except Exception as err:  # distributed's own errors (CommClosedError, ...): not a scheduler that answers
        raise UserError(f"{where}: {type(err).__name__}: {' '.join(str(err).split())}") from None
    return wait


def _run_coroutine(make) -> None:
    """``asyncio.run(make())``, in a thread of its own when this thread already runs an event loop (a
    notebook's), where ``asyncio.run`` is refused."""
    import asyncio

    try:
        asyncio.get_running_loop()
    except RuntimeError:  # no loop here: the usual case
        asyncio.run(make())
        return
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(1) as pool:
        pool.submit(lambda: asyncio.run(make())).result()


def _knock(address: str, wait: float) -> None:
    """Open and close a TCP connection to a ``tcp://HOST:PORT`` address (``OSError`` if refused);
    other addresses (tls://, inproc://) are left to ``distributed``."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(address if "://" in address else f"tcp://{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:  # not a number: distributed says what is wrong with it
        return
    if parts.scheme != "tcp" or not host or port is None:
        return
    with socket.create_connection((host, port), timeout=wait):
        pass


def _check_plugins(client, address: str, tasks) -> None:
    """``UserError`` naming the first worker that cannot load a problem or model plug-in the tasks need
    (a package installed where the study runs, not on the cluster). A worker that joins later and
    lacks one loses only its own runs (``run_task`` says why), retried on the next call."""
    plugins = list(dict.fromkeys(plugin for task in tasks for plugin in plugins_of(task)))
    for worker, missing in sorted(client.run(missing_plugins, plugins).items()):
        if missing:
            raise UserError(
                f"the Dask worker {worker} of the scheduler at {address} cannot load {missing[0]}; "
                "install the plug-in package on every worker"
            )


def _lost_scheduler(client, future) -> str | None:
    """Why the scheduler is gone, judging by the client and a failed ``future``; None if it is not."""
    try:
        err = future.exception(timeout=0)
    except Exception as raised:  # a cancelled future raises its cancellation
        err = raised
    # The cancellation says so, or (when the workers went first) the client is already reconnecting.
    if getattr(err, "reason", None) == _LOST_REASON or client.status not in ("running", "newly-created"):
        return "the connection closed"
    return None


def _close(client) -> None:
    try:
        # A short timeout: with the scheduler gone there is nothing to wait for.
        client.close(timeout=5)
    except Exception:  # closing a client whose scheduler is gone may complain: nothing to do about it
        pass


@contextmanager
def quiet_distributed():
    """Within the block, ``distributed``'s loggers in this process print nothing."""
    names = ["distributed", *(n for n in logging.root.manager.loggerDict if n.startswith("distributed."))]
    loggers = [logging.getLogger(n) for n in names]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)
