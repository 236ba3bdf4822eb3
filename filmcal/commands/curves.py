"""`filmcal curves`: wheel-rail correction curves of a film's posterior at any loads and offsets."""
from __future__ import annotations

import argparse
import sys

from filmcal.commands._common import print_json
from filmcal.commands._options import (FORCE_KN_BOUNDS, OFFSET_MM_BOUNDS, STUDY_IMPRINT_MODELS, add,
                                       add_roughness_map_reading, force_range, local, renamed, roughness_map_reading,
                                       split_model)
from filmcal.contact.names import MIXTURE


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "curves", help="wheel-rail correction curves with 90 %% credible bands at any loads and offsets",
        description="Propagate a film type's calibrated posterior (from the study folder) through the S1002/60E2 "
                    "wheel-rail model: contact area without film, with film (posterior median and 90 %% band), "
                    "Delta A = A_film - A_0 and the correction factor A_0 / A_film at each (load, offset), smooth "
                    "and optionally on rough bodies. The film area is interpolated in log E from solves at three "
                    "posterior quantiles; the interpolation error, checked at one more, is a column beside the "
                    "bands. Rough bodies multiply each sample by one draw's rough/smooth growths (with and "
                    "without film), so their bands hold the roughness law's uncertainty. About a second per (load, "
                    "offset) with smooth bodies; rough bodies add a few seconds per draw and (load, offset), and "
                    "first the draws' roughness laws (seconds to minutes each), each kept in the study as it is "
                    "solved, so a run interrupted and started again, or a correction on the same bodies, reads it.")
    add(p, "film", help="film type: MS, HS, HHS, or a film of the study's --films-file", required=True)
    add(p, "forces_kn", default="50,100", extra="(default 50,100)")
    add(p, "offsets_mm", default="-7:2:1", extra="(default -7:2:1)")
    add(p, "wheel_roughness_ra_um", extra="; also curves on the rough bodies: each posterior sample's areas times "
                                          "the rough/smooth growths of one draw of the roughness inputs, with "
                                          "and without film")
    add(p, "rail_roughness_ra_um", extra="; with the wheel's, or alone")
    add(p, "wheel_roughness_map", extra="(instead of --wheel-roughness-ra-um)")
    add(p, "rail_roughness_map", extra="(instead of --rail-roughness-ra-um)")
    add_roughness_map_reading(p)
    add(p, "progress", default="auto", extra="(quiet: no line per curve set)")
    local(p, "--roughness-draws", type=int,
          help="rough bodies: draws of the roughness law's conditioned inputs (coating hardness, the scan's "
               "reading level, the surface's spectrum) that the rough bands take, 1-16 (default 8); the "
               "roughness share of each band's variance and the Monte-Carlo error are columns")
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


def _rough_configurations(args: argparse.Namespace, draws: list) -> list:
    """The rough bodies asked for (`filmcal.correction.RoughConfiguration`): the bodies' Ra values and measured
    maps with the first --roughness-draws of ``draws`` (the study's conditioned draws of the roughness
    inputs), and a measured law."""
    from filmcal.correction import RoughConfiguration

    if args.wheel_roughness_ra_um and args.wheel_roughness_map or args.rail_roughness_ra_um and args.rail_roughness_map:
        raise ValueError("give each body's roughness as an Ra or as a map, not both")
    out = []
    if args.wheel_roughness_ra_um or args.rail_roughness_ra_um or args.wheel_roughness_map or args.rail_roughness_map:
        from filmcal.contact.surface_files import read_surface_file

        def body(ra, path):
            return read_surface_file(path, **roughness_map_reading(args)) if path else (ra or None)

        if isinstance(args.roughness_draws, bool) or not 1 <= args.roughness_draws <= len(draws):
            raise ValueError(f"--roughness-draws must be an integer in [1, {len(draws)}], got {args.roughness_draws!r}")
        out.append(RoughConfiguration(body(args.wheel_roughness_ra_um, args.wheel_roughness_map),
                                      body(args.rail_roughness_ra_um, args.rail_roughness_map),
                                      tuple(draws[:args.roughness_draws])))
    if args.roughness_law:
        from filmcal.contact.laws import TabularLaw

        out.append(RoughConfiguration(law=TabularLaw.from_csv(args.roughness_law)))
    return out


def _waviness_note(configuration) -> str | None:
    """What the rough rows do not hold when a measured surface carries waviness (as `filmcal correct` says)."""
    if configuration.law is not None or not configuration.draws:
        return None
    from filmcal.correction.roughness import draw_bodies

    if draw_bodies(configuration.draws[0], wheel=configuration.wheel, rail=configuration.rail)[1] is None:
        return None
    return ("the measured surface's waviness stripes the contact without film; the elastic solve puts the load on "
            "the crests, which can exceed the steel's elastic limit (filmcal correct says by how much): there the "
            "rough rows' area without film is a lower bound")


def _check_map_memory(args: argparse.Namespace) -> None:
    """Roughness maps refused before any work when their laws do not fit: per map and draw a law against the
    film and a steel law, read from their files by every worker process (each holds them for its cells). The
    draws share the steel law when every rough body is a map (the surface is the same in every draw); a
    synthetic surface on the other body makes it each draw's own."""
    from filmcal._memory import cpu_count
    from filmcal.commands._common import check_roughness_maps

    workers = cpu_count() if args.workers is None else args.workers
    copies = 1 if args.dask is not None or workers <= 1 else workers
    synthetic = bool(args.wheel_roughness_ra_um or args.rail_roughness_ra_um)
    check_roughness_maps(args, "curves", args.roughness_draws, args.roughness_draws if synthetic else 1, copies,
                         advice="use fewer --roughness-draws, or crop the map or bin its pixels"
                                + (", or use fewer --workers (each holds the laws)" if copies > 1 else ""))


