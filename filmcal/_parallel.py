"""One executor abstraction for every parallel stage: serial, local processes, Dask.

Everything in filmcal that runs independent units of work in parallel (FE
campaign points, pipeline stages per film or per fold, GP optimiser restarts)
goes through this module, so that deadlines, Ctrl-C and killed parents behave
the same way everywhere.

The executors
-------------
All three follow `concurrent.futures` (``submit`` returns a
`concurrent.futures.Future`) with one addition: ``submit`` takes a per-task
deadline ``timeout_s``; a task that runs longer ends with `TaskTimeoutError`
and the executor stays usable.

`SerialExecutor`
    Runs each task at once in the calling thread (debugging, cheap tasks). A
    deadline interrupts Python code with ``SIGALRM`` in the main thread.
`LocalPoolExecutor`
    Local worker processes (``spawn``), one BLAS/OpenMP thread each, so that
    ``n`` workers use ``n`` cores. An overdue task is ended by stopping its
    worker, which is replaced; the others carry on. Workers never outlive the
    parent: on Linux they ask the kernel for a signal when the parent dies
    (``prctl(PR_SET_PDEATHSIG)``), and everywhere a watchdog thread polls the
    parent's pid. Child processes started with `run_guarded` (external
    solvers) are killed with their worker.
`DaskExecutor`
    A Dask distributed cluster given by its scheduler address or a client.
    The address is checked before connecting and the connection is given a
    few seconds, so a wrong address fails fast with a `ValueError`.

Use `open_executor` to build one from command-line style options: it never
starts more processes than there are tasks.

Mapping with results as they complete
-------------------------------------
`Executor.map_unordered` submits tasks a bounded window at a time and yields
a `TaskOutcome` as soon as each task finishes, so that the caller can persist
every finished unit at once::

    from filmcal._parallel import open_executor

    with open_executor(workers=4, n_tasks=len(folds)) as executor:
        for outcome in executor.map_unordered(fit_fold, folds, timeout_s=600,
                                              progress=lambda done, total: ...):
            if outcome.ok:
                save(outcome.task, outcome.value)      # persisted right away
            else:
                log(outcome.task, outcome.error)       # TaskTimeoutError, WorkerDiedError, or the task's exception

On Ctrl-C (`KeyboardInterrupt` in the consuming thread) the map cancels the
tasks not started, stops the workers at once (`Executor.abort`) and re-raises:
what was already yielded is kept by the caller, the command exits in well
under 2 s. Tasks (function and arguments) must be picklable for process and
Dask executors: module-level functions, or instances of module-level classes.
"""
from __future__ import annotations

import abc
import contextlib
import ctypes
import ctypes.util
import multiprocessing
import os
import pickle
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, CancelledError, Future, wait
from dataclasses import dataclass
from multiprocessing.connection import Connection
from multiprocessing.connection import wait as wait_connections
from typing import Any

__all__ = [
    "descendant_pids",
    "pid_alive",
    "TaskTimeoutError",
    "WorkerDiedError",
    "TaskOutcome",
    "Executor",
    "SerialExecutor",
    "LocalPoolExecutor",
    "DaskExecutor",
    "open_executor",
    "SharedPool",
    "parallel_work",
    "run_tasks",
    "check_dask_address",
    "call_with_deadline",
    "limit_native_threads",
    "keep_freed_memory",
    "GuardedRun",
    "run_guarded",
    "OUTPUT_CAP_BYTES",
    "task_cancelled",
    "NATIVE_THREAD_VARIABLES",
]

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
_PARENT_POLL_S = 0.25  # how often a worker's watchdog looks at its parent
_STOP_GRACE_S = 5.0  # a worker asked to stop gets this long before it is killed
_START_ATTEMPTS = 3  # workers in a row that may die before they are ready before the pool gives up
_TERM_GRACE_S = 0.5  # a worker sent SIGTERM (it kills its children) gets this long
_CONNECT_TIMEOUT_S = 5.0

#: Most bytes of each output stream (stdout, stderr) of a command that `run_guarded` reads back:
#: the last ones; more is flagged as truncated (`GuardedRun.stdout_truncated`), never held in memory.
OUTPUT_CAP_BYTES = 16 * 2**20
_WAIT_POLL_S = 0.05  # longest sleep between two looks at a running child that has a deadline
_CANCEL_POLL_S = 0.2  # how often a waiting run_guarded asks whether its task was cancelled


# -- errors and outcomes -------------------------------------------------------------


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


# -- the processes of a worker: native threads, parent watch, guarded children --------


