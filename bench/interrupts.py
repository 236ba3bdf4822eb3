"""Ctrl-C in every stage of ``filmcal pipeline --quick``: how fast it stops, and what a rerun recomputes.

One study folder; for each stage in turn the pipeline is started (resuming
the folder), interrupted with SIGINT as soon as the stage's first progress
line appears, and the figures recorded: seconds from the signal to the exit,
the exit status, the last stderr line, worker processes left over, and the
artefacts of the study that the run had finished (kept) or that a later run
rewrote (recomputed: a finished artefact must never be). A last run
completes the study.

    python bench/interrupts.py [--study-dir /tmp/bench-interrupts] [--films HS]

Prints one line per stage and a summary; exits 1 if any stage took 2 s or
more to stop, did not exit with 130, or a finished artefact was recomputed.
"""
from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

from filmcal._parallel import descendant_pids, pid_alive

STAGES = ("design", "calibration", "comparison", "verification", "curves", "outlines", "crossval", "report")






def artefacts(study: Path) -> dict[str, str]:
    """Recorded artefacts of the study and when each was written."""
    try:
        return {k: v["written_utc"] + v["sha256"] for k, v in
                json.loads((study / "study.json").read_text())["artefacts"].items()}
    except (OSError, ValueError, KeyError):
        return {}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study-dir", default="/tmp/bench-interrupts")
    ap.add_argument("--films", default="HS")
    args = ap.parse_args()
    study = Path(args.study_dir)
    shutil.rmtree(study, ignore_errors=True)
    cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", args.films, "--workers", "2",
           "--study-dir", str(study), "--progress", "log"]
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    bad = 0
    finished: dict[str, str] = {}
    for stage in STAGES:
        log = study.parent / f"{study.name}-{stage}.err"
        before = artefacts(study)
        with open(log, "w") as err:
            proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
            marker = f"[{stage}]"
            while proc.poll() is None and marker not in log.read_text():
                time.sleep(0.05)
            if proc.poll() is not None:
                print(f"{stage:13s} the run ended before the stage showed (it had nothing left to do)")
                continue
            time.sleep(0.5)  # inside the stage's work
            family = descendant_pids(proc.pid)
            sent = time.monotonic()
            proc.send_signal(signal.SIGINT)
            status = proc.wait(timeout=120)
            stop_s = time.monotonic() - sent
        time.sleep(1.0)
        left = [p for p in family if pid_alive(p)]
        after = artefacts(study)
        rewritten = [k for k, v in finished.items() if after.get(k) != v]
        kept = [k for k in after if before.get(k) != after[k]]
        finished.update(after)
        last = log.read_text().strip().splitlines()[-1]
        ok = stop_s < 2.0 and status == 130 and not left and not rewritten and last.endswith("interrupted")
        bad += not ok
        print(f"{stage:13s} stopped in {stop_s:5.2f} s, exit {status}, last line {last!r}, workers left {len(left)}, "
              f"artefacts kept {len(kept)}, finished artefacts recomputed {len(rewritten)}")
    final = subprocess.run(cmd, capture_output=True, text=True)
    after = artefacts(study)
    rewritten = [k for k, v in finished.items() if after.get(k) != v]
    bad += final.returncode != 0 or bool(rewritten)
    print(f"completion run: exit {final.returncode}, finished artefacts recomputed {len(rewritten)} of "
          f"{len(finished)}, new {len(set(after) - set(finished))}")
    print(f"{'all stages stop within 2 s with exit 130 and keep their finished work' if not bad else 'FAILED'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
