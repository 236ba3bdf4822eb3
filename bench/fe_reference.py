#!/usr/bin/env python3
"""The FE model against its second formulation (filmcal.fem.reference).

    scripts/in-venv python bench/fe_reference.py [--films N] [--seed S] [--kinematics large] [--rows FILE]

For a Latin hypercube of films (E 500-10000 MPa, nu 0.25-0.45) on spheres of
R 250, 400 and 600 mm at 20 and 100 kN (and without film at R 250 mm / 15 kN),
the second formulation (biquadratic elements, closing-load edge) is solved at
h = 0.05 and 0.025 mm and extrapolated to h -> 0 (its reading converges at
first order in h). The production model is read at its default mesh (0.1 mm,
FILM_LAYERS film layers) and at 0.025 mm with four layers. Prints, in mm, each
reading minus the extrapolated reference, and the reference's own step from
0.025 mm to the extrapolation (its discretisation error bound).

With ``--kinematics large`` both models' films are neo-Hookean (the production
kernel in the first Piola-Kirchhoff form with selective integration, the
reference's in the second, fully integrated, with Newton at each contact set
and on each closing load); the reference is then solved at h = 0.1 and
0.05 mm (seconds to a minute per case), the production model at its default
mesh and at 0.05 mm with four layers.
"""
import argparse
import json
import sys
import time

import numpy as np
from scipy.stats import qmc

from filmcal.fem import FILM_LAYERS, ContactOptions, Film, MeshSettings, get_model
from filmcal.fem.reference import QuadraticSphereOnFlat
from filmcal.hertz import hertz_radius_mm

SPHERES_MM = (250.0, 400.0, 600.0)
FORCES_N = (20e3, 100e3)
ZONE_MM = 12.0


def film_design(n: int, seed: int) -> list[tuple[float, float]]:
    u = qmc.LatinHypercube(d=2, seed=seed).random(n)
    e = np.exp(np.log(500.0) + u[:, 0] * (np.log(10000.0) - np.log(500.0)))
    nu = 0.25 + 0.20 * u[:, 1]
    return [(float(a), float(b)) for a, b in zip(e, nu)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--films", type=int, default=8, help="films in the design (default 8)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--kinematics", choices=("small", "large"), default="small", help="the films' kinematics")
    ap.add_argument("--rows", metavar="FILE", help="write every row as JSON")
    args = ap.parse_args()
    t0 = time.perf_counter()
    large = args.kinematics == "large"
    films = ([] if large else [None]) + film_design(args.films, args.seed)
    rows = []
    steps = (0.1, 0.05) if large else (0.05, 0.025)
    fine = (0.05, 4) if large else (0.025, 4)
    options = ContactOptions(kinematics=args.kinematics)
    refs: dict = {}

    def reference(h: float, R: float, F: float) -> QuadraticSphereOnFlat:
        """The second formulation on a refined zone of ZONE_MM, or for the large-strain film (whose cost
        grows with the zone) of twice the Hertz radius."""
        zone = min(ZONE_MM, max(5.0, 2.0 * hertz_radius_mm(R, F))) if large else ZONE_MM
        if (h, R, zone) not in refs:
            refs[(h, R, zone)] = QuadraticSphereOnFlat(R, element_size_mm=h, contact_zone_mm=zone)
        return refs[(h, R, zone)]
    for film in films:
        cases = [(250.0, 15e3)] if film is None else [(R, F) for R in SPHERES_MM for F in FORCES_N]
        for R, F in cases:
            E, nu = film if film is not None else (None, 0.33)
            a = [reference(h, R, F).solve(F, E, nu, kinematics=args.kinematics).contact_radius_mm for h in steps]
            ext = 2.0 * a[1] - a[0]
            fe = {}
            for h, layers in ((0.1, FILM_LAYERS), fine):
                res = get_model(R, MeshSettings(element_size_mm=h), film_layers=layers).solve(
                    None if film is None else Film(E, nu), F, options)
                fe[f"{h}/{layers}"] = res.contact_radius_mm
            rows.append({"R": R, "F": F, "E": E, "nu": nu, "kinematics": args.kinematics,
                         f"ref_{steps[0]}": a[0], f"ref_{steps[1]}": a[1], "ref": ext,
                         "hertz": hertz_radius_mm(R, F), "fe_default": fe[f"0.1/{FILM_LAYERS}"],
                         "fe_fine": fe[f"{fine[0]}/{fine[1]}"]})
            r = rows[-1]
            print(f"R{R:4.0f} F{F / 1e3:4.0f} E{E or 0:7.0f} nu{nu:.3f}  ref {ext:.5f} (step {a[1] - ext:+.5f})  "
                  f"default {r['fe_default'] - ext:+.5f}  fine {r['fe_fine'] - ext:+.5f}", flush=True)
    film_rows = [r for r in rows if r["E"] is not None]
    for key in ("fe_default", "fe_fine"):
        d = np.array([r[key] - r["ref"] for r in film_rows])
        rel = np.array([(r[key] - r["ref"]) / r["ref"] for r in film_rows]) * 100
        print(f"{key:10}: mean {d.mean():+.4f} mm, max abs {np.abs(d).max():.4f} mm, max abs {np.abs(rel).max():.3f} %")
    print(f"({time.perf_counter() - t0:.0f} s)")
    if args.rows:
        with open(args.rows, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
