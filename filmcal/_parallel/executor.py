"""The executor contract (`Executor`), its outcomes and errors, and the serial executor.

Every executor follows `concurrent.futures` (``submit`` returns a Future) with a
per-task deadline ``timeout_s``; `Executor.map_unordered` yields a `TaskOutcome`
as each task finishes.
"""
from __future__ import annotations

import abc
import signal
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, wait
from dataclasses import dataclass
from typing import Any


class TaskTimeoutError(TimeoutError):
    """A task ran longer than its deadline.

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
    """The process running a task exited before returning its result."""


@dataclass(frozen=True)
class TaskOutcome:
    """The outcome of one task of `Executor.map_unordered`.

    Attributes
    ----------
    index : int
        Position of the task in the input sequence.
    task : object
        The task itself (the argument given to the function).
    value : object
        The function's return value (None if it failed).
    error : BaseException or None
        Why the task failed: the exception it raised, `TaskTimeoutError`, or
        `WorkerDiedError`; None if it succeeded.
    """

    index: int
    task: Any
    value: Any = None
    error: BaseException | None = None

    @property
    def ok(self) -> bool:
        """True if the task returned a value."""
        return self.error is None

    def result(self) -> Any:
        """The return value, or raise the task's error."""
        if self.error is not None:
            raise self.error
        return self.value


def _check_timeout(timeout_s: float | None) -> float | None:
    """`timeout_s` as a positive finite float, or None for no deadline."""
    if timeout_s is None:
        return None
    try:
        value = float(timeout_s)
    except (TypeError, ValueError):
        raise ValueError(f"timeout_s must be a number > 0, got {timeout_s!r}") from None
    if not (value > 0 and value < float("inf")):
        raise ValueError(f"timeout_s must be a finite number > 0, got {timeout_s!r}")
    return value


def call_with_deadline(fn: Callable[..., Any], args: tuple, timeout_s: float | None) -> Any:
    """Return ``fn(*args)``, raising `TaskTimeoutError` once it runs past `timeout_s`.

    In the main thread of a POSIX process the call is interrupted by
    ``SIGALRM`` (this stops Python code, not a long call into compiled code
    until it returns). Elsewhere it runs in a daemon thread that is abandoned
    at the deadline: it keeps running until `fn` returns, since Python cannot
    kill a thread.

    Parameters
    ----------
    fn : callable
        The function to call.
    args : tuple
        Its positional arguments.
    timeout_s : float or None
        Deadline in seconds; None calls `fn` directly.
    """
    if timeout_s is None:
        return fn(*args)
    if threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer"):
        return _call_with_alarm(fn, args, timeout_s)
    return _call_in_watched_thread(fn, args, timeout_s)


def _call_with_alarm(fn: Callable[..., Any], args: tuple, timeout_s: float) -> Any:
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
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = fn(*args)
        except BaseException as exc:  # handed over to the waiting thread below
            outcome["error"] = exc

    thread = threading.Thread(target=target, name="filmcal-task", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive():
        raise TaskTimeoutError(timeout_s)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


class Executor(abc.ABC):
    """A `concurrent.futures`-style executor with per-task deadlines.

    Use it as a context manager: leaving the block normally waits for the
    tasks in flight; leaving it by an exception (Ctrl-C...) aborts them.
    """

    @property
    @abc.abstractmethod
    def max_workers(self) -> int:
        """Number of tasks that can run at the same time."""

    @abc.abstractmethod
    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Schedule ``fn(*args)`` and return the future of its result.

        Parameters
        ----------
        fn : callable
            The function; picklable for process and Dask executors.
        *args
            Its positional arguments, picklable likewise.
        timeout_s : float, optional
            Wall-clock deadline counted from the moment the task starts
            running; a task past it ends with `TaskTimeoutError`.

        Returns
        -------
        concurrent.futures.Future
            Holds the return value, the exception the task raised,
            `TaskTimeoutError` or `WorkerDiedError`.
        """

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Release the executor's resources.

        Parameters
        ----------
        wait : bool
            Return only once the tasks already running have finished.
        cancel_futures : bool
            Cancel the tasks that have not started yet.
        """

    def abort(self) -> None:
        """Stop now: cancel the tasks not started and stop the running ones (within about a second)."""
        self.shutdown(wait=False, cancel_futures=True)

    def map_unordered(self, fn: Callable[[Any], Any], tasks: Iterable[Any], *, timeout_s: float | None = None,
                      progress: Callable[[int, int], None] | None = None,
                      window: int | None = None) -> Iterator[TaskOutcome]:
        """Apply ``fn`` to every task; yield each outcome as soon as it is finished.

        Parameters
        ----------
        fn : callable
            ``fn(task)``; picklable for process and Dask executors.
        tasks : iterable
            The tasks (each one argument of `fn`).
        timeout_s : float, optional
            Deadline of each task.
        progress : callable, optional
            ``progress(done, total)`` called after each finished task.
        window : int, optional
            Tasks submitted ahead at any time (default: twice `max_workers`),
            so that a long task list is not pickled all at once.

        Yields
        ------
        TaskOutcome
            In order of completion; a failed task does not stop the map.

        Notes
        -----
        If the consumer stops early (``break``), the tasks not started are
        cancelled. On `KeyboardInterrupt` the executor is aborted and the
        interrupt re-raised.
        """
        timeout_s = _check_timeout(timeout_s)
        items = list(tasks)
        total = len(items)
        window = max(1, window if window is not None else 2 * self.max_workers)
        queue = iter(enumerate(items))
        in_flight: dict[Future, int] = {}
        done_count = 0
        finished = False

        def top_up() -> None:
            while len(in_flight) < window:
                item = next(queue, None)
                if item is None:
                    return
                index, task = item
                in_flight[self.submit(fn, task, timeout_s=timeout_s)] = index

        try:
            top_up()
            while in_flight:
                # a bounded wait keeps the main thread responsive to Ctrl-C
                done, _ = wait(list(in_flight), timeout=0.2, return_when=FIRST_COMPLETED)
                for future in done:
                    index = in_flight.pop(future)
                    outcome = _outcome(index, items[index], future)
                    done_count += 1
                    if progress is not None:
                        progress(done_count, total)
                    yield outcome
                top_up()
            finished = True
        except KeyboardInterrupt:
            self.abort()
            raise
        finally:
            if not finished:
                for future in in_flight:
                    future.cancel()

    def __enter__(self) -> "Executor":
        return self

    def __exit__(self, exc_type: type | None, *exc_info: object) -> None:
        if exc_type is None:
            self.shutdown(wait=True)
        else:
            self.abort()


def _outcome(index: int, task: Any, future: Future) -> TaskOutcome:
    try:
        return TaskOutcome(index, task, value=future.result())
    except CancelledError as exc:
        return TaskOutcome(index, task, error=exc)
    except Exception as exc:
        return TaskOutcome(index, task, error=exc)


class SerialExecutor(Executor):
    """Run every task at once, in the calling thread.

    No processes, no pickling, exceptions with their full traceback: for
    debugging and for cheap tasks. Deadlines use ``SIGALRM`` in the main
    thread (see `call_with_deadline`).
    """

    @property
    def max_workers(self) -> int:
        """One task at a time."""
        return 1

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Call ``fn(*args)`` now and return a finished future (see `Executor.submit`)."""
        timeout_s = _check_timeout(timeout_s)
        future: Future = Future()
        future.set_running_or_notify_cancel()
        try:
            future.set_result(call_with_deadline(fn, args, timeout_s))
        except Exception as exc:
            future.set_exception(exc)
        return future
