"""External commands run under a deadline: `run_guarded`, and what it returns.

The command runs in its own process group with a run mark in its environment;
at the deadline, or when the task that started it is cancelled, the group and
everything the mark names are killed. Its output is read back to a cap
(`OUTPUT_CAP_BYTES`, its last bytes) and never held whole in memory.
"""
from __future__ import annotations

import os
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from filmcal._parallel import processes
from filmcal._parallel.executor import _check_timeout
from filmcal._parallel.processes import (RUN_MARK_VARIABLE, _child_groups, _child_lock, _die_with_children,
                                         _kill_marked, _killpg, _parent_alive, _set_parent_death_signal)

#: Most bytes of each output stream (stdout, stderr) of a command that `run_guarded` reads back:
#: the last ones; more is flagged as truncated (`GuardedRun.stdout_truncated`), never held in memory.
OUTPUT_CAP_BYTES = 16 * 2**20
_WAIT_POLL_S = 0.05  # longest sleep between two looks at a running child that has a deadline
_CANCEL_POLL_S = 0.2  # how often a waiting run_guarded asks whether its task was cancelled


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
    in_worker = processes._worker_parent_pid is not None and threading.current_thread() is threading.main_thread()
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
