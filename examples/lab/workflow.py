"""A lab's own workflow end to end: its film lot, its sphere-on-flat data, its FE solver, its imprints.

1. calibrate the lot's modulus (``filmcal calibrate``) on the lab's data (``lot.csv``) with the lab's own
   simulator: an input deck rendered from ``deck.inp.tmpl`` into each run's folder, the solver
   (``run_deck.py``, a stand-in for a commercial FE) writing a text results file, and the lab's glue
   (``results_to_json.py``) turning it into the JSON filmcal reads: the contact radius and the pressure
   profile, from which filmcal reads the activation model of the lot (``films.toml``) itself;
2. correct the lab's wheel-rail imprints (``measurements.csv``) with ``filmcal correct --batch``.

Usage (from the repository root, filmcal installed)::

    python examples/lab/workflow.py                 # 200 + 100 solver runs and 12 at each of the lot's 7 cases
    python examples/lab/workflow.py --fast          # 20 + 5 runs, 2 at each case, short chains: a check that it runs

Writes ``out/lab/`` (the study, the solver runs' store and folders in ``runs/``, ``corrected.csv``); a second
run reuses every finished solver run and the posterior. Without ``--run-store`` the runs would go to the user's
cache, ``~/.cache/filmcal/runs``, shared by every study of the same solver and settings.
"""
from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fast", action="store_true", help="20 + 5 solver runs, 2 at each case, and short chains")
    ap.add_argument("--out-dir", default="out/lab")
    ap.add_argument("--workers", default="2")
    args = ap.parse_args(argv)
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    filmcal = [sys.executable, "-m", "filmcal.cli"]
    command = (f"{sys.executable} {HERE / 'run_deck.py'} deck.inp results.txt && "
               f"{sys.executable} {HERE / 'results_to_json.py'} results.txt")
    sizes = ["--train-runs", "20", "--test-runs", "5", "--max-steps", "2000"] if args.fast else []
    calibrate = filmcal + ["calibrate", "--film", "LAB7", "--films-file", str(HERE / "films.toml"),
                           "--data", str(HERE / "lot.csv"), "--imprint-model", "activation", "--kinematics", "small",
                           "--simulator-command", command, "--template-file", str(HERE / "deck.inp.tmpl"),
                           "--timeout-s", "600", "--study-dir", str(out / "study"), "--run-store", str(out / "runs"),
                           "--workers", args.workers,
                           "--json", *sizes]
    print("1. calibrating LAB7 on the lab's data with the lab's solver ...", flush=True)
    result = json.loads(subprocess.run(calibrate, check=True, capture_output=True, text=True).stdout)
    e = result["modulus_mpa"]
    print(f"   E = {e['median']:.0f} MPa, 90 % [{e['ci90'][0]:.0f}, {e['ci90'][1]:.0f}] "
          f"(the data were made at 2200 MPa); surrogate held-out rms "
          f"{result['surrogate_validation']['radius_rms_error_mm']:.4f} mm; posterior {result['posterior_file']}")
    print("2. correcting the lab's wheel-rail imprints ...", flush=True)
    corrected = out / "corrected.csv"
    p = subprocess.run(filmcal + ["correct", "--study-dir", str(out / "study"), "--batch", str(HERE / "measurements.csv"),
                                  "--out", str(corrected), "--progress", "quiet"], capture_output=True, text=True)
    if p.returncode not in (0, 1):
        sys.stderr.write(p.stderr)
        return p.returncode
    with open(corrected, newline="") as fh:
        for row in csv.DictReader(line for line in fh if not line.startswith("#")):
            band = (f"{float(row['area_mm2']):7.1f} +/- {float(row['area_std_mm2']):4.1f} mm2"
                    if row["area_mm2"] else "")
            print(f"   {row['force_kn']:>5} kN, eta {row['offset_mm']:>3} mm: measured {row['measured_area_mm2']:>6} "
                  f"mm2 -> {band}  {row['status']}")
    print(f"   {corrected} (and {corrected}.provenance.json)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
