"""Wall time of `filmcal curves` on rough bodies with and without the study's store of rough laws.

`filmcal curves --wheel-roughness-ra-um` first solves each draw's boundary-element laws (against the film and
steel on steel), then the rough growths at every load and offset. The laws are read from the study and kept
there as each is solved (`filmcal.study.core.StudyRoughLaws`): at the pipeline's own Ra they are the pipeline's
laws, and a question asked again, or interrupted and started again, reads them. This script times, on copies of
a finished study, each in a new process:

* ``no store``: the rows as `filmcal.correction.curve_table` gives them without a store (the laws solved into a
  temporary folder, as before 29 Nov 2026), at the pipeline's Ra;
* ``store``: `filmcal curves` at the pipeline's Ra (the pipeline's laws read);
* ``first`` and ``again``: `filmcal curves` at another Ra, twice on one copy (solved and kept, then read).

It prints the times, the ratios no store / store and first / again, and whether the rows with and without the
store agree to the last digit.

Usage::

    python3 bench/rough_curves_store.py --study-dir STUDY [--film HS] [--ra-um 1.5] [--new-ra-um 2.5]
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

NO_STORE = """
import json, sys
from filmcal.correction import curve_table
from filmcal.commands._common import DEFAULT_ROUGHNESS_DRAWS
from filmcal.commands.curves import _rough_configurations
from filmcal.study import Study
from filmcal.study.core import curve_components
import argparse
study = Study(sys.argv[1])
args = argparse.Namespace(wheel_roughness_ra_um=float(sys.argv[3]), rail_roughness_ra_um=None,
                          wheel_roughness_map=None, rail_roughness_map=None, roughness_law=None,
                          roughness_draws=DEFAULT_ROUGHNESS_DRAWS)
components = curve_components(study, sys.argv[2], imprint=None, kinematics=None, loads=None)
rough = _rough_configurations(args, study.roughness_inputs()[0])
print(json.dumps(curve_table(sys.argv[2], components, (-3.0,), (100.0,), rough, None, None)))
"""


def timed(cmd: list[str]) -> tuple[float, str]:
    """Wall time (s) of a whole process and its standard output."""
    start = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr.strip()}")
    return time.perf_counter() - start, p.stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--study-dir", required=True, help="a finished study (filmcal pipeline), copied, not changed")
    ap.add_argument("--film", default="HS")
    ap.add_argument("--ra-um", type=float, default=1.5, help="the pipeline's wheel Ra (default 1.5)")
    ap.add_argument("--new-ra-um", type=float, default=2.5, help="an Ra the study has no laws of (default 2.5)")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="filmcal-bench-") as tmp:
        copies = {}
        for name in ("no store", "store", "new"):
            copies[name] = Path(tmp) / name.replace(" ", "-")
            shutil.copytree(args.study_dir, copies[name])
        def curves(study: Path, ra: float) -> tuple[float, list]:
            seconds, out = timed([sys.executable, "-m", "filmcal.cli", "curves", "--film", args.film,
                                  "--study-dir", str(study), "--offsets-mm=-3", "--forces-kn", "100",
                                  "--wheel-roughness-ra-um", str(ra), "--json", "--progress", "quiet"])
            return seconds, json.loads(out)["rows"]

        t_none, out = timed([sys.executable, "-c", NO_STORE, str(copies["no store"]), args.film, str(args.ra_um)])
        rows_none = json.loads(out)
        t_store, rows_store = curves(copies["store"], args.ra_um)
        t_first, _ = curves(copies["new"], args.new_ra_um)
        t_again, _ = curves(copies["new"], args.new_ra_um)
    from filmcal.commands._common import DEFAULT_ROUGHNESS_DRAWS

    print(f"{args.film}, 100 kN, eta -3 mm, {DEFAULT_ROUGHNESS_DRAWS} draws of the roughness inputs (whole "
          "processes):")
    print(f"  Ra {args.ra_um:g} um (the pipeline's): no store {t_none:6.2f} s, store {t_store:6.2f} s, "
          f"ratio {t_none / t_store:.2f}; rows {'identical' if rows_none == rows_store else 'DIFFER'}")
    print(f"  Ra {args.new_ra_um:g} um (new):          first    {t_first:6.2f} s, again {t_again:6.2f} s, "
          f"ratio {t_first / t_again:.2f}")


if __name__ == "__main__":
    main()
