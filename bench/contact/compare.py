"""filmcal's wheel-rail model against the stored CONTACT reference numbers, one table per case set.

For each case of ``tests/data/contact/<set>/<set>.json`` (made by ``bench/contact/make_decks.py``): CONTACT's
area extrapolated at first order in the grid (2 A3 - A2) and its finest grid's peak pressure and contact
angle, beside filmcal's at its default grid, with the differences in per cent.

    python bench/contact/compare.py                 # both sets
    python bench/contact/compare.py --set flange --grid-mm 0.05
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

DATA = Path(__file__).resolve().parents[2] / "tests" / "data" / "contact"
SETS = {"flange": ("flange-60E1-10kN", "60E1"), "layer": ("layer-S1002-60E2", "60E2")}


def compare(name: str, grid_mm: float) -> list[dict]:
    from filmcal.wheelrail.halfspace import FilmLayer
    from filmcal.wheelrail.wheelrail import WheelRailModel

    folder, rail = SETS[name]
    doc = json.loads((DATA / folder / f"{folder}.json").read_text())
    model = WheelRailModel(rail=rail, grid_mm=grid_mm)
    rows = []
    for case_name, c in doc["cases"].items():
        if c.get("prescribed_position"):
            continue  # diagnostic runs with the wheel placed by hand
        f = c["film"]
        film = None if not f else FilmLayer(f["modulus_mpa"], f["poisson"], f["thickness_mm"])
        t = time.perf_counter()
        r = model.solve(c["eta_mm"], c["force_kn"] * 1e3, film=film)
        area = c["extrapolated"]["contact_area_mm2_order1"]
        finest = c["runs"][-1]
        rows.append({"case": case_name, "contact_area_mm2": area, "filmcal_area_mm2": r.area_mm2,
                     "area_diff_pct": 100 * (r.area_mm2 / area - 1),
                     "contact_max_pressure_mpa": finest["max_pressure_mpa"],
                     "filmcal_max_pressure_mpa": r.max_pressure_mpa,
                     "pressure_diff_pct": 100 * (r.max_pressure_mpa / finest["max_pressure_mpa"] - 1),
                     "contact_angle_deg": finest.get("contact_angle_deg"),
                     "filmcal_angle_deg": math.degrees(r.contact_angle_rad), "elapsed_s": time.perf_counter() - t})
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--set", choices=sorted(SETS), action="append", help="case set (default both)")
    p.add_argument("--grid-mm", type=float, default=0.1, help="filmcal's grid (default 0.1, its default)")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = p.parse_args(argv)
    out = {name: compare(name, args.grid_mm) for name in (args.set or sorted(SETS))}
    if args.json:
        print(json.dumps(out, indent=1))
        return 0
    for name, rows in out.items():
        print(f"\n{name}: filmcal at {args.grid_mm:g} mm against CONTACT")
        print(f"{'case':22s} {'A CONTACT':>10s} {'A filmcal':>10s} {'dA %':>7s} {'p CONTACT':>10s} "
              f"{'p filmcal':>10s} {'dp %':>7s} {'angle C / f (deg)':>18s}")
        for r in rows:
            angle = "" if r["contact_angle_deg"] is None else f"{r['contact_angle_deg']:.3f} / {r['filmcal_angle_deg']:.3f}"
            print(f"{r['case']:22s} {r['contact_area_mm2']:10.3f} {r['filmcal_area_mm2']:10.3f} "
                  f"{r['area_diff_pct']:+7.2f} {r['contact_max_pressure_mpa']:10.1f} {r['filmcal_max_pressure_mpa']:10.1f} "
                  f"{r['pressure_diff_pct']:+7.2f} {angle:>18s}")
        print(f"largest |dA| {max(abs(r['area_diff_pct']) for r in rows):.2f} %, largest |dp| "
              f"{max(abs(r['pressure_diff_pct']) for r in rows):.2f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
