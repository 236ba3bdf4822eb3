"""`filmcal correct`: the contact area without film behind an imprint, with its uncertainty."""
from __future__ import annotations

import argparse
import contextlib
import sys

from filmcal.commands._common import print_json
from filmcal.commands._options import (STUDY_IMPRINT_MODELS, add, add_roughness_map_reading, add_scan_resolution,
                                      add_wheel_rail_options, force_range, local, renamed, roughness_map_reading,
                                      split_model)
from filmcal.contact.names import MIXTURE


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "correct", help="correct a contact area measured with film (wheel-rail or sphere-on-flat imprint)",
        description="Remove the film's enlargement from a measured imprint, using the film type's calibrated "
                    "posterior from the study folder (never recalibrated: when the study compared imprint models, "
                    "their mixture by pseudo-BMA+ weights, unless --imprint-model / --kinematics pin one). Wheel-rail form: --measured-area-mm2 --offset-mm --force-kn (S1002 on 60E2 by "
                    "default). Sphere-on-flat form: --measured-radius-mm --sphere-radius-mm --force-kn. Instead of "
                    "the measured area or radius, --scan reads a scanned imprint (PNG, TIFF or JPEG; red stain on "
                    "white, thresholded by Otsu's method): its stained area (sphere-on-flat: the radius of the "
                    "circle of that area), whose uncertainty adds in quadrature to --measured-area-std-mm2 / "
                    "--measurement-std-mm; --outline-out then writes the outline without film. Prints the "
                    "posterior mean area, its standard deviation and 90 %% interval (with --scan, --json adds "
                    "measured_area_mm2 and measured_area_std_mm2, the image's own uncertainty, and the scan's "
                    "details). The wheel-rail form solves the contact without film and with the film at three "
                    "moduli spanning the posteriors (one solve serves every imprint model of a film kinematics); "
                    "the study keeps those solved areas when no other process is writing it, so correcting again "
                    "at the same offset and force reads them instead of solving. On rough bodies it keeps each "
                    "boundary-element law of the roughness draws as soon as it is solved (most of the time of a "
                    "rough answer): interrupted and run again, only the missing laws are solved.")
    add(p, "film", help="film type: MS, HS, HHS, or a film of the study's --films-file",
        extra="(required, except with --batch whose rows name their film)")
    add(p, "imprint_model", choices=STUDY_IMPRINT_MODELS, default=MIXTURE,
        extra=f"; or {MIXTURE} (default): the study's weighted mixture of the models it compared")
    add(p, "kinematics", extra="(default: every kinematics of the chosen posteriors, by their weights)")
    local(p, "--poisson", choices=["fixed", "free"], help="choose the posterior calibrated with this nu mode")
    add(p, "force_kn", extra="(the wheel load, or the sphere's force; required, except with --batch)")
    local(p, "--measured-area-mm2", type=float, help="wheel-rail: imprint area on the film (mm2)")
    add(p, "offset_mm", extra="(wheel-rail)")
    add(p, "offset_std_mm", default=0.0, extra="(wheel-rail, default 0): the band includes it through the "
        "correction's slope in the offset (two more offsets solved)")
    local(p, "--measured-area-std-mm2", type=float, default=0.0,
          help="wheel-rail: standard uncertainty of the measured area (mm2, default 0; at most half the area)")
    add_wheel_rail_options(p)
    local(p, "--measured-radius-mm", type=float, help="sphere-on-flat: imprint radius on the film (mm)")
    add(p, "sphere_radius_mm", extra="(sphere-on-flat)")
    local(p, "--measurement-std-mm", type=float, default=0.0,
          help="sphere-on-flat: standard uncertainty of the measured radius (mm, default 0; at most a quarter "
               "of the radius)")
    add(p, "scan", extra="instead of --measured-area-mm2 / --measured-radius-mm")
    add_scan_resolution(p, "--scan: ")
    local(p, "--threshold", type=float,
          help="--scan: stain intensity (1 - green channel) above which a pixel is stained "
               "(default: Otsu's threshold)")
    local(p, "--min-region-mm2", type=float,
          help="--scan: smallest stained region kept, smaller specks are dust (mm2, default 1)")
    local(p, "--outline-out", metavar="FILE.csv",
          help="--scan: write the outline without film as CSV with columns part,ring,x_mm,y_mm; "
               "part is measured (the imprint), mean (posterior mean area), lo and hi (5 %% and 95 %% "
               "area quantiles: the inner and outer edge of the band); ring numbers the closed polygons "
               "(two for a two-patch contact); x to the right, y up, mm from the image's lower-left "
               "corner. Wheel-rail: shrunk by the model's film enlargement round the patch; "
               "sphere-on-flat: a uniform inward offset")
    local(p, "--field-side", choices=("right", "left", "up", "down"), default="right",
          help="--outline-out, wheel-rail: direction of the rail's field side in the scan (default "
               "right); the rolling direction is the other image axis")
    add(p, "wheel_roughness_ra_um", extra="(wheel-rail): the answer and its band include what the bodies' roughness "
        "does to the imprint and to the contact without film (default: smooth)")
    add(p, "rail_roughness_ra_um", extra="(wheel-rail)")
    add(p, "wheel_roughness_map", extra="(wheel-rail; instead of --wheel-roughness-ra-um; its Ra is reported)")
    add(p, "rail_roughness_map", extra="(wheel-rail; instead of --rail-roughness-ra-um)")
    add_roughness_map_reading(p)
    local(p, "--roughness-draws", type=int,
          help="wheel-rail with roughness: draws of the roughness law's conditioned inputs (coating hardness, "
               "the scan's reading level, the surface's spectrum) that the band takes, 1-16 (default 8; each "
               "costs 10-30 s; the JSON gives the Monte-Carlo error)")
    add(p, "progress", default="auto", extra="(wheel-rail with roughness)")
    local(p, "--elastic-limit-mpa", type=float, default=1250.0,
          help="peak pressure of the contact without film above which the answer warns that the elastic model "
               "is outside its validity (MPa, default 1250: the paper's specimens stayed elastic at p0 1083-1127 "
               "MPa and it skipped 1290 MPa)")
    add(p, "calibration_forces_kn")
    add(p, "study_dir", default="filmcal-study", extra="with the calibrated posterior (default ./filmcal-study; "
                                                       "must exist)")
    add(p, "seed", default=0, extra="of the scatter draws (default 0)")
    add(p, "json", action="store_true")
    local(p, "--batch", metavar="IN.csv",
          help="correct one measurement per row (columns film, force_kn and either measured_area_mm2, offset_mm "
               "or measured_radius_mm, sphere_radius_mm; optional measured_area_std_mm2 / measurement_std_mm, "
               "offset_std_mm, wheel_roughness_ra_um, rail_roughness_ra_um) in one process, the posteriors read "
               "once; with --out")
    local(p, "--out", metavar="OUT.csv",
          help="--batch: the rows with area_mm2, area_std_mm2, area_ci90_low_mm2, area_ci90_high_mm2 and status "
               "(ok, or failed: and the reason) added, and OUT.csv.provenance.json beside it. Exit 0 when every "
               "row is corrected, 1 when some failed, 2 when the file cannot be read")
    renamed(p, "--model", "--imprint-model IMPRINT --kinematics KINEMATICS", convert=split_model)
    renamed(p, "--measurement-std-mm2", "--measured-area-std-mm2", type=float)
    renamed(p, "--imprint", "--scan")
    renamed(p, "--loads", "--calibration-forces-kn", type=force_range)
    p.set_defaults(func=run)