def limit_native_threads() -> None:
    """Limit BLAS and OpenMP thread pools of this process to one thread."""
    for name in NATIVE_THREAD_VARIABLES:
        os.environ[name] = "1"
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # only the variables above then apply (to libraries loaded later)
        return
    threadpool_limits(limits=1)


_PR_SET_PDEATHSIG = 1
_libc: Any = None


def _c_library() -> Any:
    """The C library (Linux), loaded once; None where it cannot be loaded."""
    global _libc
    if _libc is None:
        try:
            _libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        except OSError:
            return None
    return _libc


# glibc's mallopt parameters and the values `keep_freed_memory` sets
_M_TRIM_THRESHOLD, _M_TOP_PAD, _M_MMAP_THRESHOLD = -1, -2, -3
_TRIM_THRESHOLD_BYTES = 256 << 20
_TOP_PAD_BYTES = 64 << 20
_MMAP_THRESHOLD_BYTES = 32 << 20  # glibc's largest on 64-bit systems


def keep_freed_memory() -> bool:
    """Let glibc keep freed heap memory for reuse instead of returning it to the kernel at once.

    The solvers allocate and free arrays of a few hundred kB to a few MB on
    every iteration; by default glibc gives that memory back and the next
    iteration faults it in again page by page, which costs about a quarter
    of the time of an FFT-based contact solve (system time). Arrays below
    32 MB then come from the heap (not from their own memory maps), and the
    heap keeps up to 256 MB of free memory (grown by 64 MB at a time): the
    peak memory stays about the same. Returns False where the C library is
    not glibc.
    """
    if not sys.platform.startswith("linux"):
        return False
    libc = _c_library()
    try:
        return all(libc.mallopt(param, value) == 1 for param, value in (
            (_M_MMAP_THRESHOLD, _MMAP_THRESHOLD_BYTES), (_M_TRIM_THRESHOLD, _TRIM_THRESHOLD_BYTES),
            (_M_TOP_PAD, _TOP_PAD_BYTES)))
    except AttributeError:  # not glibc
        return False


def _set_parent_death_signal(signum: int) -> bool:
    """Ask Linux to send `signum` to this process when its parent thread exits.

    Returns False where ``prctl`` is not available (not Linux).
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        return _c_library().prctl(_PR_SET_PDEATHSIG, int(signum), 0, 0, 0) == 0
    except (OSError, AttributeError):
        return False


# State of a pool worker process (set by _worker_main; unused in other processes).
_worker_parent_pid: int | None = None
_child_groups: set[tuple[int, str]] = set()  # (process group, run mark) of the children started by run_guarded
_child_lock = threading.Lock()


def _kill_children() -> None:
    """Kill the process groups of the children started by `run_guarded` in this process."""
    with _child_lock:
        groups = list(_child_groups)
    for group, _ in groups:
        _killpg(group)
    if groups:  # one sweep for every mark, without waiting: the worker has `_TERM_GRACE_S` to stop
        _kill_marked([mark for _, mark in groups], asleep_wait_s=0.0)


def _die_with_children(signum: int = signal.SIGTERM, frame: object = None) -> None:
    """Kill this worker's children, then exit at once (SIGTERM handler of a worker)."""
    _kill_children()
    os._exit(128 + int(signum))


def _watch_parent(parent_pid: int) -> None:
    """Watchdog thread of a worker: exit (with the children) once the parent is gone."""
    while True:
        time.sleep(_PARENT_POLL_S)
        if os.getppid() != parent_pid:
            _die_with_children(signal.SIGHUP)


def _parent_alive() -> bool:
    return _worker_parent_pid is None or os.getppid() == _worker_parent_pid


@dataclass(frozen=True)
class GuardedRun:
    """What a child process started by `run_guarded` did.

    Attributes
    ----------
    returncode : int or None
        Exit status (negative: killed by that signal); None if it timed out.
    stdout, stderr : str
        Its output (decoded as UTF-8 with replacement characters): all of it,
        or only its last `OUTPUT_CAP_BYTES` bytes when it wrote more (see
        `stdout_truncated`, `stderr_truncated`).
    timed_out : bool
        True if it was killed at the deadline (or because its task was cancelled).
    elapsed_s : float
        Wall-clock time.
    stdout_bytes, stderr_bytes : int
        How many bytes it wrote on each stream (0 when not measured).
    stdout_truncated, stderr_truncated : bool
        True if the stream held more than `OUTPUT_CAP_BYTES` bytes, so that
        `stdout` (`stderr`) is only its end.
    """

    returncode: int | None
    stdout: str
    stderr: str
    timed_out: bool
    elapsed_s: float
    stdout_bytes: int = 0
    stderr_bytes: int = 0
    stdout_truncated: bool = False
    stderr_truncated: bool = False


