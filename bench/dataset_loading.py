"""Loading a lab's dataset: time against the number of rows of one case (repeats numbered on loading).

    python bench/dataset_loading.py [--rows 1000,5000,20000,100000]

Prints the wall time of `filmcal.calibration.load_dataset` per size and the time per row relative to the
smallest size: about 1 for a loader linear in the rows (the numbering of unnumbered repeats was quadratic:
20 000 rows of one case took 20 s).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from filmcal.calibration.datasets import load_dataset


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default="1000,5000,20000,100000")
    args = ap.parse_args(argv)
    sizes = [int(x) for x in args.rows.split(",")]
    per_row = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            path = Path(tmp) / f"rows{n}.csv"
            path.write_text("film,sphere_radius_mm,force_kn,radius_error_mm\n" + "HS,450,75,1.1\n" * n)
            t0 = time.perf_counter()
            data = load_dataset(str(path)).data
            elapsed = time.perf_counter() - t0
            assert len(data) == n and data.repeat.max() == n
            per_row[n] = elapsed / n
            print(f"{n:>8d} rows of one case: {elapsed:7.2f} s, {1e6 * per_row[n]:6.1f} us per row, "
                  f"{per_row[n] / per_row[sizes[0]]:5.2f} x the smallest size's per-row time")
    return 0


if __name__ == "__main__":
    sys.exit(main())