def run(args: argparse.Namespace) -> int:
    from filmcal._parallel import parallel_work
    from filmcal._validation import parse_grid
    from filmcal.study import Study
    from filmcal.study.layout import check_outside_study
    from filmcal.commands._common import roughness_draws

    forces = parse_grid("forces_kn", args.forces_kn, 50)
    offsets = parse_grid("offsets_mm", args.offsets_mm, 200)
    lo, hi = FORCE_KN_BOUNDS
    if any(not (lo <= f <= hi) for f in forces):
        raise ValueError(f"--forces-kn must lie in [{lo:g}, {hi:g}] kN (a load outside is a unit error), "
                         f"got {args.forces_kn!r}")
    lo, hi = OFFSET_MM_BOUNDS  # as correct and serve take them; an offset the profiles do not allow names its cell
    if any(not (lo <= e <= hi) for e in offsets):
        raise ValueError(f"--offsets-mm must lie in [{lo:g}, {hi:g}] mm, got {args.offsets_mm!r}")
    args.roughness_draws = roughness_draws(args)
    _check_map_memory(args)
    from filmcal._io import check_distinct_files, check_output_file

    outputs = [(path, option) for path, option in ((args.csv, "--csv"), (args.plot, "--plot")) if path]
    for path, option in outputs:  # refused before the solves, not after them
        check_output_file(path, option)
        check_outside_study(path, option, args.study_dir)
    check_distinct_files(*outputs)
    from filmcal.correction import CURVE_COLUMNS, curve_table, write_curves_csv
    from filmcal.correction.curves import transfer_note
    from filmcal.study.core import StudyRoughLaws, chosen_posteriors, curve_components

    with parallel_work(args.workers, args.dask) as workers:  # a Dask scheduler is reached before anything is written
        study = Study(args.study_dir)
        film = study.film(args.film).name
        match = {"imprint": None if args.imprint_model == MIXTURE else args.imprint_model,
                 "kinematics": args.kinematics, "loads": args.calibration_forces_kn}
        chosen = chosen_posteriors(study, film, **match)
        components = curve_components(study, film, **match)
        rough = _rough_configurations(args, study.roughness_inputs()[0])
        notes = [_waviness_note(c) for c in rough if _waviness_note(c)]
        for note in notes:
            sys.stderr.write(f"filmcal curves: warning: {note}\n")
        if args.progress != "quiet":
            for label in ["smooth"] + [c.label for c in rough]:
                sys.stderr.write(f"[curves] {film}, {label}: {len(forces)} loads x {len(offsets)} offsets\n")
        def laws_started(configuration, solving: int, found: int) -> None:
            if args.progress != "quiet" and solving:
                sys.stderr.write(f"[curves] {film}, {configuration.label}: {solving} roughness laws (boundary "
                                 f"elements, seconds to minutes each) to solve, {found} read from the study\n")

        rows = curve_table(film, components, offsets, forces, rough, workers,
                           StudyRoughLaws(study, command="filmcal curves"), laws_started)
    from filmcal.hertz import ELASTIC_LIMIT_MPA

    peak = CURVE_COLUMNS.index("max_pressure_no_film_mpa")
    over = {(r[2], r[3]) for r in rows if r[peak] > ELASTIC_LIMIT_MPA}
    if over:  # as `filmcal correct` warns
        top = max(rows, key=lambda r: r[peak])
        note = (f"the contact without film exceeds the steel's elastic limit of {ELASTIC_LIMIT_MPA:.0f} MPa at "
                f"{len(over)} of {len(forces) * len(offsets)} (load, offset) cells (highest {top[peak]:.0f} MPa, at "
                f"{top[2]:g} kN, eta {top[3]:+g} mm): there the elastic model is outside its validity and the real "
                "contact is larger (plastic)")
        notes.append(note)
        sys.stderr.write(f"filmcal curves: warning: {note}\n")
    note = transfer_note(rows, components)
    if note:  # as `filmcal correct` warns
        notes.append(note)
        sys.stderr.write(f"filmcal curves: warning: {note}\n")
    if args.csv:
        write_curves_csv(args.csv, rows)
    if args.plot:
        from filmcal._io import atomic_savefig
        from filmcal.report.figures import plot_area_curves

        atomic_savefig(plot_area_curves([dict(zip(CURVE_COLUMNS, r)) for r in rows], film), args.plot, dpi=120)
    if args.json:
        print_json({"film": film, "models": {s["model"]: w for w, _, s in chosen},
                    "posterior_files": [str(p) for _, p, _ in chosen], "columns": list(CURVE_COLUMNS), "rows": rows,
                    **({"warnings": notes} if notes else {})})
    else:
        w = max([16, *(len(str(r[1])) for r in rows)])  # the bodies' labels, aligned under their header
        print(f"{'wheel':>{w}} {'F kN':>6} {'eta mm':>7} {'A0 mm2':>8} {'dA median':>9} {'dA 90 %':>17} "
              f"{'A0/A':>7} {'A0/A 90 %':>17} {'interp %':>8} {'rough share':>11} {'MC err %':>8}")
        for r in rows:
            print(f"{r[1]:>{w}} {r[2]:6g} {r[3]:+7g} {r[4]:8.1f} {r[6]:9.1f} [{r[7]:6.1f}, {r[8]:6.1f}] "
                  f"{r[9]:7.4f} [{r[10]:.4f}, {r[11]:.4f}] {100 * r[12]:8.3f} {r[14]:11.2f} {100 * r[15]:8.3f}")
    return 0