def _check_scan_options(args: argparse.Namespace) -> None:
    """--scan replaces the measured area or radius; its options need it."""
    if args.scan is not None and (args.measured_area_mm2 is not None or args.measured_radius_mm is not None):
        raise ValueError("give either --scan or --measured-area-mm2 / --measured-radius-mm, not both")
    if args.scan is None:
        for name in ("dpi", "mm_per_pixel", "threshold", "min_region_mm2", "outline_out"):
            if getattr(args, name) is not None:
                raise ValueError(f"--{name.replace('_', '-')} needs --scan")


@contextlib.contextmanager
def _rough_progress(mode: str, smooth: bool):
    """``advance(done, total)`` for the rough solves, shown as a progress stage (nothing for smooth bodies)."""
    if smooth:
        yield None
        return
    from filmcal._progress import Progress

    with Progress(mode).stage("rough solves") as stage:
        def advance(done: int, total: int) -> None:
            stage.set_total(total)
            stage.advance()

        yield advance


def run_batch(args: argparse.Namespace) -> int:
    """Correct every row of --batch into --out; exit 1 when some rows failed, 130 when interrupted (the rows
    corrected are written)."""
    from filmcal.study import Study
    from filmcal.study.batch import INTERRUPTED_STATUS, OUTPUT_COLUMNS, BatchInterrupted, correct_batch, read_batch

    if args.out is None:
        raise ValueError("--batch needs --out")
    from filmcal._io import check_distinct_files

    check_distinct_files((args.batch, "--batch"), (args.out, "--out"), (f"{args.out}.provenance.json", "--out's provenance"))
    from filmcal.study.layout import check_outside_study

    check_outside_study(args.out, "--out", args.study_dir)
    single = [name for name in ("film", "force_kn", "measured_area_mm2", "offset_mm", "measured_radius_mm", "sphere_radius_mm",
                                "scan", "wheel_roughness_ra_um", "rail_roughness_ra_um")
              if getattr(args, name, None) is not None]
    if single:
        raise ValueError(f"--batch takes the measurements from its rows, not --{single[0].replace('_', '-')}")
    header, rows = read_batch(args.batch)
    study = Study(args.study_dir)
    with contextlib.ExitStack() as stack:
        from filmcal._progress import Progress

        stage = stack.enter_context(Progress(args.progress).stage("batch", len(rows)))
        try:
            out, provenance = correct_batch(study, rows, seed=args.seed, elastic_limit_mpa=args.elastic_limit_mpa,
                                            progress=lambda k, n: stage.advance())
        except BatchInterrupted as stop:  # what was corrected is written, the other rows marked
            from filmcal.cli import EXIT_INTERRUPTED

            stack.close()
            done = len(rows) - stop.provenance["not_reached"]
            if not done:  # nothing to keep: an --out of an earlier run stays as it was
                sys.stderr.write(f"filmcal correct: interrupted before any row was corrected; {args.out} was not "
                                 "written\n")
                return EXIT_INTERRUPTED
            _write_batch(args, header + list(OUTPUT_COLUMNS), stop.rows, stop.provenance)
            sys.stderr.write(f"filmcal correct: interrupted after {done} of {len(rows)} rows; {args.out} holds "
                             f"them, the others marked '{INTERRUPTED_STATUS}': the same command run again "
                             "finishes it, reading the corrected rows' solves from the study where it could keep "
                             "them (no other process writing it)\n")
            return EXIT_INTERRUPTED
    _write_batch(args, header + list(OUTPUT_COLUMNS), out, provenance)
    failed = provenance["failed"]
    if args.json:
        print_json({"out": str(args.out), "provenance": f"{args.out}.provenance.json", "rows": len(rows),
                    "corrected": len(rows) - failed, "failed": failed})
    else:
        print(f"{len(rows) - failed} of {len(rows)} rows corrected into {args.out}"
              + (f"; {failed} failed (status column)" if failed else ""))
    return 1 if failed else 0


