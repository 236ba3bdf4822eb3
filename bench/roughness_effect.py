"""What roughness does to the imprint: a rough wheel (and a roughened flat) against each film.

Prints, for each film at its calibrated modulus, the imprint area with a smooth
and a rough (Ra 1.5 um) steel surface on the film, and their ratio:

* wheel-rail, S1002 on 60E2 (1:40), eta = -5, -3, 0 mm, 50 and 100 kN;
* sphere-on-flat, R450 on a roughened flat, 50 and 100 kN.

``imprint`` is what the imprint model (default activation) reads on the nominal
pressure field; ``spots`` is the area of the coloured spots, the model's stain
probability averaged over the asperity pressures at each nominal pressure.
The laws' parameters and their sources are printed first.

Usage::

    OMP_NUM_THREADS=1 python3 bench/roughness_effect.py [--imprint activation] [--large-strain]
        [--offsets -5,-3,0] [--loads 50,100] [--ra-um 1.5] [--json out.json]

Film moduli: the posterior medians of the current study (MS 768, HS 2739,
HHS 6291 MPa, nu 0.33); film facts (activation pressure, thickness) from
the film registry.
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from filmcal.contact.imprint import get_imprint_model
from filmcal.contact.roughness import (PET_HARDNESS_MPA, WHEEL_SURFACE_DEFAULTS, RoughSurface,
                                       rough_contact_law)
from filmcal.films import get_film
from filmcal.wheelrail.halfspace import sphere_on_flat_contact
from filmcal.contact.laws import FilmLayer, film_law
from filmcal.wheelrail.wheelrail import WheelRailModel

#: Posterior medians of the film moduli in the current study (MPa).
CALIBRATED_MODULUS_MPA = {"MS": 768.0, "HS": 2739.0, "HHS": 6291.0}


def _areas(contact, model, film_type, law) -> tuple[float, float]:
    imprint = model.area_mm2(contact.grid.x_mm, contact.grid.y_mm, contact.pressure_mpa, film_type)
    if law is None:
        return imprint, imprint
    p = contact.pressure_mpa
    frac = law.expected_stain(lambda q: model.stain_probability(q, film_type), p[p > 0.0])
    return imprint, float(frac.sum() * contact.grid.cell_area_mm2)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--imprint", default="activation")
    ap.add_argument("--large-strain", action="store_true")
    ap.add_argument("--offsets", default="-5,-3,0")
    ap.add_argument("--loads", default="50,100")
    ap.add_argument("--ra-um", type=float, default=1.5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--hardness-mpa", type=float, default=PET_HARDNESS_MPA,
                    help="asperity pressure cap (a sensitivity; default the PET value)")
    ap.add_argument("--rolloff-um", type=float, help="roll-off wavelength (sensitivity)")
    ap.add_argument("--size-um", type=float, help="periodic cell side (sensitivity)")
    ap.add_argument("--rms-slope", type=float, help="RMS slope, sets the cut-off (sensitivity)")
    ap.add_argument("--no-sphere", action="store_true", help="wheel-rail only")
    ap.add_argument("--json", metavar="PATH")
    args = ap.parse_args(argv)
    offsets = [float(v) for v in args.offsets.split(",")]
    loads = [float(v) for v in args.loads.split(",")]
    model = get_imprint_model(args.imprint)
    d = WHEEL_SURFACE_DEFAULTS
    surface = RoughSurface.synthetic(
        ra_um=args.ra_um, hurst=d["hurst"], n=d["n"], seed=args.seed, rms_slope=args.rms_slope,
        rolloff_wavelength_um=args.rolloff_um or d["rolloff_wavelength_um"],
        size_um=args.size_um or d["size_um"])
    print("Rough surface:", surface.description)
    print(f"  Ra {surface.ra_um:.3f} um, RMS {surface.rms_um:.3f} um, RMS slope "
          f"{surface.rms_slope:.3f}, seed {args.seed}")
    print("  sources:", d["sources"])
    print(f"  asperity pressure cap H = {args.hardness_mpa:g} MPa (default {PET_HARDNESS_MPA:g}: "
          "Tabor H = 3 Y, Y = 100 MPa for biaxially oriented PET)")
    print(f"  imprint model: {args.imprint}; film kinematics: "
          f"{'large strain' if args.large_strain else 'small strain'}")
    laws = {}
    for name, e in CALIBRATED_MODULUS_MPA.items():
        ft = get_film(name)
        t0 = time.perf_counter()
        law = rough_contact_law(surface, e, ft.poisson, ft.thickness_mm,
                                hardness_mpa=args.hardness_mpa)
        laws[name] = law
        print(f"\nLaw for {name} (E {e:g} MPa, nu {ft.poisson:g}, t {ft.thickness_mm:g} mm, "
              f"activation {ft.activation_pressure_mpa:g} MPa), {time.perf_counter() - t0:.1f} s:")
        print("   p_nom MPa  closure um  contact  plastic  above activation")
        for step in law.steps[::4] + [law.steps[-1]]:
            above = law.fraction_above(ft.activation_pressure_mpa,
                                       np.array([step.nominal_pressure_mpa]))[0]
            print(f"   {step.nominal_pressure_mpa:9.3g}  {1e3 * step.closure_mm:10.3f}  "
                  f"{step.contact_fraction:7.3f}  {step.plastic_fraction:7.3f}  {above:8.3f}")
        print(f"   hard above {law.saturation_pressure_mpa:.3g} MPa")

    rows = []
    wr = WheelRailModel()
    print("\nWheel-rail S1002 / 60E2 (1:40), Ra on the wheel, film-wheel interface")
    print(" film  eta mm  F kN  smooth mm2  rough mm2  growth %  spots mm2  spots/smooth %  s")
    for name, e in CALIBRATED_MODULUS_MPA.items():
        ft = get_film(name)
        film = FilmLayer(e, ft.poisson, ft.thickness_mm)
        for eta in offsets:
            for f_kn in loads:
                t0 = time.perf_counter()
                f0, l0 = film_law(film, None, kinematics="large" if args.large_strain else "small")
                smooth = wr.solve(eta, 1e3 * f_kn, film=f0, roughness=l0)
                f1, l1 = film_law(film, laws[name], kinematics="large" if args.large_strain else "small")
                rough = wr.solve(eta, 1e3 * f_kn, film=f1, roughness=l1)
                a0, _ = _areas(smooth.contact, model, ft, None)
                a1, s1 = _areas(rough.contact, model, ft, laws[name])
                row = {"case": "wheel-rail", "film": name, "modulus_mpa": e, "offset_mm": eta,
                       "force_kn": f_kn, "smooth_mm2": a0, "rough_mm2": a1, "spots_mm2": s1,
                       "growth_pct": 100.0 * (a1 / a0 - 1.0),
                       "spots_vs_smooth_pct": 100.0 * (s1 / a0 - 1.0),
                       "converged": bool(smooth.converged and rough.converged)}
                rows.append(row)
                print(f" {name:4s}  {eta:6g}  {f_kn:4g}  {a0:10.2f}  {a1:9.2f}  {row['growth_pct']:8.2f}"
                      f"  {s1:9.2f}  {row['spots_vs_smooth_pct']:14.2f}  {time.perf_counter() - t0:.1f}")

    if args.no_sphere:
        return _finish(args, rows, laws)
    print("\nSphere-on-flat R450, roughened flat (same surface), film-flat interface")
    print(" film  F kN  smooth mm2  rough mm2  growth %  spots mm2  spots/smooth %")
    for name, e in CALIBRATED_MODULUS_MPA.items():
        ft = get_film(name)
        film = FilmLayer(e, ft.poisson, ft.thickness_mm)
        for f_kn in loads:
            f0, l0 = film_law(film, None, kinematics="large" if args.large_strain else "small")
            smooth = sphere_on_flat_contact(450.0, 1e3 * f_kn, film=f0, law=l0)
            f1, l1 = film_law(film, laws[name], kinematics="large" if args.large_strain else "small")
            rough = sphere_on_flat_contact(450.0, 1e3 * f_kn, film=f1, law=l1)
            a0, _ = _areas(smooth, model, ft, None)
            a1, s1 = _areas(rough, model, ft, laws[name])
            row = {"case": "sphere-on-flat", "film": name, "modulus_mpa": e, "sphere_radius_mm": 450.0,
                   "force_kn": f_kn, "smooth_mm2": a0, "rough_mm2": a1, "spots_mm2": s1,
                   "growth_pct": 100.0 * (a1 / a0 - 1.0),
                   "spots_vs_smooth_pct": 100.0 * (s1 / a0 - 1.0),
                   "converged": bool(smooth.converged and rough.converged)}
            rows.append(row)
            print(f" {name:4s}  {f_kn:4g}  {a0:10.2f}  {a1:9.2f}  {row['growth_pct']:8.2f}  "
                  f"{s1:9.2f}  {row['spots_vs_smooth_pct']:14.2f}")
    return _finish(args, rows, laws)


def _finish(args: argparse.Namespace, rows: list, laws: dict) -> int:
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"rows": rows, "laws": {k: v.describe() for k, v in laws.items()}}, fh,
                      indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
