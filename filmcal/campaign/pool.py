"""A local process pool with per-call deadlines: `LocalPoolExecutor`.

Why not `concurrent.futures.ProcessPoolExecutor`: it cannot stop one hung call.
Killing one of its workers breaks the whole pool. Here each worker process
runs one call at a time and the parent knows which call runs where and since
when, so an overdue call is ended by killing its worker, and a fresh worker
takes its place while the others carry on.

Workers live as long as the pool (they are not recycled after each call), so
a model can cache expensive setup in module-level state of the worker process.
Each worker limits BLAS/OpenMP to one thread: ``n`` workers use ``n`` cores.

A manager thread in the parent sends calls to idle workers, receives their
results, watches deadlines and replaces workers that died or were killed.
Calls and results travel as pickles through one pipe per worker.
"""
from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
import threading
import time
from collections import deque
from concurrent.futures import Future
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, Callable

from filmcal.campaign.executors import PointExecutor, TaskTimeoutError, WorkerDiedError, check_timeout

__all__ = ["LocalPoolExecutor"]

# Read by BLAS and OpenMP runtimes when they are loaded; threadpoolctl covers
# the ones already loaded when a worker starts.
NATIVE_THREAD_VARIABLES = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
)
_STOP = b""  # an empty message asks a worker to exit
_READY = b"ready"  # a started worker's first message
_STOP_GRACE_S = 5.0


def limit_native_threads() -> None:
    """Limit BLAS and OpenMP thread pools of this process to one thread."""
    for name in NATIVE_THREAD_VARIABLES:
        os.environ[name] = "1"
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # only the variables above then apply (to libraries loaded later)
        return
    threadpool_limits(limits=1)


