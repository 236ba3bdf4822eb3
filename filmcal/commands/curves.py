"""`filmcal curves`: wheel-rail correction curves of a film's posterior at any loads and offsets."""
from __future__ import annotations

import argparse
import sys

from filmcal.commands._common import print_json


def _floats(text: str, name: str) -> list[float]:
    """``a,b,c`` or ``start:stop:step`` (stop included) as floats."""
    import numpy as np

    try:
        if ":" in text:
            start, stop, step = (float(x) for x in text.split(":"))
            if step <= 0 or stop < start:
                raise ValueError
            return [float(x) for x in np.round(np.arange(start, stop + step / 2, step), 9)]
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"{name} must be a comma-separated list or start:stop:step (step > 0), got {text!r}") from None


def _measured_law(path: str):
    """A `TabularLaw` from a CSV of closure_um, pressure_mpa."""
    import csv

    from filmcal.wheelrail import TabularLaw

    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    try:
        closure = [float(r["closure_um"]) * 1e-3 for r in rows]
        pressure = [float(r["pressure_mpa"]) for r in rows]
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"roughness_law {path}: needs numeric columns closure_um,pressure_mpa") from None
    return TabularLaw(closure, pressure)


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "curves", help="wheel-rail correction curves with 90 %% credible bands at any loads and offsets",
        description="Propagate a film type's calibrated posterior (from the study folder) through the S1002/60E2 "
                    "wheel-rail model: contact area without film, with film (posterior median and 90 %% band), "
                    "Delta A = A_film - A_0 and the correction factor A_0 / A_film at each (load, offset), smooth "
                    "and optionally rough wheel. The film area is interpolated in log E from solves at five "
                    "posterior quantiles; the interpolation error, checked at two more, is a column beside the "
                    "bands. About 1.3 s per (load, offset) with the smooth wheel; a rough wheel adds its law, about "
                    "45 s for two offsets (measured 2026-11-24 on a full study, 2 cores at load average about 4).")
    p.add_argument("--film", required=True, help="film type: MS, HS or HHS")
    p.add_argument("--forces-kn", default="50,100", help="loads in kN: list or start:stop:step (default 50,100)")
    p.add_argument("--offsets-mm", default="-7:2:1", help="lateral offsets eta in mm (default -7:2:1)")
    p.add_argument("--rough-ra-um", type=float, default=None,
                   help="also a rough wheel of this Ra (um), as a Greenwood-Williamson law")
    p.add_argument("--roughness-law", metavar="CSV",
                   help="also a rough wheel with this measured film-wheel pressure-overclosure law: a CSV with "
                        "columns closure_um,pressure_mpa, both strictly increasing from pressure 0")
    p.add_argument("--loads", help="calibration data: load range in kN, e.g. 50-100 (default: all loads)")
    p.add_argument("--study-dir", default="filmcal-study", help="study folder with the posterior")
    p.add_argument("--model", metavar="IMPRINT/KINEMATICS",
                   help="pin one calibrated model, e.g. activation/small (default: the study's mixture of compared "
                        "models, or its only posterior)")
    p.add_argument("--csv", help="write the curves to this CSV file")
    p.add_argument("--plot", help="write a PNG of the areas with and without film")
    p.add_argument("--json", action="store_true", help="print the rows as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.study import Study

    study = Study(args.study_dir)
    ft = study.film(args.film)
    forces = _floats(args.forces_kn, "forces_kn")
    offsets = _floats(args.offsets_mm, "offsets_mm")
    if not forces or any(not (0 < f < float("inf")) for f in forces):
        raise ValueError(f"forces_kn must be finite and > 0, got {args.forces_kn!r}")
    if not offsets or any(not (-20 <= e <= 10) for e in offsets):
        raise ValueError(f"offsets_mm must lie in [-20, 10] mm, got {args.offsets_mm!r}")
    if args.rough_ra_um is not None and not args.rough_ra_um > 0:
        raise ValueError(f"rough_ra_um must be > 0, got {args.rough_ra_um}")
    from filmcal.correction import CURVE_COLUMNS, curve_rows, wheel_label, write_curves_csv
    from filmcal.study.core import chosen_posteriors, curve_components

    film = ft.name
    chosen = chosen_posteriors(study, film, model=args.model, loads=args.loads)
    components = curve_components(study, film, model=args.model, loads=args.loads)
    wheels = [None] + ([args.rough_ra_um] if args.rough_ra_um else [])
    if args.roughness_law:
        wheels.append(_measured_law(args.roughness_law))
    rows = []
    for wheel in wheels:
        sys.stderr.write(f"[curves] {film}, {wheel_label(wheel)} wheel: {len(forces)} loads x {len(offsets)} "
                         "offsets\n")
        rows += curve_rows(film, components, offsets, forces, wheel)
    if args.csv:
        write_curves_csv(args.csv, rows)
    if args.plot:
        from filmcal.report.figures import plot_area_curves

        plot_area_curves([dict(zip(CURVE_COLUMNS, r)) for r in rows], film).savefig(args.plot, dpi=120)
    if args.json:
        print_json({"film": film, "models": {s["model"]: w for w, _, s in chosen},
                    "posterior_files": [str(p) for _, p, _ in chosen], "columns": list(CURVE_COLUMNS), "rows": rows})
    else:
        print(f"{'wheel':>16} {'F kN':>6} {'eta mm':>7} {'A0 mm2':>8} {'dA median':>9} {'dA 90 %':>17} "
              f"{'A0/A':>7} {'A0/A 90 %':>17} {'interp %':>8}")
        for r in rows:
            print(f"{r[1]:>16} {r[2]:6g} {r[3]:+7g} {r[4]:8.1f} {r[6]:9.1f} [{r[7]:6.1f}, {r[8]:6.1f}] "
                  f"{r[9]:7.4f} [{r[10]:.4f}, {r[11]:.4f}] {100 * r[12]:8.3f}")
    return 0
