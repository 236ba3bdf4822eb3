"""`filmcal wheelrail`: wheel-rail normal contact (S1002 on 60E2/60E1) with or without film."""
from __future__ import annotations

import argparse
import math
from fractions import Fraction
from pathlib import Path

from filmcal._validation import check_positive, check_range
from filmcal.commands._common import print_json

from filmcal.films import ACTIVATION_PRESSURE_MPA as ACTIVATION_MPA


def add_parser(subparsers) -> None:
    """Register the `wheelrail` subcommand."""
    p = subparsers.add_parser(
        "wheelrail",
        help="wheel-rail contact area at a lateral offset, with or without film",
        description="Normal contact of an S1002 wheel on an inclined 60E2 (or 60E1) rail at the "
                    "lateral offset eta (eta = 0: tape circle over the rail's inclined symmetry "
                    "plane; eta > 0 moves the flange towards the gauge corner) under a vertical "
                    "load F, solved as two elastic half-spaces (boundary elements) in the plane "
                    "tangent to the contact, with a Prescale film as springs in series. With a film "
                    "the area is read with the edge-profile fit of the axisymmetric FE "
                    "calibration model (contact_area_mm2); support_area_mm2 is where the pressure "
                    "is positive (the two coincide for hard contact).")
    p.add_argument("--offset-mm", type=float, required=True,
                   help="lateral offset eta in mm (the paper studies -7 to +2; use --offset-mm=-3 "
                        "for negative values)")
    p.add_argument("--force-kn", type=float, required=True,
                   help="vertical wheel load F in kN (the paper: 50 and 100)")
    p.add_argument("--rail", default="60E2",
                   help="rail profile: 60E2 (default), 60E1, or a CSV file y_mm,z_mm in the rail's "
                        "standard coordinates")
    p.add_argument("--wheel", default="S1002",
                   help="wheel profile: S1002 (default) or a CSV file y_mm,z_mm in the wheel's "
                        "standard coordinates")
    film = p.add_mutually_exclusive_group(required=True)
    film.add_argument("--film-modulus-mpa", type=float,
                      help="film Young's modulus E in MPa (HS calibrated: 2800)")
    film.add_argument("--no-film", action="store_true", help="steel on steel, no film")
    p.add_argument("--film-poisson", type=float, default=0.33,
                   help="film Poisson's ratio nu (default 0.33)")
    p.add_argument("--film-thickness-mm", type=float, default=0.09,
                   help="film thickness in mm (default 0.09)")
    p.add_argument("--roughness-ra-um", type=float,
                   help="roughness Ra of the wheel in um (Greenwood-Williamson law at the "
                        "film-wheel interface, or at the wheel-rail interface without film); "
                        "smooth by default")
    p.add_argument("--inclination", default="1/40",
                   help="rail inclination as a fraction or a number, e.g. 1/40 (default), 1/20, "
                        "0.025, or 0 for an upright rail")
    p.add_argument("--wheel-radius-mm", type=float, default=460.0,
                   help="wheel rolling radius at the tape circle in mm (default 460)")
    p.add_argument("--grid-mm", type=float, default=0.1,
                   help="cell size of the contact grid in mm (default 0.1, the film's resolution)")
    p.add_argument("--film-type", choices=sorted(ACTIVATION_MPA),
                   help="also report the area where the pressure exceeds this film's activation "
                        "pressure (MS 10, HS 50, HHS 130 MPa)")
    p.add_argument("--plot", metavar="PNG",
                   help="draw the pressure map with the contact outline into a PNG file")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def parse_inclination(text: str) -> float:
    """Rail inclination from '1/40', '0.025' or '0' (ValueError naming the option otherwise)."""
    try:
        value = float(Fraction(str(text).strip()))
    except (ValueError, ZeroDivisionError):
        raise ValueError(f"inclination {text!r} is not a number or a fraction like 1/40") from None
    return check_range("inclination", value, 0.0, 0.2, low_open=False)


def _profile(name: str, kind: str):
    from filmcal.wheelrail.profiles import get_profile, load_profile_csv

    if name.lower().endswith(".csv") or Path(name).is_file():
        return load_profile_csv(name, kind=kind)
    profile = get_profile(name)
    if profile.kind != kind:
        raise ValueError(f"{kind} must be a {kind} profile, got the {profile.kind} profile {name!r}")
    return profile


