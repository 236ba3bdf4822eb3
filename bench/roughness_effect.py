"""What the bodies' roughness does to each film's imprint, with 90 % bands over the roughness inputs.

Each film at its calibrated median modulus under its preferred imprint model, as the shipped conditioned
draws were made with them (`filmcal/data/roughness_inputs.json`, ``films``). Prints:

* wheel-rail S1002 on 60E2 (1:40), eta and load as given: the growth of the film's imprint (g_f - 1), of
  the contact without film (g_0 - 1) and the change of the correction factor (g_0 / g_f - 1), mean and 90 %
  band over the conditioned draws of the inputs (`load_roughness_inputs`), with the Monte-Carlo error of
  the mean, for the roughness on the wheel, on the rail and on both;
* with ``--prior``: the same over as many prior draws (the prior-predictive table beside the conditioned).

Usage::

    OMP_NUM_THREADS=1 python3 bench/roughness_effect.py [--ra-um 0.5,1.0,1.5] [--bodies wheel,rail,both]
        [--offset-mm -3] [--force-kn 100] [--draws 8] [--prior] [--json out.json]
"""
from __future__ import annotations

import argparse
import json
import time

from filmcal.contact.film import FilmModel
from filmcal.contact.rough_imprint import load_roughness_inputs
from filmcal.correction.roughness import wheel_rail_growth
from filmcal.films import get_film
from filmcal.wheelrail.settings import GRID_MM, NOMINAL_RADIUS_MM, RAIL, RAIL_INCLINATION, WHEEL

def _films() -> tuple:
    """The films of the shipped conditioning: (name, modulus, imprint, kinematics)."""
    from filmcal.contact.rough_imprint import _shipped

    return tuple((f["film"], float(f["modulus_mpa"]), f["imprint"], f["kinematics"]) for f in _shipped()["films"])


FILMS = _films()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ra-um", default="1.5")
    ap.add_argument("--bodies", default="wheel,rail,both")
    ap.add_argument("--offset-mm", type=float, default=-3.0)
    ap.add_argument("--force-kn", type=float, default=100.0)
    ap.add_argument("--draws", type=int, default=8)
    ap.add_argument("--prior", action="store_true", help="also the prior-predictive table")
    ap.add_argument("--json", metavar="PATH")
    args = ap.parse_args(argv)
    settings = dict(wheel=WHEEL, rail=RAIL, rail_inclination=RAIL_INCLINATION, nominal_radius_mm=NOMINAL_RADIUS_MM,
                    grid_mm=GRID_MM)
    sets = {"conditioned": load_roughness_inputs()[:args.draws]}
    if args.prior:
        sets["prior"] = load_roughness_inputs("prior")[:args.draws]
    rows = []
    print(f"S1002 / 60E2 (1:40), eta {args.offset_mm:g} mm, {args.force_kn:g} kN; growth in %, mean [90 %] "
          f"(+- Monte-Carlo error)")
    print(f"{'inputs':12} {'body':6} {'Ra um':>6} {'film':5} {'film imprint':>26} {'no film':>24} "
          f"{'correction factor':>26}  s")
    for which, draws in sets.items():
        for ra in [float(v) for v in args.ra_um.split(",")]:
            for body in args.bodies.split(","):
                wheel = ra if body in ("wheel", "both") else None
                rail = ra if body in ("rail", "both") else None
                for name, modulus, imprint, kinematics in FILMS:
                    t0 = time.perf_counter()
                    g = wheel_rail_growth(FilmModel(get_film(name), imprint, kinematics), modulus, draws,
                                          args.offset_mm, 1e3 * args.force_kn, settings, wheel=wheel, rail=rail)
                    s = g.summary()
                    row = {"inputs": which, "body": body, "ra_um": ra, "film": name, **s}
                    rows.append(row)

                    def cell(key: str) -> str:
                        v = s[key]
                        return (f"{v['mean_pct']:+6.2f} [{v['ci90_pct'][0]:+6.2f},{v['ci90_pct'][1]:+6.2f}]"
                                f"+-{v['mc_error_pct']:.2f}")

                    print(f"{which:12} {body:6} {ra:6.2f} {name:5} {cell('film_growth'):>26} "
                          f"{cell('no_film_growth'):>24} {cell('correction_factor_change'):>26}  "
                          f"{time.perf_counter() - t0:.0f}", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"offset_mm": args.offset_mm, "force_kn": args.force_kn, "rows": rows}, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
