"""Wall times of the user-facing commands, start-up included, against their targets.

    python bench/end_to_end.py [--study-dir filmcal-study] [--repeats 3]
    python bench/end_to_end.py --pipeline --work-dir /tmp/e2e     # also the pipeline: full, rerun, --quick
    python bench/end_to_end.py --pipeline --quick-only --work-dir /tmp/e2e   # only --quick: new, rerun

``filmcal correct`` (target <= 1 s, start-up included) is timed in both
forms of the contract, as the median of ``--correct-repeats`` (5) whole-process
runs in a row, each line with the child's CPU time (user + system), the number
of modules the form imports (one ``-X importtime`` run), the first run apart
(a wheel-rail correction solves the wheel-rail contact once per (offset,
force) and the study keeps the solved areas, so the first run of a new
configuration is the slow one) and the machine's load average before and
after. It is timed on
an existing study folder (a `filmcal.study.Study` folder with its manifest
``study.json``: run ``filmcal pipeline`` first); it reads the film's recorded
posteriors (the mixture of the compared models when the study compared them)
and never calibrates. With ``--pipeline`` the full pipeline (3 films x 3
imprint models x 2 film kinematics) is run in a new folder (target <= 5 min),
run again on the finished folder (<= 2 s), the pipeline of the paper's own
scope (edge imprint, small-strain film: ``--imprint-models edge --kinematics
small``) in another new folder (<= 3 min), and ``--quick`` in a third
(<= 45 s); with ``--quick-only`` only the ``--quick`` pipeline, new and again,
and ``correct`` is timed on it. Each line prints the median over the repeats,
the spread, the ratio to the target and the load average before and after.
"""
from __future__ import annotations

import argparse
import os
import resource
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


def timed_cpu(cmd: list[str]) -> tuple[float, float]:
    """Wall and CPU time (user + system of the child) of one whole-process run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = timed(cmd)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def import_count(cmd: list[str]) -> int:
    """Modules a command imports (``python -X importtime``, one run)."""
    out = subprocess.run([cmd[0], "-X", "importtime", *cmd[1:]], capture_output=True, text=True)
    return sum(line.startswith("import time:") and "[us]" not in line
               for line in out.stderr.splitlines())


def time_correct(cli: list[str], study_dir: str, repeats: int, target_s: float = 1.0) -> None:
    """Both forms of ``filmcal correct``: median of `repeats` whole-process runs against the target."""
    load = os.getloadavg()
    print(f"filmcal correct on {study_dir}: median of {repeats} whole-process runs, target {target_s:g} s "
          f"(OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}, {os.cpu_count()} CPUs, "
          f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f})", flush=True)
    for name, form in CORRECT_FORMS.items():
        cmd = [*cli, "correct", "--film", "HS", *form, "--study-dir", study_dir, "--json"]
        runs = [timed_cpu(cmd) for _ in range(repeats)]
        wall, cpu = [w for w, _ in runs], [c for _, c in runs]
        med = statistics.median(wall)
        print(f"{name:28s} median {med:6.2f} s wall, {statistics.median(cpu):5.2f} s CPU  (first {wall[0]:.2f} s, "
              f"min {min(wall):.2f}, max {max(wall):.2f})  {import_count(cmd)} imports  target {target_s:g} s  "
              f"ratio {med / target_s:.2f}  {'ok' if med <= target_s else 'OVER'}", flush=True)
    load = os.getloadavg()
    print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}", flush=True)


def report(name: str, run, repeats: int, target_s: float) -> None:
    """Median of `repeats` calls of ``run() -> seconds`` against the target, with the load around them."""
    before = os.getloadavg()[0]
    times = [run() for _ in range(repeats)]
    med = statistics.median(times)
    print(f"{name:28s} median {med:8.2f} s  (min {min(times):.2f}, max {max(times):.2f}, n={len(times)})  "
          f"target {target_s:g} s  ratio {med / target_s:.2f}  {'ok' if med <= target_s else 'OVER'}  "
          f"load average {before:.2f} -> {os.getloadavg()[0]:.2f}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study-dir", default="filmcal-study", help="finished study for the correct timings")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--correct-repeats", type=int, default=5, help="whole-process runs of each correct form")
    ap.add_argument("--pipeline", action="store_true", help="also time the pipelines (about 6 minutes)")
    ap.add_argument("--work-dir", default="bench-e2e", help="folder for the pipeline's new studies")
    ap.add_argument("--quick-only", action="store_true",
                    help="with --pipeline: only the --quick pipeline (new study and again, 1-3 min)")
    args = ap.parse_args()
    cli = [sys.executable, "-m", "filmcal.cli"]
    if args.pipeline:
        work = Path(args.work_dir)
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)  # the pipeline creates its study folder, not missing parents
        quick = [*cli, "pipeline", "--quick", "--study-dir", str(work / "quick")]
        if args.quick_only:
            report("pipeline --quick, new study", lambda: timed(quick), 1, 45)
            report("pipeline --quick, again", lambda: timed(quick), args.repeats, 2)
            args.study_dir = str(work / "quick")
        else:
            full = [*cli, "pipeline", "--study-dir", str(work / "full")]
            paper = [*cli, "pipeline", "--imprint-models", "edge", "--kinematics", "small", "--study-dir",
                     str(work / "paper-scope")]
            report("pipeline, new study", lambda: timed(full), 1, 5 * 60)
            report("pipeline, again", lambda: timed(full), args.repeats, 2)
            report("pipeline, paper's scope (edge, small strain), new study", lambda: timed(paper), 1, 3 * 60)
            report("pipeline --quick, new study", lambda: timed(quick), 1, 45)
            args.study_dir = str(work / "full")
    from filmcal._errors import InputError
    from filmcal.study import Study

    try:
        Study(args.study_dir)  # a study folder with its manifest; never created here
    except InputError as exc:
        raise SystemExit(f"{exc} (or use --pipeline)") from None
    time_correct(cli, args.study_dir, args.correct_repeats)


if __name__ == "__main__":
    main()
