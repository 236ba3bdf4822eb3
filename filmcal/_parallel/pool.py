"""`LocalPoolExecutor`: local worker processes that an overdue task can be taken from.

A worker is a ``spawn`` process with one BLAS/OpenMP thread; it receives pickled
tasks over a pipe and answers each. An overdue task is ended by stopping its
worker, which is replaced, so that the others carry on (`ProcessPoolExecutor`
cannot stop one task).
"""
from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import CancelledError, Future
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as wait_connections
from typing import Any

from filmcal._parallel import processes
from filmcal._parallel.executor import Executor, TaskTimeoutError, WorkerDiedError, _check_timeout
from filmcal._parallel.processes import (_die_with_children, _set_parent_death_signal, _watch_parent,
                                         keep_freed_memory, limit_native_threads)

_STOP_GRACE_S = 5.0  # a worker asked to stop gets this long before it is killed
_START_ATTEMPTS = 3  # workers in a row that may die before they are ready before the pool gives up
_TERM_GRACE_S = 0.5  # a worker sent SIGTERM (it kills its children) gets this long
_STOP = b""  # an empty message asks a worker to exit
_READY = b"ready"  # a started worker's first message


def _worker_main(conn: Connection, parent_pid: int) -> None:
    """Serve tasks from the parent until it asks to stop or goes away."""
    processes._worker_parent_pid = parent_pid
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    if hasattr(signal, "pthread_sigmask"):  # blocked since the start (see _manage); a pending one is discarded
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    signal.signal(signal.SIGTERM, _die_with_children)
    _set_parent_death_signal(signal.SIGKILL)
    threading.Thread(target=_watch_parent, args=(parent_pid,), name="filmcal-parent-watch", daemon=True).start()
    if os.getppid() != parent_pid:  # the parent died before the watch was set up
        os._exit(1)
    limit_native_threads()
    keep_freed_memory()
    try:
        conn.send_bytes(_READY)
    except OSError:
        return
    while True:
        try:
            request = conn.recv_bytes()
        except (EOFError, OSError):
            return
        if request == _STOP:
            return
        reply = _answer(request)
        try:
            conn.send_bytes(reply)
        except OSError:
            return