def _write_batch(args: argparse.Namespace, columns: list[str], rows: list[dict], provenance: dict) -> None:
    """--out and its provenance beside it, each written whole or not at all."""
    import csv

    from filmcal._io import atomic_open, atomic_write_json

    with atomic_open(args.out, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    atomic_write_json(f"{args.out}.provenance.json", {**provenance, "batch": str(args.batch)})


def run(args: argparse.Namespace) -> int:
    from filmcal.study import Study
    from filmcal.study.correct import (BodyRoughness, ScanReading, SphereMeasurement, WheelRailMeasurement,
                                       correct_measurement)

    from filmcal.commands._common import check_roughness_maps, roughness_draws

    args.roughness_draws = roughness_draws(args, batch=args.batch is not None)
    # one law against the film per draw and map, one steel law per map: refused before any work if they do
    # not fit in the memory available now
    check_roughness_maps(args, "correct", args.roughness_draws, 1,
                         advice="use fewer --roughness-draws, or crop the map or bin its pixels")
    if args.batch is not None:
        return run_batch(args)
    if args.out is not None:
        raise ValueError("--out needs --batch")
    if args.film is None or args.force_kn is None:
        raise ValueError("--film and --force-kn are required (or --batch, whose rows give them)")
    sphere = args.measured_radius_mm is not None or args.sphere_radius_mm is not None
    wheel_rail = args.measured_area_mm2 is not None or args.offset_mm is not None
    if sphere == wheel_rail:
        raise ValueError("give either --measured-area-mm2 (or --scan) with --offset-mm (wheel-rail) or "
                         "--measured-radius-mm (or --scan) with --sphere-radius-mm (sphere on flat)")
    _check_scan_options(args)
    if sphere and args.offset_std_mm:
        raise ValueError("--offset-std-mm applies to the wheel-rail form")
    if sphere and (args.sphere_radius_mm is None or (args.measured_radius_mm is None and args.scan is None)):
        raise ValueError("sphere-on-flat needs --measured-radius-mm (or --scan) and --sphere-radius-mm")
    if wheel_rail and (args.offset_mm is None or (args.measured_area_mm2 is None and args.scan is None)):
        raise ValueError("wheel-rail needs --measured-area-mm2 (or --scan) and --offset-mm")
    if sphere:
        measurement = SphereMeasurement(args.measured_radius_mm, args.sphere_radius_mm, args.force_kn,
                                        args.measurement_std_mm)
    else:
        measurement = WheelRailMeasurement(args.measured_area_mm2, args.offset_mm, args.force_kn,
                                           args.measured_area_std_mm2, args.wheel, args.rail, args.rail_inclination,
                                           args.nominal_radius_mm, args.offset_std_mm)
    scan = None if args.scan is None else ScanReading(
        args.scan, args.dpi, args.mm_per_pixel, args.threshold,
        1.0 if args.min_region_mm2 is None else args.min_region_mm2, args.outline_out, args.field_side)
    roughness = BodyRoughness(args.wheel_roughness_ra_um, args.rail_roughness_ra_um, args.roughness_draws,
                              args.wheel_roughness_map, args.rail_roughness_map, **roughness_map_reading(args))
    if sphere and not roughness.smooth:
        raise ValueError("--wheel-roughness-ra-um / --rail-roughness-ra-um apply to the wheel-rail form")
    study = Study(args.study_dir)  # an existing study: a mistyped folder is an error, not a new study
    with _rough_progress(args.progress, roughness.smooth) as advance:
        out, reading = correct_measurement(study, args.film, measurement, imprint_model=args.imprint_model,
                                           kinematics=args.kinematics, poisson=args.poisson,
                                           calibration_forces_kn=args.calibration_forces_kn, scan=scan,
                                           roughness=roughness, seed=args.seed, progress=advance,
                                           elastic_limit_mpa=args.elastic_limit_mpa)
    if args.json:
        print_json(out)
    else:
        lo, hi = out["area_ci90_mm2"]
        if reading is not None:
            print(f"imprint area {reading.area_mm2:.2f} mm2 +/- {reading.area_std_mm2:.2f} "
                  f"({reading.n_regions} region(s), pixel {reading.pixel_size_mm:.4f} mm)")
        print(f"corrected area {out['area_mm2']:.2f} mm2 +/- {out['area_std_mm2']:.2f} (90 % {lo:.2f} - {hi:.2f})")
        terms = [(m["weight"], m["transfer"]) for m in out["models"].values() if "transfer" in m]
        if terms:
            total = sum(w for w, _ in terms)
            shift = sum(w * t["shift_rel"] for w, t in terms) / total
            std = sum(w * t["std_rel"] for w, t in terms) / total
            print(f"includes the transfer term (the calibrated FE film against the wheel-rail model's): film area "
                  f"{100 * shift:+.2f} % +/- {100 * std:.2f} %")
        rough = out.get("roughness")
        if rough is not None:
            slo, shi = rough["smooth_area_ci90_mm2"]
            print(f"includes the bodies' roughness (wheel Ra {rough['wheel_ra_um']:.3g} um, rail Ra "
                  f"{rough['rail_ra_um']:.3g} um, {rough['n_draws']} draws of its inputs): smooth bodies would give "
                  f"{rough['smooth_area_mm2']:.2f} mm2 (90 % {slo:.2f} - {shi:.2f}); roughness is "
                  f"{100 * rough['share_of_variance']:.0f} % of the band's variance")
        for what in out.get("not_included", []):
            print(f"not included: {what}")
        if args.outline_out is not None:
            print(f"outline without film ({out['outline_rule']}): {args.outline_out}")
    return 0