def _worker_main(conn: Connection) -> None:
    """Serve calls from the parent until it asks to stop or goes away."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    limit_native_threads()
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
    """Run the pickled call ``(fn, args)``; return the pickled ``(ok, value)``."""
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


class LocalPoolExecutor(PointExecutor):
    """Run calls in a pool of local worker processes, each call with its own deadline.

    Parameters
    ----------
    max_workers : int, optional
        Number of worker processes; defaults to ``os.cpu_count()``.
    start_method : {"spawn", "forkserver", "fork"}
        How worker processes are started. ``"spawn"`` (default) starts clean
        interpreters, which is safe with threads in the parent; the function
        and arguments of a call must then be importable by name.

    Notes
    -----
    A deadline counts from the moment the call is handed to a started, idle
    worker (unpickling the call, e.g. importing the model's module on a
    worker's first call, is part of it). A call that exceeds its deadline, or whose worker dies (a crash in
    compiled code, the out-of-memory killer), ends with `TaskTimeoutError` or
    `WorkerDiedError`; its worker is replaced and the other calls go on.
    If the parent is killed, idle workers exit at once and busy ones as soon
    as their current call returns.
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
        self._broken: BaseException | None = None
        self._woken = False  # a wake-up byte is in the pipe
        self._wake_reader, self._wake_writer = self._context.Pipe(duplex=False)
        self._workers = [self._start_worker() for _ in range(max_workers)]
        self._manager = threading.Thread(target=self._manage, name="filmcal-pool-manager", daemon=True)
        self._manager.start()

    @property
    def max_workers(self) -> int:
        """Number of worker processes."""
        return self._max_workers

    def submit(self, fn: Callable[..., Any], /, *args: Any, timeout_s: float | None = None) -> Future:
        """Schedule ``fn(*args)`` on a worker process (see `PointExecutor.submit`).

        Raises
        ------
        RuntimeError
            After `shutdown`, or if the pool broke.
        ValueError
            If `fn` or `args` cannot be pickled (e.g. a lambda or a local function).
        """
        timeout_s = check_timeout(timeout_s)
        try:
            payload = pickle.dumps((fn, args), protocol=pickle.HIGHEST_PROTOCOL)
        except (pickle.PicklingError, TypeError, AttributeError) as exc:
            raise ValueError(f"cannot send the call to a worker process, it must be picklable: {exc}") from exc
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
        """Stop accepting calls; workers exit once the accepted calls are done.

        Parameters
        ----------
        wait : bool
            Block until the workers have exited.
        cancel_futures : bool
            Cancel the calls that have not started yet.
        """
        with self._lock:
            self._shutting_down = True
            if cancel_futures:
                while self._pending:
                    self._pending.popleft().future.cancel()
            self._wake()
        if wait:
            self._manager.join()

    # -- parent side: everything below runs in the manager thread, except _wake

    def _wake(self) -> None:
        """Interrupt the manager's wait (call with the lock held).

        At most one byte is in the pipe at a time, so writing never blocks.
        """
        if not self._woken:
            self._woken = True
            self._wake_writer.send_bytes(b"\0")

    def _start_worker(self) -> _Worker:
        parent_conn, child_conn = self._context.Pipe(duplex=True)
        process = self._context.Process(target=_worker_main, args=(child_conn,),
                                        name="filmcal-worker", daemon=True)
        process.start()
        child_conn.close()
        return _Worker(process, parent_conn)

    def _manage(self) -> None:
        """Dispatch calls, collect results and enforce deadlines until shut down."""
        try:
            while True:
                self._dispatch()
                if self._finished():
                    break
                ready = wait(self._waitables(), timeout=self._seconds_to_next_deadline())
                self._collect(ready)
                self._expire_overdue()
        except BaseException as exc:  # a manager that stops must not leave futures hanging
            self._fail_all(exc)
        finally:
            self._stop_workers()

    def _finished(self) -> bool:
        with self._lock:
            idle = not self._pending and all(w.task is None for w in self._workers)
            return self._shutting_down and idle

    def _next_task(self) -> _Task | None:
        """The oldest pending call that was not cancelled, marked as running."""
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
        """Handle the objects `wait` found ready: wake-ups, replies, exits."""
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
        """Read a worker's message: its ready signal, or a reply that settles its call."""
        try:
            reply = worker.conn.recv_bytes()
        except (EOFError, OSError):
            self._handle_exit(worker)
            return
        if not worker.ready:
            worker.ready = reply == _READY
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
        """A worker exited on its own: fail its call and replace it.

        A worker that dies before it is ready would die again (e.g. a script
        that starts the pool without an ``if __name__ == "__main__":`` guard):
        the pool then stops instead of restarting workers forever.
        """
        worker.process.join(_STOP_GRACE_S)
        if worker.process.is_alive():
            worker.process.kill()
            worker.process.join()
        code = worker.process.exitcode
        if not worker.ready:
            raise WorkerDiedError(f"a worker process failed to start (exit code {code})")
        if worker.task is not None:
            worker.task.future.set_exception(WorkerDiedError(f"worker process died (exit code {code})"))
        self._replace(worker)

    def _expire_overdue(self) -> None:
        """Kill the workers whose call ran past its deadline and replace them."""
        now = time.monotonic()
        for worker in list(self._workers):
            task = worker.task
            if task is None or worker.deadline is None or worker.deadline > now:
                continue
            if worker.conn.poll():  # the result arrived just in time
                self._receive(worker)
                continue
            worker.process.kill()
            worker.process.join()
            worker.task = None
            task.future.set_exception(TaskTimeoutError(task.timeout_s))
            self._replace(worker)

    def _replace(self, worker: _Worker) -> None:
        """Drop a dead (joined) worker; start a new one unless the pool is winding down."""
        worker.conn.close()
        worker.process.close()
        index = self._workers.index(worker)
        with self._lock:
            needed = not self._shutting_down or bool(self._pending)
        if needed:
            self._workers[index] = self._start_worker()
        else:
            del self._workers[index]

    def _fail_all(self, exc: BaseException) -> None:
        """Mark the pool broken and end every pending and running call with `exc`."""
        error = RuntimeError(f"the process pool stopped: {exc!r}")
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

    def _stop_workers(self) -> None:
        """Ask every worker to exit; kill those that do not within a grace period."""
        for worker in self._workers:
            try:
                worker.conn.send_bytes(_STOP)
            except OSError:
                pass  # already gone
        for worker in self._workers:
            worker.process.join(_STOP_GRACE_S)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join()
            worker.conn.close()
            worker.process.close()
        self._workers = []
