"""Executors that evaluate design points: in-process and on a Dask cluster.

Every executor follows `concurrent.futures`: ``submit`` returns a
`concurrent.futures.Future`, and the caller collects results with
`concurrent.futures.wait` or `concurrent.futures.as_completed`, whichever
executor produced them. One addition to the standard interface: ``submit``
takes a per-call deadline ``timeout_s``. A call that runs longer ends its
future with `TaskTimeoutError`, and the executor stays usable for the other
calls. How the deadline is enforced depends on where the call runs:

- `SerialExecutor` runs the call in the calling thread and interrupts it with
  ``SIGALRM`` (POSIX, main thread), which stops Python code, including
  ``time.sleep``, but not a long call into compiled code until it returns.
- `filmcal.campaign.LocalPoolExecutor` kills the worker process that runs an
  overdue call and starts a fresh one: the only mechanism that stops any hang.
- `DaskExecutor` runs the call in a watched thread of the Dask worker and gives
  up waiting at the deadline; the abandoned thread keeps running until the call
  returns (Python cannot kill a thread), so a model that truly never returns
  keeps using a core of that worker until the worker is restarted.
"""
from __future__ import annotations

import abc
import signal
import threading
from concurrent.futures import Future
from typing import Any, Callable

from filmcal._validation import check_positive

__all__ = [
    "TaskTimeoutError",
    "WorkerDiedError",
    "PointExecutor",
    "SerialExecutor",
    "DaskExecutor",
    "call_with_deadline",
]


class TaskTimeoutError(TimeoutError):
    """A call ran longer than its deadline.

    Parameters
    ----------
    timeout_s : float
        The deadline that was exceeded, in seconds.
    """

    def __init__(self, timeout_s: float) -> None:
        super().__init__(timeout_s)
        self.timeout_s = float(timeout_s)

    def __str__(self) -> str:
        return f"timeout after {self.timeout_s:g} s"


class WorkerDiedError(RuntimeError):
    """The process running a call exited before returning its result."""


def check_timeout(timeout_s: float | None) -> float | None:
    """Return `timeout_s` as a positive float, or None for no deadline."""
    return None if timeout_s is None else check_positive("timeout_s", timeout_s)


class PointExecutor(abc.ABC):
    """A `concurrent.futures`-style executor with per-call deadlines.

    Subclasses run ``fn(*args)`` somewhere and report its outcome through a
    `concurrent.futures.Future`. Use an executor as a context manager, or call
    `shutdown` when done.
    """

    @property
    @abc.abstractmethod
    def max_workers(self) -> int:
        """Number of calls that can run at the same time."""

    @abc.abstractmethod
    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Schedule ``fn(*args)`` and return the future of its result.

        Parameters
        ----------
        fn : callable
            The function to call; it must be picklable (a module-level
            function or an instance of a module-level class) for executors
            that run it in another process.
        *args
            Positional arguments of `fn`, picklable likewise.
        timeout_s : float, optional
            Wall-clock deadline of the call, counted from the moment it starts
            running. A call that runs longer ends with `TaskTimeoutError`.

        Returns
        -------
        concurrent.futures.Future
            Holds the return value of `fn`, the exception it raised,
            `TaskTimeoutError`, or `WorkerDiedError`.
        """

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Release the executor's resources.

        Parameters
        ----------
        wait : bool
            Return only once the calls already running have finished.
        cancel_futures : bool
            Cancel the calls that have not started yet.
        """

    def __enter__(self) -> "PointExecutor":
        return self

    def __exit__(self, exc_type: type | None, *exc_info: object) -> None:
        """Shut down; after an exception (Ctrl-C...) cancel and do not wait for calls in flight."""
        failed = exc_type is not None
        self.shutdown(wait=not failed, cancel_futures=failed)