def _answer(request: bytes) -> bytes:
    """Run the pickled task ``(fn, args)``; return the pickled ``(ok, value)``."""
    try:
        fn, args = pickle.loads(request)
        outcome: tuple[bool, Any] = (True, fn(*args))
    except Exception as exc:
        outcome = (False, exc)
    try:
        return pickle.dumps(outcome, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception as exc:
        what = "result" if outcome[0] else f"exception {type(outcome[1]).__name__}: {outcome[1]}"
        return pickle.dumps((False, RuntimeError(f"could not pickle the {what} ({exc})")))


@dataclass(eq=False)
class _Task:
    future: Future
    payload: bytes
    timeout_s: float | None


@dataclass(eq=False)
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: Connection
    ready: bool = False
    task: _Task | None = None
    deadline: float | None = None


def _stop_process(process: multiprocessing.process.BaseProcess, grace_s: float = _TERM_GRACE_S) -> None:
    """SIGTERM (the worker kills its children), then SIGKILL after `grace_s`; join."""
    if process.is_alive():
        process.terminate()
        process.join(grace_s)
    if process.is_alive():
        process.kill()
    process.join()


class LocalPoolExecutor(Executor):
    """Local worker processes, each task with its own deadline.

    Why not `concurrent.futures.ProcessPoolExecutor`: it cannot stop one hung
    task (killing a worker breaks the whole pool) and its workers outlive a
    killed parent. Here each worker runs one task at a time, the parent knows
    which task runs where and since when, an overdue task is ended by
    stopping its worker, and a fresh worker takes its place.

    Workers live as long as the pool, so a task can cache expensive setup in
    module-level state of its worker. Each worker limits BLAS/OpenMP to one
    thread. A manager thread of the parent starts the workers, dispatches
    tasks, collects results and enforces deadlines; tasks and results travel
    as pickles through one pipe per worker.

    Parameters
    ----------
    max_workers : int, optional
        Number of worker processes (default ``os.cpu_count()``).
    start_method : {"spawn", "forkserver", "fork"}
        How workers are started; ``"spawn"`` (default) is safe with threads
        in the parent, and needs tasks importable by name.

    Notes
    -----
    A worker dies with its parent: Linux delivers SIGKILL to it when the
    manager thread's process dies (``PR_SET_PDEATHSIG``), and a watchdog
    thread polls the parent pid every 0.25 s elsewhere; a worker running an
    external command (`run_guarded`) kills the command's process group
    first. Once the workers are gone, the multiprocessing resource tracker
    sees its pipe close and exits too.
    """

    def __init__(self, max_workers: int | None = None, *, start_method: str = "spawn") -> None:
        if max_workers is None:
            max_workers = os.cpu_count() or 1
        if isinstance(max_workers, bool) or not isinstance(max_workers, int) or max_workers < 1:
            raise ValueError(f"max_workers must be an integer >= 1, got {max_workers!r}")
        try:
            self._context = multiprocessing.get_context(start_method)
        except ValueError:
            methods = ", ".join(multiprocessing.get_all_start_methods())
            raise ValueError(f"start_method must be one of {methods}; got {start_method!r}") from None
        self._max_workers = max_workers
        self._lock = threading.Lock()
        self._pending: deque[_Task] = deque()
        self._shutting_down = False
        self._aborting = False
        self._broken: BaseException | None = None
        self._woken = False  # a wake-up byte is in the pipe
        self._wake_reader, self._wake_writer = self._context.Pipe(duplex=False)
        self._workers: list[_Worker] = []
        self._failed_starts = 0  # workers in a row that exited before they were ready
        # Workers are started by the manager thread, which lives until they
        # are all stopped: the parent-death signal follows the thread that
        # started a process.
        self._manager = threading.Thread(target=self._manage, name="filmcal-pool-manager", daemon=True)
        self._manager.start()

    @property
    def max_workers(self) -> int:
        """Number of worker processes."""
        return self._max_workers

    def worker_pids(self) -> list[int]:
        """Process ids of the current workers (for monitoring and tests)."""
        return [w.process.pid for w in list(self._workers) if w.process.pid is not None]

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Schedule ``fn(*args)`` on a worker process (see `Executor.submit`).

        Raises
        ------
        RuntimeError
            After `shutdown`, or if the pool broke.
        ValueError
            If `fn` or `args` cannot be pickled (e.g. a lambda or a local function).
        """
        timeout_s = _check_timeout(timeout_s)
        try:
            payload = pickle.dumps((fn, args), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            raise ValueError(f"cannot send the task to a worker process, it must be picklable: {exc}") from exc
        future: Future = Future()
        with self._lock:
            if self._broken is not None:
                raise RuntimeError(f"the process pool is broken: {self._broken!r}")
            if self._shutting_down:
                raise RuntimeError("cannot submit to a process pool after shutdown")
            self._pending.append(_Task(future, payload, timeout_s))
            self._wake()
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        """Stop accepting tasks; workers exit once the accepted tasks are done.

        Parameters
        ----------
        wait : bool
            Block until the workers have exited.
        cancel_futures : bool
            Cancel the tasks that have not started yet.
        """
        with self._lock:
            self._shutting_down = True
            if cancel_futures:
                while self._pending:
                    self._pending.popleft().future.cancel()
            self._wake()
        if wait:
            self._manager.join()

    def abort(self) -> None:
        """Cancel the tasks not started, stop every worker now and wait (about a second) for it."""
        with self._lock:
            self._shutting_down = True
            self._aborting = True
            while self._pending:
                self._pending.popleft().future.cancel()
            self._wake()
        self._manager.join(_TERM_GRACE_S + 1.5)

    # -- everything below runs in the manager thread, except _wake

    def _wake(self) -> None:
        """Interrupt the manager's wait (call with the lock held); one byte in the pipe at most."""
        if not self._woken:
            self._woken = True
            self._wake_writer.send_bytes(b"\0")

    def _start_worker(self) -> _Worker:
        if hasattr(signal, "pthread_sigmask"):
            # Workers inherit this (manager) thread's signal mask: a Ctrl-C that reaches a worker
            # while it is still starting, before it ignores SIGINT, then waits and is discarded
            # instead of printing a traceback; the main thread still receives the user's Ctrl-C.
            # The resource tracker is started first: starting it unblocks SIGINT in this thread.
            from multiprocessing import resource_tracker

            resource_tracker.ensure_running()
            signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        parent_conn, child_conn = self._context.Pipe(duplex=True)
        process = self._context.Process(target=_worker_main, args=(child_conn, os.getpid()),
                                        name="filmcal-worker", daemon=True)
        process.start()
        child_conn.close()
        return _Worker(process, parent_conn)

    def _manage(self) -> None:
        """Start workers, dispatch tasks, collect results and enforce deadlines until shut down."""
        try:
            self._workers = [self._start_worker() for _ in range(self._max_workers)]
            while True:
                if self._aborting:
                    break
                self._dispatch()
                if self._finished():
                    break
                ready = wait_connections(self._waitables(), timeout=self._seconds_to_next_deadline())
                if self._aborting:
                    break
                self._collect(ready)
                self._expire_overdue()
        except BaseException as exc:  # a manager that stops must not leave futures hanging
            self._fail_all(exc)
        finally:
            if self._aborting:
                self._fail_all(CancelledError("the executor was aborted"))
                self._kill_workers()
            else:
                self._stop_workers()

    def _finished(self) -> bool:
        with self._lock:
            idle = not self._pending and all(w.task is None for w in self._workers)
            return self._shutting_down and idle

    def _next_task(self) -> _Task | None:
        """The oldest pending task that was not cancelled, marked as running."""
        while True:
            with self._lock:
                if not self._pending:
                    return None
                task = self._pending.popleft()
            if task.future.set_running_or_notify_cancel():
                return task

    def _dispatch(self) -> None:
        for worker in list(self._workers):
            if not worker.ready or worker.task is not None:
                continue
            task = self._next_task()
            if task is None:
                return
            worker.task = task
            worker.deadline = None if task.timeout_s is None else time.monotonic() + task.timeout_s
            try:
                worker.conn.send_bytes(task.payload)
            except OSError:
                self._handle_exit(worker)

    def _waitables(self) -> list:
        objects: list = [self._wake_reader]
        for worker in self._workers:
            objects.append(worker.process.sentinel)
            if worker.task is not None or not worker.ready:
                objects.append(worker.conn)
        return objects

    def _seconds_to_next_deadline(self) -> float | None:
        deadlines = [w.deadline for w in self._workers if w.task is not None and w.deadline is not None]
        return max(0.0, min(deadlines) - time.monotonic()) if deadlines else None

    def _collect(self, ready: list) -> None:
        """Handle the objects found ready: wake-ups, replies, exits."""
        if self._wake_reader in ready:
            with self._lock:
                self._wake_reader.recv_bytes()
                self._woken = False
        # Match before handling: a replacement worker may reuse a closed descriptor number.
        replied = [w for w in self._workers if (w.task is not None or not w.ready) and w.conn in ready]
        exited = [w for w in self._workers if w.process.sentinel in ready]
        for worker in replied:
            if worker in self._workers:
                self._receive(worker)
        for worker in exited:
            if worker in self._workers:
                self._handle_exit(worker)

    def _receive(self, worker: _Worker) -> None:
        """Read a worker's message: its ready signal, or a reply that settles its task."""
        try:
            reply = worker.conn.recv_bytes()
        except (EOFError, OSError):
            self._handle_exit(worker)
            return
        if not worker.ready:
            worker.ready = reply == _READY
            if worker.ready:
                self._failed_starts = 0
            return
        task, worker.task, worker.deadline = worker.task, None, None
        if task is None:
            return
        try:
            ok, value = pickle.loads(reply)
        except Exception as exc:
            task.future.set_exception(RuntimeError(f"could not unpickle the worker's reply ({exc})"))
            return
        if ok:
            task.future.set_result(value)
        else:
            task.future.set_exception(value)

    def _handle_exit(self, worker: _Worker) -> None:
        """A worker exited on its own: fail its task and replace it.

        A worker that dies before it is ready is started again, up to
        `_START_ATTEMPTS` times in a row: one failed start can be the
        machine's (the interpreter's exec refused for a moment: exit code 255
        and no message), but workers that keep dying would die forever (e.g.
        a script that starts the pool without an ``if __name__ ==
        "__main__":`` guard): the pool then stops.
        """
        worker.process.join(_STOP_GRACE_S)
        if worker.process.is_alive():
            _stop_process(worker.process)
        code = worker.process.exitcode
        if not worker.ready:
            self._failed_starts += 1
            if self._failed_starts >= _START_ATTEMPTS:
                raise WorkerDiedError(f"a worker process failed to start {self._failed_starts} times in a row "
                                      f"(exit code {code})")
        if worker.task is not None:
            worker.task.future.set_exception(WorkerDiedError(f"worker process died (exit code {code})"))
            worker.task = None
        self._replace(worker)

    def _expire_overdue(self) -> None:
        """Stop the workers whose task ran past its deadline and replace them."""
        now = time.monotonic()
        for worker in list(self._workers):
            task = worker.task
            if task is None or worker.deadline is None or worker.deadline > now:
                continue
            if worker.conn.poll():  # the result arrived just in time
                self._receive(worker)
                continue
            _stop_process(worker.process)
            worker.task = None
            task.future.set_exception(TaskTimeoutError(task.timeout_s))
            self._replace(worker)

    def _replace(self, worker: _Worker) -> None:
        """Drop a dead (joined) worker; start a new one unless the pool is winding down."""
        worker.conn.close()
        worker.process.close()
        index = self._workers.index(worker)
        with self._lock:
            needed = not self._aborting and (not self._shutting_down or bool(self._pending))
        if needed:
            self._workers[index] = self._start_worker()
        else:
            del self._workers[index]

    def _fail_all(self, exc: BaseException) -> None:
        """Mark the pool broken and end every pending and running task with `exc`."""
        error = exc if isinstance(exc, CancelledError) else RuntimeError(f"the process pool stopped: {exc!r}")
        with self._lock:
            self._broken = exc
            pending = list(self._pending)
            self._pending.clear()
        for task in pending:
            if task.future.set_running_or_notify_cancel():
                task.future.set_exception(error)
        for worker in self._workers:
            if worker.task is not None and not worker.task.future.done():
                worker.task.future.set_exception(error)

    def _kill_workers(self) -> None:
        """Stop every worker at once: SIGTERM (each kills its children), SIGKILL shortly after."""
        for worker in self._workers:
            if worker.process.is_alive():
                worker.process.terminate()
        deadline = time.monotonic() + _TERM_GRACE_S
        for worker in self._workers:
            worker.process.join(max(0.0, deadline - time.monotonic()))
            if worker.process.is_alive():
                worker.process.kill()
            worker.process.join()
            worker.conn.close()
            worker.process.close()
        self._workers = []

    def _stop_workers(self) -> None:
        """Ask every worker to exit; stop those that do not within a grace period."""
        for worker in self._workers:
            try:
                worker.conn.send_bytes(_STOP)
            except OSError:
                pass  # already gone
        for worker in self._workers:
            worker.process.join(_STOP_GRACE_S)
            _stop_process(worker.process)
            worker.conn.close()
            worker.process.close()
        self._workers = []
