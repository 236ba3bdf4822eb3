"""How a run's progress display behaves on a terminal: gaps between advances and the error of its ETA.

Runs a command in a pseudo-terminal (so that ``--progress auto`` draws its
bar), keeps every byte it writes with the time it arrived, and reads back the
run bar of ``filmcal pipeline`` (``<stage> NN%|...| [elapsed] <units> <note>,
about <T> left``) and, in log mode, its ``run NN % done, about T left``.
It prints, measured in that one run:

* the run's length;
* the longest time between two advances of the completed-work counter (the
  run's per-mille of planned work) and between any two updates of the display;
* the ETA's error at 25, 50 and 75 % of the run's length: the time left the
  display showed then, minus the time the run actually took from then on.

    python bench/progress_eta.py -- filmcal pipeline --study-dir /tmp/s --no-report
    python bench/progress_eta.py --json -- filmcal pipeline --quick --study-dir /tmp/q
"""
from __future__ import annotations

import argparse
import fcntl
import json
import os
import pty
import re
import struct
import subprocess
import sys
import termios
import time

BAR = re.compile(r"(\d+)%\|[^|]*\|.*?about ([\d.]+) (s|min|h) left")
LOG = re.compile(r"run (\d+) % done, about ([\d.]+) (s|min|h) left")
UNIT_S = {"s": 1.0, "min": 60.0, "h": 3600.0}


def run_in_terminal(command: list[str], columns: int = 160) -> tuple[list[tuple[float, str]], float, int]:
    """(time, text) of every write of `command` on a pseudo-terminal of `columns`, its length and exit status."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 50, columns, 0, 0))
    start = time.monotonic()
    proc = subprocess.Popen(command, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave, close_fds=True)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # the terminal closed: the command ended
            break
        if not data:
            break
        chunks.append((time.monotonic() - start, data.decode("utf-8", "replace")))
    status = proc.wait()
    os.close(master)
    return chunks, time.monotonic() - start, status


def readings(chunks: list[tuple[float, str]]) -> list[tuple[float, int, float, str]]:
    """(time, percent done, time left shown, the line) of every display update found in the output."""
    out = []
    for t, text in chunks:
        for piece in re.split(r"[\r\n]", text):
            m = BAR.search(piece) or LOG.search(piece)
            if m:
                out.append((t, int(m.group(1)), float(m.group(2)) * UNIT_S[m.group(3)], piece.strip()))
    return out


def summary(reads: list[tuple[float, int, float, str]], length_s: float) -> dict:
    """The figures of one run (see the module notes)."""
    times = [0.0] + [r[0] for r in reads] + [length_s]
    moved = [r for r, prev in zip(reads, [(0.0, -1, 0.0, "start")] + reads) if r[1] != prev[1]]
    advances = [(0.0, "start")] + [(r[0], r[3]) for r in moved] + [(length_s, "end")]
    gap, before = max(((b[0] - a[0], a[1]) for a, b in zip(advances, advances[1:])), key=lambda g: g[0])
    eta = {}
    for q in (0.25, 0.5, 0.75):
        now = q * length_s
        shown = [r[2] for r in reads if r[0] <= now]
        if shown:
            actual = length_s - now
            eta[f"{int(100 * q)}%"] = {"shown_s": round(shown[-1], 1), "actual_s": round(actual, 1),
                                       "error_s": round(shown[-1] - actual, 1),
                                       "error_of_run_pct": round(100 * (shown[-1] - actual) / length_s, 1)}
    return {"length_s": round(length_s, 1), "updates": len(reads),
            "longest_gap_between_counter_advances_s": round(gap, 1), "longest_gap_after": before,
            "longest_gap_between_display_updates_s": round(max(b - a for a, b in zip(times, times[1:])), 1),
            "eta": eta}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], epilog="Put the command after --.")
    p.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    p.add_argument("command", nargs=argparse.REMAINDER, help="the command to run (after --)")
    args = p.parse_args(argv)
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        p.error("give the command to run after --")
    chunks, length, status = run_in_terminal(command)
    result = {"command": command, "exit_status": status, **summary(readings(chunks), length)}
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"{' '.join(command)}: exit {status}, {result['length_s']} s, {result['updates']} display updates")
        print(f"longest time between two advances of the completed-work counter: "
              f"{result['longest_gap_between_counter_advances_s']} s, after: {result['longest_gap_after']} "
              f"(between any two updates: {result['longest_gap_between_display_updates_s']} s)")
        for q, e in result["eta"].items():
            print(f"ETA at {q} of the run: shown {e['shown_s']} s, actual {e['actual_s']} s, error "
                  f"{e['error_s']:+} s ({e['error_of_run_pct']:+} % of the run)")
    return 0 if status == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
