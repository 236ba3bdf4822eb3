"""Progress of long work: one display for a whole run, stage by stage.

Three modes:

``bar``    one tqdm bar per stage on a terminal: the stage, units done of
           total, elapsed and estimated time left (tqdm's own estimate);
``log``    plain lines for files and CI: whenever a unit finishes (at most one
           line per second, and always for the last unit), and a heartbeat at
           least every ``interval_s`` seconds while a stage runs, with units
           done of total, elapsed and the estimated time left;
``quiet``  nothing but warnings.

``auto`` is ``bar`` on a terminal and ``log`` otherwise. Libraries' own bars
(emcee's, the campaign's) stay off inside a run: their work reports here.
Warnings are collected and repeated at the end, in colour on a terminal.

A run of several stages can be given a plan (`Progress.plan`): each stage's
expected cost in seconds, from a cost model of its settings. The run's
display then shows the whole run's share done, advancing with every unit of
inner work a stage reports (`_Stage.update`: FE runs, chains, curve solves,
report sections), and its estimated time left: the planned cost still to do
times the run's speed so far (time taken over the planned cost of the work
done), so the estimate converges as the run proceeds. A stage that found its
work done already (a resumed run) leaves the plan without counting.
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
        self._fraction: float | None = None
        self._bar = None
        if owner.mode == "bar" and owner._run_bar is None:
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=name, unit="unit", file=owner.stream, leave=True,
                             bar_format="{desc:<13} {percentage:3.0f}%|{bar:24}| {n_fmt}/{total_fmt} "
                                        "[{elapsed}<{remaining}] {postfix}")

    def set_total(self, total: int) -> None:
        self.total = int(total)
        if self._bar is not None:
            self._bar.total = self.total
            self._bar.refresh()

    def advance(self, n: int = 1, note: str = "", fraction: float | None = None) -> None:
        """`n` more units finished (`note`: what, shown beside; `fraction`: the stage's share done, when its
        units are not of equal cost)."""
        self.done += n
        if fraction is not None:
            self._fraction = min(max(float(fraction), 0.0), 1.0)
        if note:
            self.note = note
        if self._bar is not None:
            if note:
                self._bar.set_postfix_str(note, refresh=False)
            self._bar.update(n)
        else:
            self.owner._show(self)

    def update(self, fraction: float | None = None, note: str = "") -> None:
        """Inner work: the stage's share done (0-1; default units done over total) and what is running."""
        if fraction is not None:
            self._fraction = min(max(float(fraction), 0.0), 1.0)
        if note:
            self.note = note
        if self._bar is not None:
            self._bar.set_postfix_str(self.note, refresh=True)
        else:
            self.owner._show(self)

    @property
    def fraction(self) -> float:
        """Share of the stage's work done (0-1)."""
        if self._fraction is not None:
            return self._fraction
        return self.done / self.total if self.total else 0.0

    def status(self) -> str:
        elapsed = time.monotonic() - self.started
        text = f"[{self.name}] "
        if self.total:
            text += f"{self.done}/{self.total} done, {_duration(elapsed)} elapsed"
            if 0 < self.done < self.total:
                text += f", about {_duration(elapsed / self.done * (self.total - self.done))} left"
        else:
            text += f"{self.done} done, {_duration(elapsed)} elapsed"
        text += f" ({self.note})" if self.note else ""
        return text + self.owner.run_status()

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
        self._planned: dict[str, float] = {}
        self._finished: list[tuple[float, float]] = []  # (planned s, taken s) of the stages that did their work
        self._run_bar = None
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
        """Close the run's bar, and repeat the warnings at the end, in colour on a terminal (even when quiet)."""
        if self._run_bar is not None:
            self._run_bar.close()
            self._run_bar = None
        if not self.warnings:
            return
        colour = getattr(self.stream, "isatty", lambda: False)()
        for text in self.warnings:
            line = f"warning: {text}"
            self.stream.write((f"\033[1;33m{line}\033[0m" if colour else line) + "\n")
        self.stream.flush()

    # ------------------------------------------------------------ the run
    def plan(self, planned_s: dict[str, float]) -> None:
        """The run's stages in order with their expected cost (s): the display then shows the whole run."""
        self._planned = {k: max(float(v), 0.0) for k, v in planned_s.items()}
        if self.mode == "bar" and self._run_bar is None:
            from tqdm import tqdm

            self._run_bar = tqdm(total=1000, desc="run", file=self.stream, leave=True,
                                 bar_format="{desc:<13} {percentage:3.0f}%|{bar:24}| [{elapsed}] {postfix}")

    def unplan(self, name: str) -> None:
        """A stage found its work done (a resumed run): it leaves the plan and the speed estimate."""
        self._planned[name] = 0.0

    def run_fraction(self) -> float | None:
        """Share of the planned run done (None without a plan)."""
        total = sum(self._planned.values())
        if total <= 0:
            return None
        done = sum(p for p, _ in self._finished)
        stage = self._current
        if stage is not None:
            done += self._planned.get(stage.name, 0.0) * stage.fraction
        return min(done / total, 1.0)

    def run_left_s(self) -> float | None:
        """Estimated time left in the run (s): planned cost still to do, times the speed so far."""
        total = sum(self._planned.values())
        if total <= 0:
            return None
        planned_done = sum(p for p, _ in self._finished)
        taken = sum(t for _, t in self._finished)
        stage = self._current
        if stage is not None:
            planned_done += self._planned.get(stage.name, 0.0) * stage.fraction
            taken += time.monotonic() - stage.started
        speed = taken / planned_done if planned_done > 0.02 * total and taken > 0 else 1.0
        return max(total - planned_done, 0.0) * speed

    def run_status(self) -> str:
        """``; run 43 % done, about 4.2 min left`` (empty without a plan)."""
        f, left = self.run_fraction(), self.run_left_s()
        if f is None:
            return ""
        return f"; run {100 * f:.0f} % done, about {_duration(left)} left"

    def _show(self, stage: _Stage) -> None:
        """Show inner progress: the run's bar, or a log line at most every second."""
        if self._run_bar is not None:
            f = self.run_fraction() or 0.0
            self._run_bar.n = int(round(1000 * f))
            self._run_bar.set_description_str(stage.name, refresh=False)
            self._run_bar.set_postfix_str(f"{stage.done}/{stage.total or '?'} {stage.note}".strip()
                                          + f", about {_duration(self.run_left_s() or 0.0)} left", refresh=True)
        elif self.mode == "log" and (time.monotonic() - stage._last_line >= 1.0
                                     or (stage.total and stage.done == stage.total)):
            stage.line()

    # ------------------------------------------------------------ stages
    @contextlib.contextmanager
    def stage(self, name: str, total: int | None = None) -> Iterator[_Stage]:
        """Show a stage while its body runs; yields the handle to advance."""
        stage = _Stage(self, name, total)
        self._current = stage
        self._start_heartbeat()
        try:
            yield stage
            planned = self._planned.get(name, 0.0)
            if planned > 0:
                self._finished.append((planned, time.monotonic() - stage.started))
        finally:
            self._current = None
            self._stop_heartbeat()
            stage.close()
            if self._run_bar is not None:
                self._show(stage)

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