def plot_pressure_map(result, path: str | Path) -> None:
    """Pressure map in track coordinates with the fitted and positive-pressure outlines."""
    import numpy as np
    from matplotlib.figure import Figure

    grid = result.grid
    x = grid.x_mm
    y = result.grid_track_y_mm
    p = np.ma.masked_less_equal(result.pressure_mpa, 0.0)
    fig = Figure(figsize=(6.4, 5.2), layout="constrained")
    ax = fig.add_subplot()
    mesh = ax.pcolormesh(y, x, p, shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="pressure (MPa)")
    for k, ring in enumerate(result.outline_mm):
        ax.plot(ring[:, 1], ring[:, 0], "-", color="black", lw=1.0,
                label="contact outline (FE edge reading)" if k == 0 else None)
    for k, ring in enumerate(result.support_outline_mm):
        ax.plot(ring[:, 1], ring[:, 0], ":", color="tab:red", lw=1.0,
                label="pressure > 0" if k == 0 else None)
    ax.set_aspect("equal")
    ax.set_xlabel("y (mm), track frame, field side positive")
    ax.set_ylabel("x (mm), along the rail")
    film = "no film" if result.film is None else f"film E = {result.film.modulus_mpa:g} MPa"
    ax.set_title(f"{result.placement.wheel.name} on {result.placement.rail.name}, "
                 f"eta = {result.offset_mm:g} mm, F = {result.force_n / 1e3:g} kN, {film}\n"
                 f"A = {result.area_mm2:.1f} mm2, p_max = {result.max_pressure_mpa:.0f} MPa",
                 fontsize=9)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.6)
    fig.savefig(path, dpi=150)


def run(args: argparse.Namespace) -> int:
    """Solve the case and print the result."""
    from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, contact_modulus_mpa
    from filmcal.wheelrail.interface import FilmLayer, GreenwoodWilliamsonLaw
    from filmcal.wheelrail.wheelrail import solve_wheel_rail

    force_n = 1e3 * check_positive("force_kn", args.force_kn)
    inclination = parse_inclination(args.inclination)
    film = None if args.no_film else FilmLayer(args.film_modulus_mpa, args.film_poisson,
                                               args.film_thickness_mm)
    roughness = None
    if args.roughness_ra_um is not None:
        e_star = contact_modulus_mpa() if film is None else contact_modulus_mpa(
            film.modulus_mpa, film.poisson, STEEL_MODULUS_MPA, STEEL_POISSON)
        roughness = GreenwoodWilliamsonLaw(args.roughness_ra_um, e_star)
    result = solve_wheel_rail(args.offset_mm, force_n, wheel=_profile(args.wheel, "wheel"),
                              rail=_profile(args.rail, "rail"), rail_inclination=inclination,
                              nominal_radius_mm=args.wheel_radius_mm, film=film,
                              roughness=roughness, grid_mm=args.grid_mm)
    out = result.summary()
    if args.roughness_ra_um is not None:
        out["roughness_ra_um"] = args.roughness_ra_um
    if args.film_type:
        level = ACTIVATION_MPA[args.film_type]
        out["imprint_area_mm2"] = result.contact.area_above_mm2(level)
        out["activation_pressure_mpa"] = level
    if args.plot:
        plot_pressure_map(result, args.plot)
    if args.json:
        print_json(out)
        return 0 if result.converged else 1
    film_text = "no film" if film is None else f"film E = {film.modulus_mpa:g} MPa, nu = {film.poisson:g}"
    print(f"{out['wheel']} on {out['rail']} (inclination {inclination:g}), eta = {result.offset_mm:g} mm, "
          f"F = {force_n / 1e3:g} kN, {film_text}")
    print(f"contact area     {result.area_mm2:.2f} mm2   (pressure > 0: {result.support_area_mm2:.2f} mm2)")
    if result.hertz is not None:
        note = "applies" if result.hertz_like else "does not apply here"
        print(f"local Hertz      {result.hertz.area_mm2:.2f} mm2 ({note})")
    print(f"max pressure     {result.max_pressure_mpa:.1f} MPa")
    print(f"patches          {result.n_patches}, centroid y = {result.centroid_y_mm:.2f} mm "
          f"(rail {result.centroid_rail_y_mm:.2f}, wheel {result.centroid_wheel_y_mm:.2f}), "
          f"contact angle {math.degrees(result.contact_angle_rad):.2f} deg")
    if args.film_type:
        print(f"imprint area     {out['imprint_area_mm2']:.2f} mm2 "
              f"(pressure > {out['activation_pressure_mpa']:g} MPa)")
    state = "converged" if result.converged else "NOT converged"
    print(f"{state}, {result.elapsed_s:.3f} s")
    return 0 if result.converged else 1
