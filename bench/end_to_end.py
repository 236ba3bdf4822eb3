"""Wall times of the user-facing commands, start-up included, against their targets.

    python bench/end_to_end.py [--study-dir filmcal-study] [--repeats 3]
    python bench/end_to_end.py --pipeline --work-dir /tmp/e2e     # also the pipeline: full, rerun, --quick

``filmcal correct`` (target <= 5 s) is timed in both forms of the contract on
an existing study (run ``filmcal pipeline`` first). With ``--pipeline`` the
full pipeline is run in a new folder (target <= 20 min), run again on the
finished folder (<= 1 min), and ``--quick`` in another new folder (<= 3 min).
Each line prints the median over the repeats, the spread, and the ratio to
the target.
"""
from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

CORRECT_FORMS = {
    "correct, wheel-rail": ["--measured-area-mm2", "150", "--offset-mm=-3", "--force-kn", "100"],
    "correct, sphere-on-flat": ["--sphere-radius-mm", "450", "--force-kn", "75", "--measured-radius-mm", "7.12"],
}


def timed(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    out = subprocess.run(cmd, capture_output=True, text=True)
    elapsed = time.perf_counter() - t0
    if out.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{out.stderr[-2000:]}")
    return elapsed


def report(name: str, times: list[float], target_s: float) -> None:
    med = statistics.median(times)
    print(f"{name:28s} median {med:8.2f} s  (min {min(times):.2f}, max {max(times):.2f}, n={len(times)})  "
          f"target {target_s:g} s  ratio {med / target_s:.2f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study-dir", default="filmcal-study", help="finished study for the correct timings")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--pipeline", action="store_true", help="also time the pipeline (about 10 minutes)")
    ap.add_argument("--work-dir", default="bench-e2e", help="folder for the pipeline's new studies")
    args = ap.parse_args()
    cli = [sys.executable, "-m", "filmcal.cli"]
    if args.pipeline:
        work = Path(args.work_dir)
        shutil.rmtree(work, ignore_errors=True)
        full = [*cli, "pipeline", "--study-dir", str(work / "full")]
        report("pipeline, new study", [timed(full)], 20 * 60)
        report("pipeline, again", [timed(full) for _ in range(args.repeats)], 60)
        report("pipeline --quick, new study", [timed([*cli, "pipeline", "--quick", "--study-dir",
                                                      str(work / "quick")])], 3 * 60)
        args.study_dir = str(work / "full")
    if not Path(args.study_dir).is_dir():
        raise SystemExit(f"no study in {args.study_dir}: run `filmcal pipeline` first (or use --pipeline)")
    for name, form in CORRECT_FORMS.items():
        cmd = [*cli, "correct", "--film", "HS", *form, "--study-dir", args.study_dir, "--json"]
        report(name, [timed(cmd) for _ in range(args.repeats)], 5)


if __name__ == "__main__":
    main()
