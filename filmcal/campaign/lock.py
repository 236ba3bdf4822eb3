"""One writer per campaign store: an OS file lock beside the store.

`StoreLock` takes an exclusive ``flock`` on ``<store>.lock`` for as long as a
campaign runs, and writes into that file who holds it (pid, host, command,
start time). The operating system releases the lock when the holder exits,
however it exits (SIGKILL included), so a stale lock never blocks a resume.
A second campaign on the same store is refused at once with
`StoreBusyError`, whose message says who holds the lock; or, given a
``wait_s``, waits for the holder to finish (a study on a shared run store:
it then reuses what the holder computed instead of computing it again).

The lock file is named after the store's real path (symbolic links and ``..`` resolved), and an
existing store file is locked too, on its inode: two names of one file (a hard link, another mount)
reach the same lock. ``flock`` locks are independent of the POSIX record locks SQLite takes, so this
does not interfere with SQLite. ``flock`` locks are reliable on local file systems; on network file systems
(NFS) their behaviour depends on the server, so keep stores on a local disk.
"""
from __future__ import annotations

import fcntl
import json
import os
import socket
import sys
import time
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from filmcal._errors import InputError

__all__ = ["StoreBusyError", "LockHolder", "StoreLock", "lock_path_for"]


class StoreBusyError(InputError):
    """Another process holds the store's lock (it is running a campaign on it)."""


@dataclass(frozen=True)
class LockHolder:
    """Who holds a store's lock.

    Attributes
    ----------
    pid : int
    host : str
    command : str
        The holder's command line.
    started_at : str
        ISO 8601 UTC time at which it took the lock.
    """

    pid: int
    host: str
    command: str
    started_at: str

    def describe(self) -> str:
        """One line: ``pid 123 on host since T (command)``."""
        return f"pid {self.pid} on {self.host} since {self.started_at} ({self.command})"


def lock_path_for(store_path: str | os.PathLike) -> Path:
    """The lock file of a store: ``<store>.lock`` beside the file itself.

    Named after the store's real path, so that two campaigns reaching one store through different paths (a
    symbolic link, ``..``) take the same lock.
    """
    path = Path(os.path.realpath(store_path))
    return path.with_name(path.name + ".lock")


