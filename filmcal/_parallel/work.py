"""Building executors from command-line options, one pool shared by stages, and running a dict of tasks."""
from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from typing import Any

from filmcal._parallel.cluster import DaskExecutor
from filmcal._parallel.executor import Executor, SerialExecutor
from filmcal._parallel.pool import LocalPoolExecutor


def open_executor(workers: int | None = None, *, dask: Any = None, n_tasks: int | None = None,
                  serial: bool = False) -> Executor:
    """The executor for command-line style options.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: number of CPUs).
    dask : str or distributed.Client, optional
        Run on this Dask cluster instead (``workers`` must then be None).
    n_tasks : int, optional
        Number of tasks to run: never more local processes than this.
    serial : bool
        Run in the calling thread (`SerialExecutor`).

    Returns
    -------
    Executor

    Raises
    ------
    ValueError
        If `workers` is not an integer >= 1, both `workers` and `dask` are
        given, or the Dask scheduler is malformed or unreachable.
    """
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if dask is not None:
        if workers is not None or serial:
            raise ValueError("give either workers (local processes) or dask (a cluster), not both")
        return DaskExecutor(dask)
    if serial:
        return SerialExecutor()
    n = workers if workers is not None else (os.cpu_count() or 1)
    if n_tasks is not None:
        n = max(1, min(n, int(n_tasks)))
    return LocalPoolExecutor(n)


class SharedPool(Executor):
    """Local worker processes started by the first task and shared by every later one.

    A run of several stages, each with a few tasks, opens one `SharedPool`
    and hands it to every stage (`run_tasks`, `filmcal.campaign.Campaign`):
    the workers then import the solvers and fill their per-process caches
    once for the whole run instead of once per stage, and a run whose work
    is all done already (a rerun) starts no process at all.

    Parameters
    ----------
    workers : int, optional
        Worker processes (default: number of CPUs).
    """

    def __init__(self, workers: int | None = None) -> None:
        if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        self.workers = workers
        self._pool: LocalPoolExecutor | None = None
        self._closed = False

    @property
    def started(self) -> bool:
        """True once the worker processes have been started."""
        return self._pool is not None

    def _open(self) -> LocalPoolExecutor:
        if self._closed:
            raise RuntimeError("the shared pool is shut down")
        if self._pool is None:
            self._pool = LocalPoolExecutor(self.workers if self.workers is not None else (os.cpu_count() or 1))
        return self._pool

    @property
    def max_workers(self) -> int:
        """Number of worker processes (started or to be started)."""
        return self._pool.max_workers if self._pool is not None else (self.workers or os.cpu_count() or 1)

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Submit ``fn(*args)``, starting the workers first if needed (see `Executor.submit`)."""
        return self._open().submit(fn, *args, timeout_s=timeout_s)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop the workers, if they were started."""
        self._closed = True
        if self._pool is not None:
            self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)

    def abort(self) -> None:
        """Stop the workers at once, if they were started."""
        self._closed = True
        if self._pool is not None:
            self._pool.abort()


@contextlib.contextmanager
def parallel_work(workers: int | None = None, dask: Any = None, *,
                  shared: bool = False) -> Iterator[int | Executor | None]:
    """Where a command's parallel work runs (its ``--workers`` or ``--dask``), for as long as the command runs.

    Yields the ``workers`` argument of the library's parallel functions
    (`run_tasks`, `filmcal.study.Study.calibrate`, ...). With `dask`, the
    scheduler is reached on entry, so a command that enters this before it
    writes anything leaves nothing behind when the scheduler cannot be
    reached; the client is closed on exit.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: all cores; 1: everything in the calling process). Unused with `dask`.
    dask : str or distributed.Client, optional
        A Dask scheduler's address (or a client): every task runs on that cluster (`DaskExecutor`).
    shared : bool
        Without `dask`: one `SharedPool` for every call (a run of several stages) instead of `workers` as
        given (each call opens and closes its own pool; 1 stays 1 either way).

    Raises
    ------
    ValueError
        If the Dask address is malformed or its scheduler cannot be reached.
    """
    if dask is not None:
        with DaskExecutor(dask) as cluster:
            yield cluster
    elif shared and workers != 1:
        with SharedPool(workers) as pool:
            yield pool
    else:
        yield workers


def _call_task(task: tuple) -> tuple[Any, list]:
    """Run one ``(key, function, args)`` task of `run_tasks`: its value and the warnings it raised.

    A worker's warnings would reach the terminal raw, line by line; they travel back with the value instead
    and are raised again in the calling process, where a stage collects them into one line.
    """
    import warnings

    import pickle

    _, fn, args = task
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        value = fn(*args)
    raised: dict = {}  # each (kind, message) once: a warning in an inner loop is not sent back a thousand times
    for w in caught:
        category = w.category
        try:
            pickle.dumps(category)
        except Exception:  # a warning class defined where the caller cannot import it
            category = UserWarning
        raised.setdefault((category, str(w.message)), None)
    return value, list(raised)


def _raise_again(raised: list) -> None:
    import warnings

    for category, message in raised:
        warnings.warn(message, category if isinstance(category, type) and issubclass(category, Warning)
                      else UserWarning, stacklevel=2)


def run_tasks(tasks: dict, workers: int | Executor | None, on_done: Callable[[Any, Any, int], None]) -> None:
    """Run ``{key: (function, args)}`` and hand each result to ``on_done(key, value, k)`` as it finishes.

    Each finished unit reaches `on_done` at once (which persists it), so an
    interrupt keeps every finished unit; a failed unit raises after the others
    have finished. Given a number of workers, one task, or ``workers=1``,
    runs in the calling process, and a pool opened for more is closed at the
    end; given an executor (a `SharedPool`), every task goes to it and it is
    left running.

    Parameters
    ----------
    tasks : dict
        Key -> (picklable module-level function, argument tuple); the order is
        the order of submission (put the longest first).
    workers : int or Executor, optional
        Local worker processes (default: all cores), or the executor to use.
    on_done : callable
        ``on_done(key, value, k)`` with ``k`` the number finished so far.

    Raises
    ------
    InputError
        If the first failed task failed on its input (`filmcal._errors.InputError`: bad input, said as such).
    RuntimeError
        If any other task failed (the first failure is chained).
    """
    from filmcal._errors import InputError

    items = [(key, fn, args) for key, (fn, args) in tasks.items()]
    if not items:
        return
    errors = []

    def consume(executor: Executor) -> None:
        for k, outcome in enumerate(executor.map_unordered(_call_task, items), 1):
            if outcome.ok:
                value, raised = outcome.value
                _raise_again(raised)
                on_done(outcome.task[0], value, k)
            else:
                errors.append((outcome.task[0], outcome.error))

    if isinstance(workers, Executor):
        consume(workers)
    else:
        with open_executor(workers, n_tasks=len(items), serial=len(items) <= 1 or workers == 1) as executor:
            consume(executor)
    if errors:
        key, error = errors[0]
        if isinstance(error, InputError):  # the input's fault, said as it is: not an internal error
            raise error
        raise RuntimeError(f"{len(errors)} task(s) failed, first {key}: {error!r}") from error
