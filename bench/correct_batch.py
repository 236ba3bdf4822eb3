"""A day's imprints in one process against one process each: ``filmcal correct --batch`` on a finished study.

Writes 100 wheel-rail measurements (5 offsets x 2 loads x 10 areas, two of them bad: a non-numeric load and
an implausible area), corrects them with one ``filmcal correct --batch`` and with 100 separate ``filmcal
correct --json`` processes, checks that every good row's answer is the single process's to the digit and that
the bad rows are marked (exit 1), and prints both wall times and their ratio. Run it on a study whose
wheel-rail solves are already kept (a second run), as a lab's day of corrections would be.

Usage::

    python bench/correct_batch.py --study-dir filmcal-study [--film HS] [--singles 100]
"""
from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study-dir", required=True)
    ap.add_argument("--film", default="HS")
    ap.add_argument("--singles", type=int, default=100, help="how many rows to also run one process each")
    args = ap.parse_args(argv)
    cli = [sys.executable, "-m", "filmcal.cli", "correct", "--study-dir", args.study_dir]
    rows = [[args.film, f"{force:g}", f"{area:g}", f"{eta:g}"] for force in (50, 100)
            for eta in (-5.0, -4.0, -3.0, -2.0, -1.0) for area in [90 + 8 * k for k in range(10)]]
    rows[13][1] = "abc"
    rows[57][2] = "1e9"
    with tempfile.TemporaryDirectory() as tmp:
        src, out = Path(tmp) / "day.csv", Path(tmp) / "day-corrected.csv"
        with open(src, "w", newline="") as fh:
            csv.writer(fh).writerows([["film", "force_kn", "measured_area_mm2", "offset_mm"], *rows])
        subprocess.run(cli + ["--batch", str(src), "--out", str(out), "--progress", "quiet"], capture_output=True)
        t0 = time.perf_counter()
        p = subprocess.run(cli + ["--batch", str(src), "--out", str(out), "--progress", "quiet"],
                           capture_output=True, text=True)
        batch_s = time.perf_counter() - t0
        with open(out, newline="") as fh:
            done = list(csv.DictReader(fh))
        failed = [k for k, r in enumerate(done) if r["status"].startswith("failed")]
        print(f"batch: {len(rows)} rows in {batch_s:.2f} s, exit {p.returncode}, failed rows {failed}")
        singles, equal, t0 = 0, 0, time.perf_counter()
        for k, (film, force, area, eta) in enumerate(rows[:args.singles]):
            if k in failed:
                continue
            q = subprocess.run(cli + ["--film", film, "--force-kn", force, "--measured-area-mm2", area,
                                      f"--offset-mm={eta}", "--json"], capture_output=True, text=True)
            singles += 1
            answer = json.loads(q.stdout)
            equal += float(done[k]["area_mm2"]) == answer["area_mm2"] and \
                float(done[k]["area_std_mm2"]) == answer["area_std_mm2"]
        single_s = time.perf_counter() - t0
        per = single_s / max(singles, 1)
        print(f"singles: {singles} processes in {single_s:.1f} s ({per:.2f} s each; {per * len(rows):.1f} s for "
              f"{len(rows)}); equal to the batch's rows: {equal} of {singles}")
        print(f"ratio: one process each / batch = {per * len(rows) / batch_s:.1f}")
        return 0 if p.returncode == 1 and failed == [13, 57] and equal == singles else 1


if __name__ == "__main__":
    raise SystemExit(main())