# A probe set by the executor running the current task: returns True once the
# task is no longer wanted (its Dask client went away, ...).
_task_context = threading.local()


def task_cancelled() -> bool:
    """True if the executor running the current task no longer wants its result.

    Long tasks may poll it; `run_guarded` does, and kills its child when it
    turns True. Only Dask tasks can be cancelled while running (when their
    client disconnects or cancels them); elsewhere it is always False.
    """
    probe = getattr(_task_context, "cancelled", None)
    if probe is None:
        return False
    try:
        return bool(probe())
    except Exception:  # a probe that fails never stops a task
        return False


def run_guarded(argv: Sequence[str] | str, *, cwd: str | os.PathLike | None = None,
                timeout_s: float | None = None, shell: bool = False,
                env: dict[str, str] | None = None) -> GuardedRun:
    """Run a child process in its own process group, killed with its descendants at the deadline.

    The child gets a new session, so a deadline (or the death of the worker
    running it) kills the whole group: a shell and everything it started.
    In a `LocalPoolExecutor` worker the group is also killed when the worker
    is stopped or its parent dies, so no external solver outlives a killed
    campaign.

    Parameters
    ----------
    argv : sequence of str, or str with ``shell=True``
        The command.
    cwd : path-like, optional
        Working folder of the child.
    timeout_s : float, optional
        Deadline in seconds.
    shell : bool
        Run `argv` (a string) with ``/bin/sh -c``.
    env : dict, optional
        Environment of the child (default: this process's).

    Returns
    -------
    GuardedRun

    Notes
    -----
    The run ends when the child itself exits, not when its output streams
    close: stdout and stderr go to unnamed temporary files (in the folder of
    `tempfile.gettempdir`, ``TMPDIR``), so a background process the command leaves behind (``sleep 60 &``)
    holds no pipe that would keep the caller waiting. Once the child has
    exited, its process group is killed, so such leftovers die with it; and
    on Linux so is every process that carries the run's mark in its
    environment (`RUN_MARK_VARIABLE`, set for the child and inherited): a
    descendant that left the group (``setsid``, a daemon) dies too. One
    started without the mark escapes (``env -u FILMCAL_RUN_MARK`` for a
    helper meant to outlive the run; ``env -i``); it does not delay the run
    either.

    Only the last `OUTPUT_CAP_BYTES` bytes of each stream are read back, so
    a command that writes gigabytes costs disk space in the temporary
    folder, not memory; `GuardedRun.stdout_truncated` and
    `GuardedRun.stderr_truncated` say when a stream was longer. The end is
    kept because that is where a command prints its answer (a final JSON
    line) and its error messages.
    """
    timeout_s = _check_timeout(timeout_s)
    cap = int(OUTPUT_CAP_BYTES)
    mark = os.urandom(12).hex()
    env = dict(os.environ if env is None else env)
    # added to the marks of any run this one is part of (filmcal inside a guarded command), not in their place
    env[RUN_MARK_VARIABLE] = ":".join(filter(None, (env.get(RUN_MARK_VARIABLE, ""), mark)))
    in_worker = _worker_parent_pid is not None and threading.current_thread() is threading.main_thread()
    start = time.perf_counter()
    if in_worker:
        # While a child runs, the parent's death is a catchable SIGTERM, so
        # that the worker can kill the child's group before it exits.
        _set_parent_death_signal(signal.SIGTERM)
        if not _parent_alive():
            _die_with_children(signal.SIGHUP)
    try:
        with tempfile.TemporaryFile() as out_file, tempfile.TemporaryFile() as err_file:
            process = subprocess.Popen(argv, cwd=cwd, shell=shell, env=env, stdin=subprocess.DEVNULL,
                                       stdout=out_file, stderr=err_file, start_new_session=True)
            with _child_lock:
                _child_groups.add((process.pid, mark))
            try:
                try:
                    _wait_for_exit(process, timeout_s)
                    timed_out = False
                except subprocess.TimeoutExpired:  # the deadline, or _Cancelled
                    timed_out = True
            finally:
                # The child is not reaped yet, so its pid (the group's id) cannot be reused: this kills the
                # command at its deadline (or on an exception), and else what it left running.
                _killpg(process.pid)
                process.wait()  # a session leader cannot leave its group: it is dead now
                _kill_marked(mark)  # and what left the group (setsid, a daemon) but kept the environment
                with _child_lock:
                    _child_groups.discard((process.pid, mark))
            out, out_bytes = _read_tail(out_file, cap)
            err, err_bytes = _read_tail(err_file, cap)
    finally:
        if in_worker:
            _set_parent_death_signal(signal.SIGKILL)
    return GuardedRun(None if timed_out else process.returncode,
                      out.decode("utf-8", "replace"), err.decode("utf-8", "replace"),
                      timed_out, time.perf_counter() - start,
                      stdout_bytes=out_bytes, stderr_bytes=err_bytes,
                      stdout_truncated=out_bytes > cap, stderr_truncated=err_bytes > cap)


