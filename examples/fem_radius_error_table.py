"""The paper's finding in kind: the film's radius error a - a_Hertz at the ten
(R, F) cases of Table 1 for film moduli E = 1000, 2000, 2800, 4000 MPa
(nu = 0.33), under two interface settings and both film kinematics, beside
the measured errors of Table 1 (MS, HS, HHS).

    python examples/fem_radius_error_table.py [--out-dir out/fem_table]

Writes radius_error_table.csv and radius_error_table.md.
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

from filmcal.calibration.datasets import load_table1
from filmcal.fem import ContactOptions, Film, get_model

MODULI_MPA = (1000.0, 2000.0, 2800.0, 4000.0)
SETTINGS = {
    "frictionless/tied, small strain": ContactOptions(),
    "frictionless/tied, large strain": ContactOptions(kinematics="large"),
    "friction 0.4 both, small strain": ContactOptions(sphere_contact="friction", flat_contact="friction"),
    "friction 0.4 both, large strain": ContactOptions(sphere_contact="friction", flat_contact="friction",
                                                      kinematics="large"),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out-dir", default="out/fem_table")
    args = ap.parse_args()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    measured = {}
    for film in ("MS", "HS", "HHS"):
        d = load_table1(film)
        for r, f, e in zip(d.sphere_radius_mm, d.force_n, d.radius_error_mm):
            measured[(film, float(r), float(f))] = float(e)
    cases = sorted({(r, f) for (_, r, f) in measured}, key=lambda c: (c[1], c[0]))
    rows = []
    t0 = time.perf_counter()
    for name, opts in SETTINGS.items():
        for r, f in cases:
            model = get_model(r)
            row = {"setting": name, "sphere_radius_mm": r, "force_kn": f / 1e3}
            for e in MODULI_MPA:
                res = model.solve(Film(e, 0.33), f, opts)
                row[f"E{e:g}"] = res.radius_error_mm if res.converged else float("nan")
            for film in ("MS", "HS", "HHS"):
                row[film] = measured[(film, r, f)]
            rows.append(row)
            print(f"{name:34s} R{r:g} {f / 1e3:g} kN: " + " ".join(f"{row[f'E{e:g}']:+.3f}" for e in MODULI_MPA),
                  flush=True)
    keys = list(rows[0])
    with open(out / "radius_error_table.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    lines = ["| setting | R (mm) | F (kN) | " + " | ".join(f"E={e:g}" for e in MODULI_MPA) + " | MS | HS | HHS |",
             "|---|---|---|" + "---|" * (len(MODULI_MPA) + 3)]
    for row in rows:
        lines.append(f"| {row['setting']} | {row['sphere_radius_mm']:g} | {row['force_kn']:g} | "
                     + " | ".join(f"{row[f'E{e:g}']:+.3f}" for e in MODULI_MPA)
                     + f" | {row['MS']:+.2f} | {row['HS']:+.2f} | {row['HHS']:+.2f} |")
    (out / "radius_error_table.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {out}/radius_error_table.csv and .md in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