def _read_holder(fd: int) -> LockHolder | None:
    try:
        text = os.pread(fd, 65536, 0).decode("utf-8", "replace")
        data = json.loads(text)
        return LockHolder(int(data["pid"]), str(data["host"]), str(data["command"]), str(data["started_at"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None


class StoreLock:
    """An exclusive lock on a campaign store, held by one process at a time.

    Parameters
    ----------
    store_path : path-like
        The store; the lock file is ``<store>.lock`` beside it.
    command : str, optional
        What the holder is doing, shown to a process that is refused
        (default: this process's command line).
    wait_s : float
        How long to wait for a holder to release the lock before refusing (0: refuse at once).
    on_wait : callable, optional
        Called once, with the holder (or None if unknown), when the lock is busy and this process waits.

    Examples
    --------
    >>> with StoreLock("runs.sqlite"):  # doctest: +SKIP
    ...     ...  # the only writer of runs.sqlite
    """

    def __init__(self, store_path: str | os.PathLike, command: str | None = None, *, wait_s: float = 0.0,
                 on_wait=None) -> None:
        self.store_path = Path(store_path)
        self.path = lock_path_for(store_path)
        self.command = command if command is not None else " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])
        self.wait_s = max(0.0, float(wait_s))
        self.on_wait = on_wait
        self._fd: int | None = None
        self._store_fd: int | None = None

    @property
    def held(self) -> bool:
        """True while this object holds the lock."""
        return self._fd is not None

    def acquire(self) -> "StoreLock":
        """Take the lock, or refuse (at once, or after waiting ``wait_s`` for the holder).

        Raises
        ------
        StoreBusyError
            If another process holds it (past ``wait_s``); the message names that process.
        filmcal._errors.InputError
            If the lock file cannot be created (folder missing or read-only).
        """
        if self._fd is not None:
            return self
        try:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise InputError(f"--store {self.store_path}: cannot create the lock file {self.path} "
                             f"({exc.strerror or exc})") from None
        deadline = time.monotonic() + self.wait_s
        store_fd = None
        try:
            self._flock_until(fd, deadline, fd)
            try:  # the store itself, on its inode: another name of the same file takes the same lock
                store_fd = os.open(self.store_path, os.O_RDONLY | os.O_CLOEXEC | os.O_NONBLOCK)
            except FileNotFoundError:
                pass  # a new store: nobody else can reach it under another name yet
            if store_fd is not None:
                self._flock_until(store_fd, deadline, fd)
        except BlockingIOError:
            holder = self._busy_holder(fd) if store_fd is None else None
            self._close(fd, store_fd)
            who = (holder.describe() if holder else "another process" if store_fd is None
                   else "another process, under another name of the same file (a hard link)")
            raise StoreBusyError(f"campaign store {self.store_path} is in use by {who}; "
                                 "wait for it to finish or stop it, then run again") from None
        except OSError as exc:  # the lock file's flock, or the store's open or flock
            self._close(fd, store_fd)
            raise InputError(f"--store {self.store_path}: cannot lock it ({exc.strerror or exc})") from None
        except BaseException:  # an interrupt while waiting, or the waiting note failing: nothing left open
            self._close(fd, store_fd)
            raise
        self._store_fd = store_fd
        holder = LockHolder(os.getpid(), socket.gethostname(), self.command,
                            datetime.now(timezone.utc).isoformat(timespec="seconds"))
        data = json.dumps(holder.__dict__).encode()
        os.ftruncate(fd, 0)
        os.pwrite(fd, data, 0)
        self._fd = fd
        return self

    def _flock_until(self, fd: int, deadline: float, holder_fd: int) -> None:
        """An exclusive flock on fd, waiting until the deadline (BlockingIOError past it)."""
        told = False
        while True:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                return
            except BlockingIOError:
                if time.monotonic() >= deadline:
                    raise
                if not told and self.on_wait is not None:
                    self.on_wait(self._busy_holder(holder_fd))
                told = True
                time.sleep(0.2)

    @staticmethod
    def _close(*fds: int | None) -> None:
        for fd in fds:
            if fd is not None:
                os.close(fd)

    @staticmethod
    def _busy_holder(fd: int) -> LockHolder | None:
        for _ in range(20):  # the holder may be writing its details right now
            holder = _read_holder(fd)
            if holder is not None:
                return holder
            time.sleep(0.01)
        return None

    def release(self) -> None:
        """Clear the holder's details and release the lock (the file stays)."""
        if self._fd is None:
            return
        fd, self._fd = self._fd, None
        try:
            os.ftruncate(fd, 0)
        except OSError:
            pass
        fcntl.flock(fd, fcntl.LOCK_UN)
        self._close(fd, self._store_fd)  # closing the store's descriptor releases its flock
        self._store_fd = None

    def holder(self) -> LockHolder | None:
        """The details written by the current holder, if any (without taking the lock)."""
        try:
            fd = os.open(self.path, os.O_RDONLY | os.O_CLOEXEC)
        except OSError:
            return None
        try:
            return _read_holder(fd)
        finally:
            os.close(fd)

    def running_holder(self) -> LockHolder | None:
        """Who holds the lock right now, without touching it; None if nobody does.

        Reads the kernel's table of file locks (``/proc/locks``, Linux), so it
        never competes with a campaign that is starting. Where that table is
        not available, the details written by the last holder are returned
        if the file has any (a holder that was killed leaves them behind).
        """
        try:
            info = os.stat(self.path)
        except OSError:
            return None
        try:
            with open("/proc/locks") as stream:
                table = stream.read().splitlines()
        except OSError:
            return self.holder()
        device = f"{os.major(info.st_dev):02x}:{os.minor(info.st_dev):02x}:{info.st_ino}"
        for line in table:
            fields = line.split()
            # "1: FLOCK  ADVISORY  WRITE 1234 fd:01:567 0 EOF"; a blocked waiter reads "1: -> FLOCK ..."
            if len(fields) >= 6 and fields[1] == "FLOCK" and fields[5] == device:
                return self.holder() or LockHolder(int(fields[4]), "?", "?", "?")
        return None

    def __enter__(self) -> "StoreLock":
        return self.acquire()

    def __exit__(self, *exc_info: object) -> None:
        self.release()
