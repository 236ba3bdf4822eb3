"""`filmcal fem`: one evaluation of the axisymmetric sphere-on-flat FE model."""
from __future__ import annotations

import argparse
import warnings

from filmcal.commands._common import print_json
from filmcal.commands._options import add, add_contact_options, local, renamed
from filmcal.contact.names import DEFAULT_IMPRINT_MODEL, DEFAULT_KINEMATICS, FILM_LAYERS, IMPRINT_MODELS
from filmcal.films import FILM_POISSON, FILM_THICKNESS_MM


class FEValidityWarning(UserWarning):
    """The solution lies outside its model's validity (`filmcal.fem.FEResult.validity_warnings`)."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "fem", help="press a steel sphere on a steel flat with a film between (axisymmetric FE)",
        description="Axisymmetric finite-element model of the Hertzian film experiments: a steel sphere "
                    "(radius R) pressed with force F on a steel flat, with a Prescale film (E, nu, 90 um) "
                    "between them or without one. Prints the contact radius (the zero-pressure edge) read with "
                    "sub-element accuracy, the area, the maximum pressure and the Hertz radius for reference; "
                    "with --film, also the imprint that film records (--imprint-model).")
    add(p, "sphere_radius_mm", required=True, extra="(e.g. 300, 450, 600; the FE body takes spheres of at least "
        "55 mm, 1.1 times its 50 mm size)")
    add(p, "force_kn", required=True, extra="(e.g. 25-100)")
    film = p.add_mutually_exclusive_group(required=True)
    add(film, "film_modulus_mpa")
    local(film, "--no-film", action="store_true", help="steel on steel, no film")
    add(p, "film_poisson", extra=f"(default: the film type's, else {FILM_POISSON:g})")
    add(p, "film_thickness_mm", extra=f"(default: the film type's, else {FILM_THICKNESS_MM:g} mm); the FE resolves "
        "a film at least element size / 10 thick (0.01 mm at the default mesh)")
    local(p, "--film-layers", type=int, default=FILM_LAYERS,
          help=f"element layers through the film (default {FILM_LAYERS}; the paper used 1)")
    add_contact_options(p)
    add(p, "kinematics", default=DEFAULT_KINEMATICS, extra=f"(default {DEFAULT_KINEMATICS})")
    local(p, "--element-size-mm", type=float,
          help="element size in the contact zone in mm (default: the paper's contact-zone elements, "
               "filmcal.fem.MeshSettings)")
    imprint = p.add_mutually_exclusive_group()
    add(imprint, "film", extra="; also report its imprint (imprint_radius_mm, imprint_area_mm2); with --no-film, "
                               "the imprint of a film too thin to matter (where the contact without film exceeds "
                               "its activation pressure)")
    local(imprint, "--activation-pressure-mpa", type=float, metavar="P",
          help="also report the imprint of a film that colours above P MPa")
    add(p, "imprint_model", default=DEFAULT_IMPRINT_MODEL, extra=f"(default {DEFAULT_IMPRINT_MODEL})")
    add(p, "films_file")
    local(p, "--pressure-csv", metavar="FILE", help="write the pressure distribution p(r) to a CSV file (with a film, the two nodes nearest the "
                                     "axis read from the profile beyond them: FEResult.pressure_profile_mpa)")
    local(p, "--plot", metavar="PNG", help="plot the pressure distribution against Hertz to a PNG")
    add(p, "json", action="store_true")
    renamed(p, "--radius-mm", "--sphere-radius-mm", type=float)
    renamed(p, "--film-type", "--film")
    renamed(p, "--imprint", "--imprint-model", choices=IMPRINT_MODELS)
    renamed(p, "--large-strain", "--kinematics large", "kinematics", flag_value="large")
    p.set_defaults(func=run)


def _zone_for_force(mesh, sphere_radius_mm: float, force_kn: float):
    """The mesh with its refined zone grown to 1.6 Hertz radii at this force where the default zone (sized for
    150 kN) is smaller; a contact too large for the FE body is refused before any work."""
    import math
    from dataclasses import replace

    from filmcal.fem.mesh import default_contact_zone_mm
    from filmcal.hertz import hertz_radius_mm

    need = 1.6 * float(hertz_radius_mm(sphere_radius_mm, 1e3 * force_kn))
    if need <= default_contact_zone_mm(sphere_radius_mm, mesh):
        return mesh
    limit = 0.6 * mesh.body_size_mm
    if need > limit:
        raise ValueError(f"--force-kn: {force_kn:g} kN on a sphere of {sphere_radius_mm:g} mm makes a contact of "
                         f"{need / 1.6:.1f} mm Hertz radius; the FE body ({mesh.body_size_mm:g} mm) resolves "
                         f"contacts up to {limit / 1.6:.1f} mm: lower the force or take a smaller sphere")
    h = mesh.element_size_mm
    return replace(mesh, contact_zone_mm=min(math.ceil(need / h) * h, limit))


def run(args: argparse.Namespace) -> int:
    from filmcal.commands._options import contact_options
    from filmcal.fem import Film, MeshSettings, solve_sphere_on_flat

    from filmcal.films import FilmRegistry, FilmType

    film_type = None
    if args.film is not None:
        film_type = FilmRegistry.from_file(args.films_file).get(args.film)
    elif args.activation_pressure_mpa is not None:
        if not args.activation_pressure_mpa > 0:
            raise ValueError(f"--activation-pressure-mpa must be > 0, got {args.activation_pressure_mpa:g}")
        film_type = FilmType(f"p>{args.activation_pressure_mpa:g}MPa",
                             activation_pressure_mpa=args.activation_pressure_mpa)
    elif args.films_file is not None:
        FilmRegistry.from_file(args.films_file)  # report a bad file even when unused
    if film_type is None and args.imprint_model != DEFAULT_IMPRINT_MODEL:
        raise ValueError("--imprint-model needs --film (or --activation-pressure-mpa)")
    poisson = args.film_poisson if args.film_poisson is not None else (
        film_type.poisson if film_type is not None else FILM_POISSON)
    thickness = args.film_thickness_mm if args.film_thickness_mm is not None else (
        film_type.thickness_mm if film_type is not None else FILM_THICKNESS_MM)
    film = None if args.no_film else Film(args.film_modulus_mpa, poisson)
    options = contact_options(args)
    mesh = MeshSettings() if args.element_size_mm is None else MeshSettings(element_size_mm=args.element_size_mm)
    mesh = _zone_for_force(mesh, args.sphere_radius_mm, args.force_kn)
    if film is not None:  # a film thinner than the mesh resolves: refused before the model is built
        from filmcal.fem.model import check_film_thickness
        check_film_thickness(thickness, mesh.element_size_mm, args.film_layers)
    from filmcal.fem.memory import check_fe_memory  # a mesh that does not fit in memory: refused before any work

    size = (f"--element-size-mm {args.element_size_mm:g}" if args.element_size_mm is not None
            else f"the default --element-size-mm {mesh.element_size_mm:g}")
    check_fe_memory(args.sphere_radius_mm, mesh, args.film_layers, film is not None, options.kinematics,
                    options.sphere_contact, options.flat_contact,
                    options=f"{size} with --film-layers {args.film_layers} at --sphere-radius-mm "
                            f"{args.sphere_radius_mm:g}")
    res = solve_sphere_on_flat(args.sphere_radius_mm, args.force_kn * 1e3, film, options, mesh,
                               thickness, args.film_layers, film_type=film_type, imprint_model=args.imprint_model)
    if args.pressure_csv:
        import numpy as np
        from filmcal._io import atomic_open
        with atomic_open(args.pressure_csv, "w") as fh:
            np.savetxt(fh, np.column_stack([res.r_mm, res.pressure_profile_mpa, res.film_strain]),
                       delimiter=",", header="r_mm,pressure_mpa,film_strain", comments="", fmt="%.8g")
    if args.plot:
        from filmcal.report.figures import plot_pressure_profile
        plot_pressure_profile(res, args.plot)
    out = res.summary()
    out["warnings"] = res.validity_warnings()
    for text in out["warnings"]:
        warnings.warn(FEValidityWarning(text), stacklevel=1)
    if args.json:
        print_json(out)
    else:
        state = "converged" if res.converged else f"NOT converged: {res.reason}"
        print(f"R = {res.sphere_radius_mm:g} mm, F = {res.force_n / 1e3:g} kN, "
              + ("no film" if film is None else f"film E = {film.modulus_mpa:g} MPa, nu = {film.poisson:g}"))
        if not res.converged:  # its numbers are no solution (FEResult): not printed as one
            print(f"{state} in {res.iterations} iterations, {res.elapsed_s:.3f} s; no contact radius, area or "
                  "pressure to report")
            return 1
        print(f"contact radius  {res.contact_radius_mm:.4f} mm   (Hertz {res.hertz_radius_mm:.4f} mm, "
              f"difference {res.radius_error_mm:+.4f} mm)")
        print(f"contact area    {res.contact_area_mm2:.2f} mm2")
        print(f"peak pressure   {res.peak_pressure_mpa:.1f} MPa")
        if film is not None:
            print(f"film strain     {100 * res.film_strain_max:.1f} % (max through-thickness compression)")
        if res.imprint_radius_mm is not None:
            print(f"imprint radius  {res.imprint_radius_mm:.4f} mm ({res.imprint_model} model, film type "
                  f"{res.film}), area {res.imprint_area_mm2:.2f} mm2")
        print(f"{state} in {res.iterations} iterations, {res.elapsed_s:.3f} s")
    return 0 if res.converged else 1
