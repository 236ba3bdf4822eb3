"""`filmcal wheelrail`: wheel-rail normal contact (S1002 on 60E2/60E1) with or without film."""
from __future__ import annotations

import argparse
import math
from fractions import Fraction
from pathlib import Path

from filmcal._validation import check_positive, check_range
from filmcal.commands._common import print_json

#: The imprint models that `--imprint` offers: those of filmcal.contact.imprint (not imported
#: here, to keep the parser quick to build; a test checks that the two agree).
IMPRINT_CHOICES = ("activation", "edge", "capsule")


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
                    "the area is read as the axisymmetric FE model reads its edge (the edge "
                    "imprint model's zero-pressure outline, contact_area_mm2); support_area_mm2 is where the pressure "
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
                      help="film Young's modulus E in MPa (HS, edge reading, small strain: about "
                           "2800, from `filmcal pipeline` on 2026-11-24)")
    film.add_argument("--no-film", action="store_true", help="steel on steel, no film")
    p.add_argument("--film-poisson", type=float,
                   help="film Poisson's ratio nu (default: the film type's, else 0.33)")
    p.add_argument("--film-thickness-mm", type=float,
                   help="film thickness in mm (default: the film type's, else 0.09)")
    p.add_argument("--large-strain", action="store_true",
                   help="film springs follow the large-strain law of the FE's --large-strain film "
                        "(compressible neo-Hookean, compressed oedometrically) instead of the "
                        "linear law t/M")
    rough = p.add_mutually_exclusive_group()
    rough.add_argument("--roughness-ra-um", type=float,
                       help="roughness Ra of the wheel in um: a synthetic self-affine steel surface "
                            "pressed into the film (FFT boundary elements, PET hardness cap) gives "
                            "the film-wheel pressure-closure law; without film, the "
                            "Greenwood-Williamson law at the wheel-rail interface. Smooth by default")
    rough.add_argument("--roughness-law", metavar="CSV",
                       help="a measured film-wheel pressure-closure law: CSV with columns "
                            "closure_um,pressure_mpa")
    rough.add_argument("--roughness-map", metavar="FILE",
                       help="a measured height map of the wheel: CSV of heights (um, see "
                            "--roughness-height-scale) or a greyscale PNG/TIFF (see "
                            "--roughness-height-range-um), with --roughness-pixel-um")
    p.add_argument("--roughness-pixel-um", type=float,
                   help="pixel size of --roughness-map in um")
    p.add_argument("--roughness-height-scale", type=float, default=1.0,
                   help="CSV height map: factor from the numbers to um (default 1)")
    p.add_argument("--roughness-height-range-um", type=float,
                   help="image height map: height in um from black to full white")
    p.add_argument("--roughness-seed", type=int, default=0,
                   help="seed of the synthetic rough surface (default 0)")
    p.add_argument("--hardness-mpa", type=float,
                   help="cap on asperity pressures in the film (default 300 MPa, PET)")
    p.add_argument("--inclination", default="1/40",
                   help="rail inclination as a fraction or a number, e.g. 1/40 (default), 1/20, "
                        "0.025, or 0 for an upright rail")
    p.add_argument("--wheel-radius-mm", type=float, default=460.0,
                   help="wheel rolling radius at the tape circle in mm (default 460)")
    p.add_argument("--grid-mm", type=float, default=0.1,
                   help="cell size of the contact grid in mm (default 0.1, the film's resolution)")
    p.add_argument("--film-type", metavar="NAME",
                   help="film type (MS, HS, HHS or one of --films-file): also report the imprint "
                        "area that the imprint model colours (imprint_area_mm2); its thickness and "
                        "Poisson's ratio are the defaults of the film")
    p.add_argument("--films-file", metavar="TOML", help="user film types (TOML)")
    p.add_argument("--imprint", dest="imprint_model", choices=IMPRINT_CHOICES,
                   default="activation",
                   help="what the film records (default activation: where the pressure exceeds "
                        "the film's activation pressure)")
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


def _film_type(args: argparse.Namespace):
    from filmcal.films import FilmRegistry

    if args.film_type is None:
        if args.films_file:
            raise ValueError("--films-file needs --film-type")
        return None
    return FilmRegistry.from_file(args.films_file).get(args.film_type)


def _surface(args: argparse.Namespace):
    """The rough wheel surface of --roughness-ra-um or --roughness-map (None otherwise)."""
    from filmcal.contact.roughness import WHEEL_SURFACE_DEFAULTS, RoughSurface

    if args.roughness_map:
        path = Path(args.roughness_map)
        if not path.is_file():
            raise ValueError(f"roughness_map {path}: not found")
        if args.roughness_pixel_um is None:
            raise ValueError("--roughness-map needs --roughness-pixel-um")
        if path.suffix.lower() in (".png", ".tif", ".tiff"):
            if args.roughness_height_range_um is None:
                raise ValueError("an image --roughness-map needs --roughness-height-range-um")
            return RoughSurface.from_image(path, args.roughness_pixel_um,
                                           args.roughness_height_range_um)
        return RoughSurface.from_csv(path, args.roughness_pixel_um, args.roughness_height_scale)
    if args.roughness_ra_um is None:
        return None
    check_range("roughness_ra_um", args.roughness_ra_um, 0.0, 30.0, high_open=False)
    d = WHEEL_SURFACE_DEFAULTS
    return RoughSurface.synthetic(ra_um=args.roughness_ra_um, hurst=d["hurst"],
                                  rolloff_wavelength_um=d["rolloff_wavelength_um"],
                                  size_um=d["size_um"], n=d["n"], seed=args.roughness_seed)


