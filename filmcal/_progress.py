"""Progress of long work: one display for a whole run, stage by stage.

Three modes:

``bar``    one tqdm bar per stage on a terminal: the stage, units done of
           total, elapsed and estimated time left (tqdm's own estimate);
``log``    plain lines for files and CI: a line when a stage starts, whenever a
           unit finishes (at most one line per second), and a heartbeat at
           least every ``interval_s`` seconds while a stage runs, with units
           done of total, elapsed and the estimated time left;
``quiet``  nothing but warnings.

``auto`` is ``bar`` on a terminal and ``log`` otherwise. Libraries' own bars
(emcee's, the campaign's) stay off inside a run: their work reports here.
Warnings are collected and repeated at the end, in colour on a terminal.
"""
from __future__ import annotations

import contextlib
import sys
import threading
import time
from typing import IO, Iterator

__all__ = ["Progress", "MODES"]

MODES = ("auto", "bar", "log", "quiet")


def _duration(seconds: float) -> str:
    seconds = max(0.0, float(seconds))
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


class _Stage:
    """Units of one stage; ``advance`` after each finished unit."""

    def __init__(self, owner: "Progress", name: str, total: int | None) -> None:
        self.owner, self.name, self.total, self.done = owner, name, total, 0
        self.note = ""
        self.started = time.monotonic()
        self._last_line = 0.0
        self._bar = None
        if owner.mode == "bar":
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=name, unit="unit", file=owner.stream, leave=True,
                             bar_format="{desc:<13} {percentage:3.0f}%|{bar:24}| {n_fmt}/{total_fmt} "
                                        "[{elapsed}<{remaining}] {postfix}")

    def set_total(self, total: int) -> None:
        self.total = int(total)
        if self._bar is not None:
            self._bar.total = self.total
            self._bar.refresh()

    def advance(self, n: int = 1, note: str = "") -> None:
        """`n` more units finished (`note`: what, shown beside)."""
        self.done += n
        if note:
            self.note = note
        if self._bar is not None:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.update(n)
        elif self.owner.mode == "log" and time.monotonic() - self._last_line >= 1.0:
            self.line()

    def status(self) -> str:
        elapsed = time.monotonic() - self.started
        text = f"[{self.name}] "
        if self.total:
            text += f"{self.done}/{self.total} done, {_duration(elapsed)} elapsed"
            if 0 < self.done < self.total:
                text += f", about {_duration(elapsed / self.done * (self.total - self.done))} left"
        else:
            text += f"{self.done} done, {_duration(elapsed)} elapsed"
        return text + (f" ({self.note})" if self.note else "")

    def log(self, text: str) -> None:
        """A message of this stage."""
        self.owner.write(text)

    def line(self) -> None:
        self._last_line = time.monotonic()
        self.owner.write(self.status())

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


class Progress:
    """The progress display of one run.

    Parameters
    ----------
    mode : {"auto", "bar", "log", "quiet"}
    stream : file, optional
        Where to write (default stderr).
    interval_s : float
        Heartbeat of the ``log`` mode: a line at least this often while a stage runs.
    """

    def __init__(self, mode: str = "auto", stream: IO[str] | None = None, interval_s: float = 10.0) -> None:
        if mode not in MODES:
            raise ValueError(f"progress mode must be one of {', '.join(MODES)}, got {mode!r}")
        self.stream = stream or sys.stderr
        if mode == "auto":
            mode = "bar" if getattr(self.stream, "isatty", lambda: False)() else "log"
        self.mode = mode
        self.interval_s = float(interval_s)
        self.warnings: list[str] = []
        self._current: _Stage | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------ output
    def write(self, text: str) -> None:
        """One line (above a live bar), unless quiet."""
        if self.mode == "quiet":
            return
        with self._lock:
            if self.mode == "bar":
                from tqdm import tqdm

                tqdm.write(text, file=self.stream)
            else:
                self.stream.write(text + "\n")
                self.stream.flush()

    def log(self, text: str) -> None:
        """A message of the run (``[stage] ...``)."""
        self.write(text)

    def warn(self, text: str) -> None:
        """A warning: shown now and repeated at the end (`summary`)."""
        self.warnings.append(text)
        self.write(f"warning: {text}")

    def summary(self) -> None:
        """Repeat the warnings at the end, in colour on a terminal (even when quiet)."""
        if not self.warnings:
            return
        colour = getattr(self.stream, "isatty", lambda: False)()
        for text in self.warnings:
            line = f"warning: {text}"
            self.stream.write((f"\033[1;33m{line}\033[0m" if colour else line) + "\n")
        self.stream.flush()

    # ------------------------------------------------------------ stages
    @contextlib.contextmanager
    def stage(self, name: str, total: int | None = None) -> Iterator[_Stage]:
        """Show a stage while its body runs; yields the handle to advance."""
        stage = _Stage(self, name, total)
        self._current = stage
        self._start_heartbeat()
        try:
            yield stage
        finally:
            self._current = None
            self._stop_heartbeat()
            stage.close()

    def _start_heartbeat(self) -> None:
        if self.mode != "log":
            return
        self._stop.clear()

        def beat() -> None:
            while not self._stop.wait(self.interval_s):
                stage = self._current
                if stage is not None and time.monotonic() - stage._last_line >= self.interval_s - 0.05:
                    stage.line()

        self._thread = threading.Thread(target=beat, name="filmcal-progress", daemon=True)
        self._thread.start()

    def _stop_heartbeat(self) -> None:
        if self._thread is not None:
            self._stop.set()
            self._thread.join(timeout=2)
            self._thread = None
