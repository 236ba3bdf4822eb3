"""`filmcal curves`: wheel-rail correction curves of a film's posterior at any loads and offsets."""
from __future__ import annotations

import argparse
import sys

from filmcal.commands._common import print_json
from filmcal.commands._options import (FORCE_KN_BOUNDS, STUDY_IMPRINT_MODELS, add, force_range, local, renamed,
                                       split_model)
from filmcal.contact.names import MIXTURE


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "curves", help="wheel-rail correction curves with 90 %% credible bands at any loads and offsets",
        description="Propagate a film type's calibrated posterior (from the study folder) through the S1002/60E2 "
                    "wheel-rail model: contact area without film, with film (posterior median and 90 %% band), "
                    "Delta A = A_film - A_0 and the correction factor A_0 / A_film at each (load, offset), smooth "
                    "and optionally rough wheel. The film area is interpolated in log E from solves at three "
                    "posterior quantiles; the interpolation error, checked at one more, is a column beside the "
                    "bands. About a second per (load, offset) with the smooth wheel; a rough wheel adds its law.")
    add(p, "film", required=True)
    add(p, "forces_kn", default="50,100", extra="(default 50,100)")
    add(p, "offsets_mm", default="-7:2:1", extra="(default -7:2:1)")
    add(p, "wheel_roughness_ra_um", extra="; also a rough wheel of this Ra: its boundary-element law against each "
                                          "film modulus, and against the steel rail for the area without film")
    add(p, "rail_roughness_ra_um", extra="; with the wheel's, or alone")
    add(p, "wheel_roughness_map", extra="(instead of --wheel-roughness-ra-um)")
    add(p, "rail_roughness_map", extra="(instead of --rail-roughness-ra-um)")
    local(p, "--roughness-pixel-um", type=float, help="pixel size in um of a CSV or image roughness map")
    local(p, "--roughness-law", metavar="CSV",
          help="also a rough wheel with this measured film-wheel pressure-overclosure law: a CSV with "
               "columns closure_um,pressure_mpa, both strictly increasing from pressure 0")
    add(p, "calibration_forces_kn")
    add(p, "study_dir", default="filmcal-study", extra="with the posterior (default ./filmcal-study)")
    add(p, "imprint_model", choices=STUDY_IMPRINT_MODELS, default=MIXTURE,
        extra=f"; or {MIXTURE} (default): the study's weighted mixture of the models it compared")
    add(p, "kinematics", extra="(default: every kinematics of the chosen posteriors, by their weights)")
    local(p, "--csv", help="write the curves to this CSV file")
    local(p, "--plot", help="write a PNG of the areas with and without film")
    where = p.add_mutually_exclusive_group()
    add(where, "workers", extra="(default: all cores)")
    add(where, "dask", extra="; the command's parallel work runs there (roughness laws, curve solves)")
    add(p, "json", action="store_true", help="print the rows as one JSON object")
    renamed(p, "--rough-ra-um", "--wheel-roughness-ra-um", type=float)
    renamed(p, "--loads", "--calibration-forces-kn", type=force_range)
    renamed(p, "--model", "--imprint-model IMPRINT --kinematics KINEMATICS", convert=split_model)
    p.set_defaults(func=run)


def _rough_bodies(args: argparse.Namespace) -> list:
    """The rough bodies asked for (none, a rough wheel's Ra, or `Roughness` of Ra values and measured maps)."""
    if args.wheel_roughness_ra_um and args.wheel_roughness_map or args.rail_roughness_ra_um and args.rail_roughness_map:
        raise ValueError("give each body's roughness as an Ra or as a map, not both")
    if not (args.rail_roughness_ra_um or args.wheel_roughness_map or args.rail_roughness_map):
        return [args.wheel_roughness_ra_um] if args.wheel_roughness_ra_um else []
    from filmcal.contact.rough_imprint import representative_roughness_inputs
    from filmcal.contact.surface_files import read_surface_file

    def body(ra, path):
        return read_surface_file(path, args.roughness_pixel_um) if path else ra

    bodies = representative_roughness_inputs().bodies(body(args.wheel_roughness_ra_um, args.wheel_roughness_map),
                                                      body(args.rail_roughness_ra_um, args.rail_roughness_map))
    return [] if bodies.smooth else [bodies]