def _film_strain(film, pressure_mpa: float, large_strain: bool) -> float:
    """Compressive strain of the film at a pressure (linear: p/M; large: the neo-Hookean law)."""
    from filmcal.wheelrail.interface import LargeStrainFilm

    if large_strain:
        return float(LargeStrainFilm.from_film(film).strain(pressure_mpa))
    return float(pressure_mpa / film.oedometric_modulus_mpa)


def run(args: argparse.Namespace) -> int:
    """Solve the case and print the result."""
    from filmcal.films import FILM_POISSON, FILM_THICKNESS_MM
    from filmcal.hertz import contact_modulus_mpa
    from filmcal.wheelrail.interface import FilmLayer, GreenwoodWilliamsonLaw, film_law
    from filmcal.wheelrail.wheelrail import solve_wheel_rail

    force_n = 1e3 * check_positive("force_kn", args.force_kn)
    inclination = parse_inclination(args.inclination)
    film_type = _film_type(args)
    if film_type is not None:
        from filmcal.contact.imprint import get_imprint_model

        get_imprint_model(args.imprint_model).check_film(film_type)
    poisson = args.film_poisson if args.film_poisson is not None else (
        film_type.poisson if film_type is not None else FILM_POISSON)
    thickness = args.film_thickness_mm if args.film_thickness_mm is not None else (
        film_type.thickness_mm if film_type is not None else FILM_THICKNESS_MM)
    film = None if args.no_film else FilmLayer(args.film_modulus_mpa, poisson, thickness)
    if args.no_film and args.large_strain:
        raise ValueError("--large-strain needs a film (--film-modulus-mpa)")
    roughness, rough_info = None, None
    surface = _surface(args)
    if args.roughness_law:
        from filmcal.commands.curves import _measured_law

        roughness = _measured_law(args.roughness_law)
        rough_info = {"model": "measured law", "file": str(args.roughness_law)}
    elif surface is not None and film is None:
        if args.roughness_map:
            raise ValueError("--roughness-map needs a film (the law is computed against the film)")
        roughness = GreenwoodWilliamsonLaw(args.roughness_ra_um, contact_modulus_mpa())
        rough_info = {"model": "Greenwood-Williamson (steel on steel)"}
    elif surface is not None:
        from filmcal.contact.roughness import PET_HARDNESS_MPA, rough_contact_law

        hardness = PET_HARDNESS_MPA if args.hardness_mpa is None else check_positive(
            "hardness_mpa", args.hardness_mpa)
        roughness = rough_contact_law(surface, film.modulus_mpa, film.poisson, film.thickness_mm,
                                      hardness_mpa=hardness)
        rough_info = {"model": "FFT boundary elements", **roughness.describe()}
    solver_film, solver_law = film_law(film, roughness, large_strain=args.large_strain)
    result = solve_wheel_rail(args.offset_mm, force_n, wheel=_profile(args.wheel, "wheel"),
                              rail=_profile(args.rail, "rail"), rail_inclination=inclination,
                              nominal_radius_mm=args.wheel_radius_mm, film=solver_film,
                              roughness=solver_law, grid_mm=args.grid_mm)
    out = result.summary()
    if film is not None:
        out["film"] = {"modulus_mpa": film.modulus_mpa, "poisson": film.poisson,
                       "thickness_mm": film.thickness_mm,
                       "oedometric_modulus_mpa": film.oedometric_modulus_mpa,
                       "kinematics": "large" if args.large_strain else "small",
                       "max_strain": _film_strain(film, result.max_pressure_mpa, args.large_strain)}
    out["roughness"] = rough_info
    if args.roughness_ra_um is not None:
        out["roughness_ra_um"] = args.roughness_ra_um
    if film_type is not None:
        out["film_type"] = film_type.name
        out["imprint_model"] = args.imprint_model
        from filmcal.contact.film import FilmModel

        film_model = FilmModel(film_type, args.imprint_model, "large" if args.large_strain else "small")
        out["imprint_area_mm2"] = film_model.recorded_area_mm2(result)
        if film_type.activation_pressure_mpa is not None:
            out["activation_pressure_mpa"] = film_type.activation_pressure_mpa
        if hasattr(roughness, "expected_stain"):
            out["stained_area_mm2"] = film_model.stained_area_mm2(result,
                                                       roughness)
    if args.plot:
        plot_pressure_map(result, args.plot)
    if args.json:
        print_json(out)
        return 0 if result.converged else 1
    film_text = "no film" if film is None else (
        f"film E = {film.modulus_mpa:g} MPa, nu = {film.poisson:g}"
        + (", large strain" if args.large_strain else ""))
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
    if film_type is not None:
        print(f"imprint area     {out['imprint_area_mm2']:.2f} mm2 ({args.imprint_model} model, "
              f"film {film_type.name})")
        if "stained_area_mm2" in out:
            print(f"stained spots    {out['stained_area_mm2']:.2f} mm2 (asperity pressures)")
    state = "converged" if result.converged else "NOT converged"
    print(f"{state}, {result.elapsed_s:.3f} s")
    return 0 if result.converged else 1