class _Cancelled(subprocess.TimeoutExpired):
    """The task running the child was cancelled (handled like a deadline)."""


def _exited(process: subprocess.Popen, block: bool = False) -> bool:
    """True once `process` has exited, without reaping it where ``waitid`` exists (its pid stays taken).

    With `block`, wait for that.
    """
    if not hasattr(os, "waitid"):  # macOS: Popen reaps it
        if block:
            process.wait()
            return True
        return process.poll() is not None
    options = os.WEXITED | os.WNOWAIT | (0 if block else os.WNOHANG)
    try:
        return os.waitid(os.P_PID, process.pid, options) is not None
    except ChildProcessError:  # already reaped (SIGCHLD ignored): nothing left to wait for
        return True


def _wait_for_exit(process: subprocess.Popen, timeout_s: float | None) -> None:
    """Wait until the child has exited (not until its output closes).

    Raises `subprocess.TimeoutExpired` at the deadline, and `_Cancelled` once
    the task is cancelled (`task_cancelled`, polled every 0.2 s when the
    executor set a probe).
    """
    probe = getattr(_task_context, "cancelled", None) is not None
    if timeout_s is None and not probe:
        _exited(process, block=True)
        return
    now = time.monotonic()
    deadline = None if timeout_s is None else now + timeout_s
    next_probe = now + _CANCEL_POLL_S
    pause = 0.0005
    while not _exited(process):
        now = time.monotonic()
        if deadline is not None and now >= deadline:
            raise subprocess.TimeoutExpired(process.args, timeout_s)
        if probe and now >= next_probe:
            if task_cancelled():
                raise _Cancelled(process.args, timeout_s or 0.0)
            next_probe = now + _CANCEL_POLL_S
        pause = min(2 * pause, _WAIT_POLL_S)
        if deadline is not None:
            pause = min(pause, max(deadline - now, 0.0))
        time.sleep(pause)


def _read_tail(stream: Any, cap: int) -> tuple[bytes, int]:
    """The last `cap` bytes of a temporary output file, and its size.

    Read with ``pread``, so that the offset it shares with a process that
    escaped the group (and may still write) is left alone.
    """
    fd = stream.fileno()
    size = os.fstat(fd).st_size
    offset = first = max(0, size - cap)
    chunks = []
    while cap > 0:
        chunk = os.pread(fd, min(cap, 1 << 20), offset)
        if not chunk:
            break
        chunks.append(chunk)
        offset += len(chunk)
        cap -= len(chunk)
    data = b"".join(chunks)
    if first > 0:  # cut: drop the continuation bytes of a UTF-8 character split at the start
        skip = 0
        while skip < min(3, len(data)) and data[skip] & 0xC0 == 0x80:
            skip += 1
        data = data[skip:]
    return data, size


def _killpg(group: int) -> None:
    try:
        os.killpg(group, signal.SIGKILL)
    except OSError:
        pass


#: Environment variable that marks every process a `run_guarded` command starts (its value: the random marks of
#: the runs it is part of, joined by ``:``): descendants inherit it, also those that leave the process group. A
#: helper that is meant to outlive the run (a licence or compile server the command starts) is started without
#: it: ``env -u FILMCAL_RUN_MARK server &``.
RUN_MARK_VARIABLE = "FILMCAL_RUN_MARK"


def _process_state(entry: os.DirEntry) -> str | None:
    """``"D"`` if a thread of this user's process ``/proc/<pid>`` (`entry`) is in uninterruptible sleep, else its
    main thread's state letter; None for another user's process or a gone one.

    None of the reads blocks: the owner is the directory's, the states are read from the threads' ``stat``,
    which takes no lock of the process.
    """
    states = []
    try:
        if entry.stat().st_uid != os.getuid():
            return None
        for task in os.scandir(f"/proc/{entry.name}/task"):
            with open(f"/proc/{entry.name}/task/{task.name}/stat", "rb") as fh:
                stat = fh.read()
            close = stat.rfind(b")")  # the thread's name, in parentheses, may hold anything
            states.append(stat[close + 2:close + 3].decode("ascii", "replace"))
    except OSError:  # gone (or a thread gone: read again at the next pass)
        return None
    if not states:
        return None
    return "D" if "D" in states else states[0]


