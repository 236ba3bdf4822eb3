"""The processes of a worker: native threads, freed memory, the parent's death, marked children.

A pool worker lives no longer than its parent (Linux's parent-death signal, and
a watchdog thread everywhere) and kills the children `run_guarded` started for
it when it goes; those children carry a run mark in their environment, so that
what they started in turn is found and killed too.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os
import signal
import sys
import threading
import time
from collections.abc import Sequence
from typing import Any

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