def _check_map_memory(args: argparse.Namespace) -> None:
    """Roughness maps refused before any work when their laws do not fit: one law against the film at each
    modulus the curves solve at (at most `filmcal.correction.moduli.N_NODES` + 1) and one steel law, per map,
    held by this process and by every worker process (each cell's task receives the wheel's laws)."""
    from filmcal._memory import cpu_count
    from filmcal.commands._common import check_roughness_maps
    from filmcal.correction.moduli import N_NODES

    workers = cpu_count() if args.workers is None else args.workers
    copies = 1 if args.dask is not None or workers <= 1 else 1 + workers
    check_roughness_maps(args, "curves", N_NODES + 1, 1, copies,
                         advice="crop the map or bin its pixels" + (", or use fewer --workers (each holds the laws)"
                                                                    if copies > 1 else ""))


def run(args: argparse.Namespace) -> int:
    from filmcal._parallel import parallel_work
    from filmcal._validation import parse_grid
    from filmcal.study import Study

    forces = parse_grid("forces_kn", args.forces_kn, 50)
    offsets = parse_grid("offsets_mm", args.offsets_mm, 200)
    lo, hi = FORCE_KN_BOUNDS
    if any(not (lo <= f <= hi) for f in forces):
        raise ValueError(f"--forces-kn must lie in [{lo:g}, {hi:g}] kN (a larger load is a unit error), "
                         f"got {args.forces_kn!r}")
    if any(not (-20 <= e <= 10) for e in offsets):
        raise ValueError(f"offsets_mm must lie in [-20, 10] mm, got {args.offsets_mm!r}")
    _check_map_memory(args)
    from filmcal.correction import CURVE_COLUMNS, curve_table, wheel_label, write_curves_csv
    from filmcal.study.core import chosen_posteriors, curve_components

    with parallel_work(args.workers, args.dask) as workers:  # a Dask scheduler is reached before anything is written
        study = Study(args.study_dir)
        film = study.film(args.film).name
        match = {"imprint": None if args.imprint_model == MIXTURE else args.imprint_model,
                 "kinematics": args.kinematics, "loads": args.calibration_forces_kn}
        chosen = chosen_posteriors(study, film, **match)
        components = curve_components(study, film, **match)
        wheels = [None] + _rough_bodies(args)
        if args.roughness_law:
            from filmcal.contact.laws import TabularLaw

            wheels.append(TabularLaw.from_csv(args.roughness_law))
        for wheel in wheels:
            sys.stderr.write(f"[curves] {film}, {wheel_label(wheel)}: {len(forces)} loads x {len(offsets)} offsets\n")
        rows = curve_table(film, components, offsets, forces, wheels, workers)
    if args.csv:
        write_curves_csv(args.csv, rows)
    if args.plot:
        from filmcal._io import atomic_savefig
        from filmcal.report.figures import plot_area_curves

        atomic_savefig(plot_area_curves([dict(zip(CURVE_COLUMNS, r)) for r in rows], film), args.plot, dpi=120)
    rough_note = ("the rough rows use the representative draw of the roughness inputs: their bands do not hold the "
                  "inputs' spread (filmcal correct with the same roughness carries it)") if len(wheels) > 1 else None
    if args.json:
        print_json({"film": film, "models": {s["model"]: w for w, _, s in chosen},
                    "posterior_files": [str(p) for _, p, _ in chosen], "columns": list(CURVE_COLUMNS), "rows": rows,
                    **({"not_included": [rough_note]} if rough_note else {})})
    else:
        print(f"{'wheel':>16} {'F kN':>6} {'eta mm':>7} {'A0 mm2':>8} {'dA median':>9} {'dA 90 %':>17} "
              f"{'A0/A':>7} {'A0/A 90 %':>17} {'interp %':>8}")
        for r in rows:
            print(f"{r[1]:>16} {r[2]:6g} {r[3]:+7g} {r[4]:8.1f} {r[6]:9.1f} [{r[7]:6.1f}, {r[8]:6.1f}] "
                  f"{r[9]:7.4f} [{r[10]:.4f}, {r[11]:.4f}] {100 * r[12]:8.3f}")
        if rough_note:
            print(f"not included: {rough_note}")
    return 0