def call_with_deadline(fn: Callable[..., Any], args: tuple, timeout_s: float | None) -> Any:
    """Return ``fn(*args)``, raising `TaskTimeoutError` once it runs past `timeout_s`.

    In the main thread of a POSIX process the call is interrupted by
    ``SIGALRM``. Elsewhere it runs in a daemon thread that is abandoned at the
    deadline (it keeps running until `fn` returns, see the module docstring).

    Parameters
    ----------
    fn : callable
        The function to call.
    args : tuple
        Its positional arguments.
    timeout_s : float or None
        Deadline in seconds; None calls `fn` directly.

    Returns
    -------
    object
        The return value of `fn`.
    """
    if timeout_s is None:
        return fn(*args)
    if threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
        return _call_with_alarm(fn, args, timeout_s)
    return _call_in_watched_thread(fn, args, timeout_s)


def _call_with_alarm(fn: Callable[..., Any], args: tuple, timeout_s: float) -> Any:
    """Call `fn` in this (main) thread and interrupt it with SIGALRM at the deadline."""
    def on_alarm(signum: int, frame: object) -> None:
        raise TaskTimeoutError(timeout_s)

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        return fn(*args)
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def _call_in_watched_thread(fn: Callable[..., Any], args: tuple, timeout_s: float) -> Any:
    """Call `fn` in a daemon thread; stop waiting for it at the deadline."""
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = fn(*args)
        except BaseException as exc:  # handed over to the waiting thread below
            outcome["error"] = exc

    thread = threading.Thread(target=target, name="filmcal-point", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive():
        raise TaskTimeoutError(timeout_s)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


class SerialExecutor(PointExecutor):
    """Run every call at once, in the calling thread.

    The simplest executor: no processes, no pickling, exceptions with their
    full traceback. Useful for debugging a model and for cheap models.
    Deadlines use ``SIGALRM`` in the main thread (see `call_with_deadline`).
    """

    @property
    def max_workers(self) -> int:
        """One call at a time."""
        return 1

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Call ``fn(*args)`` now and return a finished future (see `PointExecutor.submit`)."""
        timeout_s = check_timeout(timeout_s)
        future: Future = Future()
        future.set_running_or_notify_cancel()
        try:
            future.set_result(call_with_deadline(fn, args, timeout_s))
        except Exception as exc:
            future.set_exception(exc)
        return future


class DaskExecutor(PointExecutor):
    """Run calls on a Dask distributed cluster.

    A thin layer over ``distributed.Client.get_executor``: the client's own
    `concurrent.futures` executor, with calls submitted as impure tasks so that
    every submission runs. Dask's nanny starts its workers with
    ``OMP_NUM_THREADS=1`` and the other BLAS thread variables set to 1 by
    default, so one worker thread uses one core.

    Parameters
    ----------
    scheduler : str or distributed.Client
        Address of the scheduler (``"tcp://host:8786"``), or a connected
        client. A client created here from an address is closed by `shutdown`;
        a client passed in is left open.
    connect_timeout_s : float
        How long to try to reach the scheduler at an address.
    """

    def __init__(self, scheduler: Any, *, connect_timeout_s: float = 10.0) -> None:
        from distributed import Client

        if isinstance(scheduler, str):
            check_positive("connect_timeout_s", connect_timeout_s)
            try:
                self.client = Client(scheduler, timeout=connect_timeout_s, set_as_default=False)
            except (OSError, TimeoutError) as exc:
                raise ValueError(f"cannot connect to the Dask scheduler at {scheduler}: {exc}") from None
            self._owns_client = True
        elif isinstance(scheduler, Client):
            self.client = scheduler
            self._owns_client = False
        else:
            raise ValueError(f"scheduler must be an address or a distributed.Client, got {type(scheduler).__name__}")
        self._executor = self.client.get_executor(pure=False)

    @property
    def max_workers(self) -> int:
        """Total number of worker threads in the cluster (at least 1)."""
        return max(1, sum(self.client.nthreads().values()))

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Submit ``fn(*args)`` to the cluster (see `PointExecutor.submit`)."""
        timeout_s = check_timeout(timeout_s)
        return self._executor.submit(call_with_deadline, fn, args, timeout_s)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop submitting and close an owned client.

        Dask's executor either waits for every call in flight or cancels them
        all: ``wait=False`` or ``cancel_futures=True`` cancels them.
        """
        self._executor.shutdown(wait=wait and not cancel_futures)
        if self._owns_client:
            self.client.close()
