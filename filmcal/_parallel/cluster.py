"""`DaskExecutor`: the same tasks on a Dask distributed cluster.

The scheduler's address is checked and probed before connecting, so that a
wrong one fails in seconds; each task runs under its deadline and stops its
guarded children when its client goes away.
"""
from __future__ import annotations

import re
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

from filmcal._parallel.executor import Executor, _check_timeout, call_with_deadline
from filmcal._parallel.guarded import _task_context
from filmcal._parallel.processes import keep_freed_memory

_CONNECT_TIMEOUT_S = 5.0
_DASK_ADDRESS = re.compile(r"^(?:(?:tcp|tls|inproc|ws|wss|ucx)://)?\[?[A-Za-z0-9_.:-]+\]?:\d{1,5}$")


def check_dask_address(address: str) -> str:
    """Return a Dask scheduler address after checking its form (``[tcp://]host:port``).

    Raises
    ------
    ValueError
        If `address` is not of the form ``[scheme://]host:port`` with a port
        in 1..65535.
    """
    text = str(address).strip()
    if not _DASK_ADDRESS.match(text) or not 0 < int(text.rsplit(":", 1)[1]) < 65536:
        raise ValueError(f"--dask must be a scheduler address such as tcp://host:8786, got {address!r}")
    return text


def _probe_tcp(address: str, timeout_s: float | None) -> None:
    """Refuse a plain-TCP scheduler address at once when nothing listens there.

    Dask's client retries a refused connection until its timeout; a refused or
    unresolvable address is known after one attempt. Other schemes (tls, ws,
    ucx, inproc) are left to the client.
    """
    import socket

    if "://" in address and not address.startswith("tcp://"):
        return
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s).close()
    except (ConnectionRefusedError, socket.gaierror) as exc:
        raise ValueError(f"cannot connect to the Dask scheduler at {address}: {exc.strerror or exc}") from None
    except OSError:  # no answer in time, or unreachable: the client says so after its own timeout
        return


def _dask_cancel_probe() -> Callable[[], bool] | None:
    """A probe telling whether the Dask task running in this thread was cancelled or released."""
    try:
        from distributed import get_worker
        from distributed.worker import thread_state

        worker, key = get_worker(), thread_state.key
    except Exception:  # not in a Dask worker thread
        return None

    def cancelled() -> bool:
        state = worker.state.tasks.get(key)
        return state is None or state.state in ("cancelled", "released", "forgotten")

    return cancelled


def _call_with_probe(probe: Callable[[], bool] | None, fn: Callable[..., Any], args: tuple) -> Any:
    _task_context.cancelled = probe
    try:
        return fn(*args)
    finally:
        _task_context.cancelled = None


_dask_worker_ready = False  # set in a Dask worker's process by its first task


def _deadline_call(fn: Callable[..., Any], args: tuple, timeout_s: float | None) -> Any:
    """A Dask task: ``fn(*args)`` with its deadline, able to see its own cancellation.

    The first task in a worker's process lets glibc keep freed memory, as local workers do
    (`keep_freed_memory`): Dask's nanny makes glibc return it at once, which made the FE solves about
    twice as slow as in local workers."""
    global _dask_worker_ready
    if not _dask_worker_ready:
        keep_freed_memory()
        _dask_worker_ready = True
    return call_with_deadline(_call_with_probe, (_dask_cancel_probe(), fn, args), timeout_s)


class DaskExecutor(Executor):
    """Run tasks on a Dask distributed cluster.

    A thin layer over ``distributed.Client.get_executor``, with tasks
    submitted as impure so that every submission runs. Dask's nanny starts
    its workers with one BLAS thread each by default. A deadline is enforced
    in a watched thread of the Dask worker: at the deadline the task is given
    up, but the abandoned thread runs on until it returns. External commands
    run with `run_guarded` are killed at their own deadline instead, and as
    soon as their task is cancelled (its client disconnected, e.g. a killed
    campaign): see `task_cancelled`.

    Parameters
    ----------
    scheduler : str or distributed.Client
        Scheduler address (``"tcp://host:8786"``), or a connected client. A
        client created here is closed by `shutdown`; a client passed in is
        left open.
    connect_timeout_s : float
        How long to try to reach the scheduler at an address.

    Raises
    ------
    ValueError
        If the address is malformed or the scheduler cannot be reached in time.
    """

    def __init__(self, scheduler: Any, *, connect_timeout_s: float = _CONNECT_TIMEOUT_S) -> None:
        if isinstance(scheduler, str):
            address = check_dask_address(scheduler)
            connect_timeout_s = _check_timeout(connect_timeout_s)
            from distributed import Client

            _probe_tcp(address, connect_timeout_s)
            try:
                self.client = Client(address, timeout=connect_timeout_s, set_as_default=False)
            except (OSError, TimeoutError, ValueError) as exc:
                raise ValueError(f"cannot connect to the Dask scheduler at {address}: "
                                 f"{str(exc).splitlines()[0] if str(exc) else type(exc).__name__}") from None
            self._owns_client = True
        else:
            from distributed import Client

            if not isinstance(scheduler, Client):
                raise ValueError(f"scheduler must be an address or a distributed.Client, "
                                 f"got {type(scheduler).__name__}")
            self.client = scheduler
            self._owns_client = False
        self._executor = self.client.get_executor(pure=False)
        self._closed = False

    @property
    def max_workers(self) -> int:
        """Total number of worker threads in the cluster (at least 1)."""
        return max(1, sum(self.client.nthreads().values()))

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Submit ``fn(*args)`` to the cluster (see `Executor.submit`)."""
        timeout_s = _check_timeout(timeout_s)
        return self._executor.submit(_deadline_call, fn, args, timeout_s)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop submitting and close an owned client (``wait=False`` or cancelling cancels all in flight)."""
        if self._closed:
            return
        self._closed = True
        self._executor.shutdown(wait=wait and not cancel_futures)
        if self._owns_client:
            self.client.close(timeout=_CONNECT_TIMEOUT_S)
