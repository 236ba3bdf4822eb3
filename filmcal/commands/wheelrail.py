"""`filmcal wheelrail`: wheel-rail normal contact (S1002 on 60E2/60E1) with or without film."""
from __future__ import annotations

import argparse
import math

from filmcal._validation import HARDNESS_MPA_BOUNDS, arg_float_in
from filmcal.commands._common import print_json
from filmcal.commands._options import (add, add_roughness_map_reading, add_wheel_rail_options, bounds_text, local,
                                       renamed)
from filmcal.contact.names import DEFAULT_IMPRINT_MODEL, DEFAULT_KINEMATICS, IMPRINT_MODELS



def add_parser(subparsers) -> None:
    """Register the `wheelrail` subcommand."""
    p = subparsers.add_parser(
        "wheelrail",
        help="wheel-rail contact area at a lateral offset, with or without film",
        description="Normal contact of an S1002 wheel on an inclined 60E2 (or 60E1) rail at the "
                    "lateral offset eta (eta = 0: tape circle over the rail's inclined symmetry "
                    "plane; eta > 0 moves the flange towards the gauge corner) under a vertical "
                    "load F, solved as two elastic half-spaces (boundary elements) in the plane "
                    "tangent to the contact, with a Prescale film as springs in series. contact_area_mm2 is "
                    "where the pressure is positive; with a film, imprint_area_mm2 is what the film's imprint "
                    "model records, with the transfer term (the calibrated continuum film's imprint minus the "
                    "springs', and its standard deviation) beside it.")
    add(p, "offset_mm", required=True, extra="(the paper studies -7 to +2)")
    add(p, "force_kn", required=True, extra="(the vertical wheel load; the paper: 50 and 100)")
    film = p.add_mutually_exclusive_group(required=True)
    add(film, "film_modulus_mpa", extra="(a calibrated value: `filmcal calibrate` or the study's report)")
    local(film, "--no-film", action="store_true", help="steel on steel, no film")
    add(p, "film_poisson", extra="(default: the film type's, else 0.33)")
    add(p, "film_thickness_mm", extra="(default: the film type's, else 0.09)")
    add(p, "kinematics", default=DEFAULT_KINEMATICS,
        extra=f"(default {DEFAULT_KINEMATICS}): the film springs follow t/M, or the large-strain law of the FE's "
              "large-strain film (compressible neo-Hookean, compressed oedometrically)")
    rough = p.add_mutually_exclusive_group()
    add(rough, "wheel_roughness_ra_um",
        extra=": pressed into the film (FFT boundary elements, the coating's hardness capping the asperity "
              "pressures) it gives the film-wheel pressure-closure law, and the imprint is read where the "
              "asperities colour the film densely enough for a scan; without film, the same surface against "
              "steel (steel hardness cap), and the nominal area is reported. The surface's spectrum, hardness "
              "and reading level are the representative draw of the inputs conditioned on the paper's "
              "roughened flat (filmcal correct carries their spread). Smooth by default")
    local(rough, "--roughness-law", metavar="CSV",
          help="a measured film-wheel pressure-closure law: CSV with columns closure_um,pressure_mpa")
    add(rough, "wheel_roughness_map", extra=", with --roughness-pixel-um (and --roughness-height-scale for a CSV, "
                                             "--roughness-height-range-um for an image)")
    add(p, "rail_roughness_map")
    add(p, "rail_roughness_ra_um", extra=": with a film, pressed into the film's other face (its law in series "
                                          "with the wheel's); without film, its heights add to the wheel's")
    add_roughness_map_reading(p)
    local(p, "--roughness-seed", type=int, help="realisation of the synthetic rough surfaces (default: the "
                                                "representative conditioned draw's)")
    local(p, "--hardness-mpa", type=arg_float_in(*HARDNESS_MPA_BOUNDS),
          help="cap on asperity pressures in the film's coating (MPa; default: the representative conditioned "
               "draw's)" + bounds_text(*HARDNESS_MPA_BOUNDS, integer=False))
    add_wheel_rail_options(p, grid=True)
    add(p, "film", extra="; also report the area its imprint model colours (imprint_area_mm2); its thickness "
                         "and nu are the defaults of the film")
    add(p, "films_file")
    add(p, "imprint_model", default=DEFAULT_IMPRINT_MODEL, extra=f"(default {DEFAULT_IMPRINT_MODEL})")
    local(p, "--plot", metavar="PNG", help="draw the pressure map with the contact outline into a PNG file")
    add(p, "json", action="store_true")
    renamed(p, "--film-type", "--film")
    renamed(p, "--imprint", "--imprint-model", choices=IMPRINT_MODELS)
    renamed(p, "--large-strain", "--kinematics large", "kinematics", flag_value="large")
    renamed(p, "--roughness-ra-um", "--wheel-roughness-ra-um", type=float)
    renamed(p, "--roughness-map", "--wheel-roughness-map")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Solve the case and print the result."""
    from filmcal.commands._common import check_roughness_maps
    from filmcal.wheelrail.film_contact import FilmContactCase, WheelRoughness, solve_film_contact

    # maps too large for the time or the memory of their boundary-element laws: refused before any work
    check_roughness_maps(args, "wheelrail", 0 if args.no_film else 1, 1 if args.no_film else 0,
                         advice="crop the map or bin its pixels")

    if args.film is None and args.imprint_model != DEFAULT_IMPRINT_MODEL:
        raise ValueError("--imprint-model needs --film")
    inclination = args.rail_inclination
    case = FilmContactCase(None if args.no_film else args.film_modulus_mpa, args.film_poisson,
                           args.film_thickness_mm, args.film, args.films_file, args.imprint_model, args.kinematics)
    roughness = WheelRoughness(args.wheel_roughness_ra_um, args.wheel_roughness_map, args.roughness_law,
                               args.roughness_pixel_um, args.roughness_height_scale, args.roughness_height_range_um,
                               args.roughness_seed, args.hardness_mpa, args.rail_roughness_ra_um,
                               args.rail_roughness_map)
    result, out = solve_film_contact(args.offset_mm, 1e3 * args.force_kn, case, roughness, wheel=args.wheel,
                                     rail=args.rail, rail_inclination=inclination,
                                     nominal_radius_mm=args.nominal_radius_mm, grid_mm=args.grid_mm,
                                     plot_path=args.plot)
    if out.get("warnings"):
        import warnings

        from filmcal.study.correct import ElasticLimitWarning

        for text in out["warnings"]:
            warnings.warn(ElasticLimitWarning(text), stacklevel=1)
    if args.json:
        print_json(out)
        return 0 if result.converged else 1
    film = out.get("film") if "modulus_mpa" in (out.get("film") or {}) else None
    film_text = "no film" if film is None else (
        f"film E = {film['modulus_mpa']:g} MPa, nu = {film['poisson']:g}"
        + (", large strain" if args.kinematics == "large" else ""))
    print(f"{out['wheel']} on {out['rail']} (inclination {inclination:g}), eta = {result.offset_mm:g} mm, "
          f"F = {args.force_kn:g} kN, {film_text}")
    print(f"contact area     {result.area_mm2:.2f} mm2   (pressure > 0)")
    if "nominal_area_mm2" in out:
        print(f"nominal area     {out['nominal_area_mm2']:.2f} mm2   (rough bodies: the smooth area times the "
              "growth of the area above 1 % of the peak pressure)")
    if result.hertz is not None:
        note = "applies" if result.hertz_like else "does not apply here"
        print(f"local Hertz      {result.hertz.area_mm2:.2f} mm2 ({note})")
    print(f"max pressure     {result.max_pressure_mpa:.1f} MPa")
    print(f"patches          {result.n_patches}, centroid y = {result.centroid_y_mm:.2f} mm "
          f"(rail {result.centroid_rail_y_mm:.2f}, wheel {result.centroid_wheel_y_mm:.2f}), "
          f"contact angle {math.degrees(result.contact_angle_rad):.2f} deg")
    if "imprint_area_mm2" in out:
        print(f"imprint area     {out['imprint_area_mm2']:.2f} mm2 ({out['imprint_model']} model, "
              f"film {out['film']['name']})")
        if (out.get("roughness") or {}).get("reading_level") is not None:
            print(f"                 (rough: read where {100 * out['roughness']['reading_level']:.0f} % of the "
                  f"film is coloured)")
        if "stained_area_mm2" in out:
            print(f"stained spots    {out['stained_area_mm2']:.2f} mm2 (asperity pressures)")
    if "transfer_shift_mm2" in out:
        print(f"as calibrated    {out['calibrated_imprint_area_mm2']:.2f} +/- {out['transfer_std_mm2']:.2f} mm2 "
              f"(transfer term {out['transfer_shift_mm2']:+.2f} mm2: the calibrated FE film against these springs)")
    state = "converged" if result.converged else "NOT converged"
    print(f"{state}, {result.elapsed_s:.3f} s")
    return 0 if result.converged else 1