#: How long a sweep after a run waits for processes in uninterruptible sleep (s): below the grace a stopped
#: worker has (`_TERM_GRACE_S`), since a worker sweeps as it stops too (without waiting).
ASLEEP_WAIT_S = 0.2


def _kill_marked(marks: str | Sequence[str], asleep_wait_s: float = ASLEEP_WAIT_S) -> int:
    """SIGKILL every process of this user whose environment carries one of `marks` (Linux: ``/proc``); their number.

    Finds what a command left running outside its process group (``setsid``, a double-forked daemon),
    as long as it kept the environment it was started with: not one started with an emptied environment
    (``env -i``, some privilege-changing launchers) or one that rewrote its environment area. Repeats until a
    pass finds none, so that a process forked during the pass is caught by the next.

    A process with a thread in uninterruptible sleep (state ``D``) is not read at once: reading another
    process's environment takes its memory map's lock, which such a thread may hold, and the read would wait
    as long as it sleeps. It is looked at again every 0.05 s for up to `asleep_wait_s` (0: not at all); one
    still asleep then is left alone, and outlives the run if it carries a mark.
    """
    if not os.path.isdir("/proc"):
        return 0
    prefix = f"{RUN_MARK_VARIABLE}=".encode()
    wanted = {m.encode() for m in ([marks] if isinstance(marks, str) else marks)}

    def kill_if_marked(entry: os.DirEntry) -> int:
        try:
            with open(f"/proc/{entry.name}/environ", "rb") as fh:
                environ = fh.read()
        except OSError:  # gone
            return 0
        if any(v.startswith(prefix) and wanted & set(v[len(prefix):].split(b":")) for v in environ.split(b"\0")):
            try:
                os.kill(int(entry.name), signal.SIGKILL)
                return 1
            except OSError:
                pass
        return 0

    killed = 0
    asleep: dict[str, os.DirEntry] = {}
    for _ in range(5):
        found = 0
        for entry in os.scandir("/proc"):
            if not entry.name.isdigit() or int(entry.name) == os.getpid():
                continue
            state = _process_state(entry)
            if state == "D":
                asleep[entry.name] = entry
            elif state is not None:
                asleep.pop(entry.name, None)
                found += kill_if_marked(entry)
        killed += found
        if not found:
            break
    deadline = time.monotonic() + asleep_wait_s
    while asleep and time.monotonic() < deadline:
        time.sleep(0.05)
        for name, entry in list(asleep.items()):
            state = _process_state(entry)
            if state != "D":
                del asleep[name]
                if state is not None:
                    killed += kill_if_marked(entry)
    return killed


# -- deadlines in the calling process -------------------------------------------------


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


# -- the executor interface -----------------------------------------------------------


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


# -- local worker processes -----------------------------------------------------------

_STOP = b""  # an empty message asks a worker to exit
_READY = b"ready"  # a started worker's first message


def _worker_main(conn: Connection, parent_pid: int) -> None:
    """Serve tasks from the parent until it asks to stop or goes away."""
    global _worker_parent_pid
    _worker_parent_pid = parent_pid
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


# -- Dask -----------------------------------------------------------------------------

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


# -- building an executor from options ------------------------------------------------


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


def _parent_pids() -> dict[int, list[int]]:
    """Parent pid -> child pids of every process (Linux ``/proc``; empty elsewhere)."""
    children: dict[int, list[int]] = {}
    try:
        entries = os.listdir("/proc")
    except OSError:
        return children
    for entry in entries:
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as stream:
                    children.setdefault(int(stream.read().rsplit(")", 1)[1].split()[1]), []).append(int(entry))
            except (OSError, ValueError, IndexError):
                continue
    return children


def descendant_pids(root: int, direct: bool = False) -> set[int]:
    """Pids of the processes that `root` started (its children only with `direct`), from ``/proc``.

    Used to check that no worker outlives a killed parent.
    """
    children = _parent_pids()
    if direct:
        return set(children.get(root, []))
    found, todo = set(), [root]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def pid_alive(pid: int) -> bool:
    """Whether process `pid` runs (a zombie, dead but not yet reaped, does not count)."""
    try:
        with open(f"/proc/{pid}/stat") as stream:
            return stream.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False
