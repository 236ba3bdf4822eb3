"""`filmcal fem`: one evaluation of the axisymmetric sphere-on-flat FE model."""
from __future__ import annotations

import argparse

from filmcal.commands._common import print_json
from filmcal.contact import DEFAULT_IMPRINT_MODEL, IMPRINT_MODELS
from filmcal.films import FILM_POISSON, FILM_THICKNESS_MM


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fem", help="press a steel sphere on a steel flat with a film between (axisymmetric FE)",
        description="Axisymmetric finite-element model of the Hertzian film experiments: a steel sphere "
                    "(radius R) pressed with force F on a steel flat, with a Prescale film (E, nu, 90 um) "
                    "between them or without one. Prints the contact radius (the zero-pressure edge) read with "
                    "sub-element accuracy, the area, the maximum pressure and the Hertz radius for reference; "
                    "with --film-type, also the imprint that film records (--imprint).")
    p.add_argument("--radius-mm", type=float, required=True, help="sphere radius R in mm (e.g. 300, 450, 600)")
    p.add_argument("--force-kn", type=float, required=True, help="normal force F in kN (e.g. 25-100)")
    film = p.add_mutually_exclusive_group(required=True)
    film.add_argument("--film-modulus-mpa", type=float, help="film Young's modulus E in MPa")
    film.add_argument("--no-film", action="store_true", help="steel on steel, no film")
    p.add_argument("--film-poisson", type=float, default=None,
                   help=f"film Poisson's ratio nu (default: the film type's, else {FILM_POISSON:g})")
    p.add_argument("--film-thickness-mm", type=float, default=None,
                   help=f"film thickness (default: the film type's, else {FILM_THICKNESS_MM:g} mm)")
    p.add_argument("--film-layers", type=int, default=1, help="element layers through the film (default 1)")
    p.add_argument("--sphere-contact", choices=["frictionless", "tied", "friction"], default="frictionless",
                   help="sphere-film interface (default frictionless)")
    p.add_argument("--flat-contact", choices=["frictionless", "tied", "friction"], default="tied",
                   help="film-flat interface, never separating (default tied)")
    p.add_argument("--friction-coefficient", type=float, default=0.4,
                   help="Coulomb coefficient of 'friction' interfaces (default 0.4, as the paper)")
    p.add_argument("--large-strain", action="store_true",
                   help="geometrically nonlinear neo-Hookean film instead of small strain")
    p.add_argument("--element-size-mm", type=float, default=0.1,
                   help="element size in the contact zone (default 0.1 mm, as the paper)")
    imprint = p.add_mutually_exclusive_group()
    imprint.add_argument("--film-type", metavar="NAME",
                         help="also report this film type's imprint (imprint_radius_mm, imprint_area_mm2): "
                              "MS, HS, HHS or a film of --films-file")
    imprint.add_argument("--activation-pressure-mpa", type=float, metavar="P",
                         help="also report the imprint of a film that colours above P MPa")
    p.add_argument("--imprint", choices=IMPRINT_MODELS, default=DEFAULT_IMPRINT_MODEL,
                   help="what the film records (default activation): 'edge' the whole contact, "
                        "'activation' where the pressure exceeds the film's activation pressure, "
                        "'capsule' the expected area of capsules broken (strengths spread over the film's range)")
    p.add_argument("--films-file", metavar="TOML", help="user film types (one TOML table per film)")
    p.add_argument("--pressure-csv", metavar="FILE", help="write the pressure distribution p(r) to a CSV file")
    p.add_argument("--plot", metavar="PNG", help="plot the pressure distribution against Hertz to a PNG")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.fem import ContactOptions, Film, MeshSettings, solve_sphere_on_flat

    from filmcal.films import FilmRegistry, FilmType

    film_type = None
    if args.film_type is not None:
        film_type = FilmRegistry.from_file(args.films_file).get(args.film_type)
    elif args.activation_pressure_mpa is not None:
        if not args.activation_pressure_mpa > 0:
            raise ValueError(f"--activation-pressure-mpa must be > 0, got {args.activation_pressure_mpa:g}")
        film_type = FilmType(f"p>{args.activation_pressure_mpa:g}MPa",
                             activation_pressure_mpa=args.activation_pressure_mpa)
    elif args.films_file is not None:
        FilmRegistry.from_file(args.films_file)  # report a bad file even when unused
    if film_type is None and args.imprint != DEFAULT_IMPRINT_MODEL:
        raise ValueError("--imprint needs --film-type (or --activation-pressure-mpa)")
    poisson = args.film_poisson if args.film_poisson is not None else (
        film_type.poisson if film_type is not None else FILM_POISSON)
    thickness = args.film_thickness_mm if args.film_thickness_mm is not None else (
        film_type.thickness_mm if film_type is not None else FILM_THICKNESS_MM)
    film = None if args.no_film else Film(args.film_modulus_mpa, poisson)
    options = ContactOptions(sphere_contact=args.sphere_contact, flat_contact=args.flat_contact,
                             friction_coefficient=args.friction_coefficient, large_strain=args.large_strain)
    mesh = MeshSettings(element_size_mm=args.element_size_mm)
    res = solve_sphere_on_flat(args.radius_mm, args.force_kn * 1e3, film, options, mesh,
                               thickness, args.film_layers, film_type=film_type, imprint_model=args.imprint)
    if args.pressure_csv:
        import numpy as np
        np.savetxt(args.pressure_csv, np.column_stack([res.r_mm, res.pressure_mpa, res.film_strain]),
                   delimiter=",", header="r_mm,pressure_mpa,film_strain", comments="", fmt="%.8g")
    if args.plot:
        from filmcal.report.figures import plot_pressure_profile
        plot_pressure_profile(res, args.plot)
    out = res.summary()
    if args.json:
        print_json(out)
    else:
        state = "converged" if res.converged else f"NOT converged: {res.reason}"
        print(f"R = {res.radius_mm:g} mm, F = {res.force_n / 1e3:g} kN, "
              + ("no film" if film is None else f"film E = {film.modulus_mpa:g} MPa, nu = {film.poisson:g}"))
        print(f"contact radius  {res.contact_radius_mm:.4f} mm   (Hertz {res.hertz_radius_mm:.4f} mm, "
              f"difference {res.radius_error_mm:+.4f} mm)")
        print(f"contact area    {res.contact_area_mm2:.2f} mm2")
        print(f"max pressure    {res.max_pressure_mpa:.1f} MPa")
        if film is not None:
            print(f"film strain     {100 * res.film_strain_max:.1f} % (max through-thickness compression)")
        if res.imprint_radius_mm is not None:
            print(f"imprint radius  {res.imprint_radius_mm:.4f} mm ({res.imprint_model} model, film type "
                  f"{res.film_type}), area {res.imprint_area_mm2:.2f} mm2")
        print(f"{state} in {res.iterations} iterations, {res.elapsed_s:.3f} s")
    return 0 if res.converged else 1
