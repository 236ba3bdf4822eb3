"""`filmcal correct`: the contact area without film behind an imprint, with its uncertainty."""
from __future__ import annotations

import argparse
import math
from pathlib import Path

from filmcal.commands._common import print_json
from filmcal.commands._options import STUDY_IMPRINT_MODELS, add, add_wheel_rail_options, force_range, local, renamed, split_model
from filmcal.contact.names import MIXTURE


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "correct", help="correct a contact area measured with film (wheel-rail or sphere-on-flat imprint)",
        description="Remove the film's enlargement from a measured imprint, using the film type's calibrated "
                    "posterior from the study folder (never recalibrated: when the study compared imprint models, "
                    "their stacking-weighted mixture, unless --imprint-model / --kinematics pin one). Wheel-rail form: --measured-area-mm2 --offset-mm --force-kn (S1002 on 60E2 by "
                    "default). Sphere-on-flat form: --measured-radius-mm --sphere-radius-mm --force-kn. Instead of "
                    "the measured area or radius, --scan reads a scanned imprint (PNG or TIFF; red stain on "
                    "white, thresholded by Otsu's method): its stained area (sphere-on-flat: the radius of the "
                    "circle of that area), whose uncertainty adds in quadrature to --measurement-std-mm2 / "
                    "--measurement-std-mm; --outline-out then writes the outline without film. Prints the "
                    "posterior mean area, its standard deviation and 90 %% interval (with --scan, --json adds "
                    "measured_area_mm2 and measured_area_std_mm2, the image's own uncertainty, and the scan's "
                    "details). The wheel-rail form solves the contact without film and with the film at three "
                    "moduli spanning the posteriors (one solve serves every imprint model of a film kinematics); "
                    "the study keeps those solved areas when no other process is writing it, so correcting again "
                    "at the same offset and force reads them instead of solving.")
    add(p, "film", required=True)
    add(p, "imprint_model", choices=STUDY_IMPRINT_MODELS, default=MIXTURE,
        extra=f"; or {MIXTURE} (default): the study's weighted mixture of the models it compared")
    add(p, "kinematics", extra="(default: every kinematics of the chosen posteriors, by their weights)")
    local(p, "--poisson", choices=["fixed", "free"], help="choose the posterior calibrated with this nu mode")
    add(p, "force_kn", required=True, extra="(the wheel load, or the sphere's force)")
    local(p, "--measured-area-mm2", type=float, help="wheel-rail: imprint area on the film (mm2)")
    add(p, "offset_mm", extra="(wheel-rail)")
    local(p, "--measurement-std-mm2", type=float, default=0.0,
          help="wheel-rail: standard uncertainty of the measured area (mm2, default 0)")
    add_wheel_rail_options(p)
    local(p, "--measured-radius-mm", type=float, help="sphere-on-flat: imprint radius on the film (mm)")
    add(p, "sphere_radius_mm", extra="(sphere-on-flat)")
    local(p, "--measurement-std-mm", type=float, default=0.0,
          help="sphere-on-flat: standard uncertainty of the measured radius (mm, default 0)")
    add(p, "scan", extra="instead of --measured-area-mm2 / --measured-radius-mm")
    local(p, "--dpi", type=float,
          help="--scan: scan resolution in dots per inch (default: the file's resolution metadata)")
    local(p, "--mm-per-pixel", type=float, help="--scan: pixel size in mm (instead of --dpi)")
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
    add(p, "calibration_forces_kn")
    add(p, "study_dir", default="filmcal-study", extra="with the calibrated posterior (default ./filmcal-study; "
                                                       "must exist)")
    add(p, "seed", default=0, extra="of the scatter draws (default 0)")
    add(p, "json", action="store_true")
    renamed(p, "--model", "--imprint-model IMPRINT --kinematics KINEMATICS", convert=split_model)
    renamed(p, "--imprint", "--scan")
    renamed(p, "--loads", "--calibration-forces-kn", type=force_range)
    p.set_defaults(func=run)


def _check_imprint_options(args: argparse.Namespace) -> None:
    """--scan replaces the measured area or radius; its options need it."""
    if args.scan is not None and (args.measured_area_mm2 is not None or args.measured_radius_mm is not None):
        raise ValueError("give either --scan or --measured-area-mm2 / --measured-radius-mm, not both")
    if args.scan is None:
        for name in ("dpi", "mm_per_pixel", "threshold", "min_region_mm2", "outline_out"):
            if getattr(args, name) is not None:
                raise ValueError(f"--{name.replace('_', '-')} needs --scan")
    elif args.outline_out is not None and not Path(args.outline_out).resolve().parent.is_dir():
        raise FileNotFoundError(f"folder of --outline-out not found: {Path(args.outline_out).parent}")


def _read_imprint(args: argparse.Namespace):
    from filmcal.correction import read_imprint

    min_region = 1.0 if args.min_region_mm2 is None else args.min_region_mm2
    return read_imprint(args.scan, dpi=args.dpi, mm_per_pixel=args.mm_per_pixel, threshold=args.threshold,
                        min_region_mm2=min_region)


def run(args: argparse.Namespace) -> int:
    from filmcal.study import Study, correctors

    sphere = args.measured_radius_mm is not None or args.sphere_radius_mm is not None
    wheel_rail = args.measured_area_mm2 is not None or args.offset_mm is not None
    if sphere == wheel_rail:
        raise ValueError("give either --measured-area-mm2 (or --scan) with --offset-mm (wheel-rail) or "
                         "--measured-radius-mm (or --scan) with --sphere-radius-mm (sphere on flat)")
    _check_imprint_options(args)
    if sphere and (args.sphere_radius_mm is None or (args.measured_radius_mm is None and args.scan is None)):
        raise ValueError("sphere-on-flat needs --measured-radius-mm (or --scan) and --sphere-radius-mm")
    if wheel_rail and (args.offset_mm is None or (args.measured_area_mm2 is None and args.scan is None)):
        raise ValueError("wheel-rail needs --measured-area-mm2 (or --scan) and --offset-mm")
    for name in ("measured_area_mm2", "measured_radius_mm"):
        value = getattr(args, name)
        if value is not None and not (value > 0 and value < float("inf")):
            raise ValueError(f"{name} must be finite and > 0, got {value}")
    for name in ("measurement_std_mm2", "measurement_std_mm"):
        if not getattr(args, name) >= 0:
            raise ValueError(f"{name} must be >= 0, got {getattr(args, name)}")
    study = Study(args.study_dir)  # an existing study: a mistyped folder is an error, not a new study
    study.film(args.film)
    imprint = None if args.scan is None else _read_imprint(args)
    match = {"imprint": None if args.imprint_model == MIXTURE else args.imprint_model,
             "kinematics": args.kinematics, "poisson": args.poisson, "loads": args.calibration_forces_kn}
    corrector = None
    if sphere:
        if imprint is not None:
            radius = imprint.equivalent_radius_mm
            radius_std = math.hypot(args.measurement_std_mm, imprint.area_std_mm2 / (2.0 * math.pi * radius))
        else:
            radius, radius_std = args.measured_radius_mm, args.measurement_std_mm
        if radius is None or args.sphere_radius_mm is None:
            raise ValueError("sphere-on-flat needs --measured-radius-mm (or --scan) and --sphere-radius-mm")
        parts = correctors(study, args.film, "sphere", random_state=args.seed, **match)
        parts[0][1].check_plausible(radius, args.sphere_radius_mm, args.force_kn * 1e3)
        results = [c.correct(radius, args.sphere_radius_mm, args.force_kn * 1e3, radius_std) for _, c, _ in parts]
    else:
        if imprint is not None:
            area, area_std = imprint.area_mm2, math.hypot(args.measurement_std_mm2, imprint.area_std_mm2)
        else:
            area, area_std = args.measured_area_mm2, args.measurement_std_mm2
        if area is None or args.offset_mm is None:
            raise ValueError("wheel-rail needs --measured-area-mm2 (or --scan) and --offset-mm")
        parts = correctors(study, args.film, "wheel-rail", random_state=args.seed,
                           wheel_rail=dict(wheel=args.wheel, rail=args.rail, rail_inclination=args.rail_inclination,
                                           nominal_radius_mm=args.nominal_radius_mm), **match)
        parts[0][1].check_plausible(area, args.offset_mm, args.force_kn * 1e3)
        results = [c.correct(area, args.offset_mm, args.force_kn * 1e3, area_std) for _, c, _ in parts]
        corrector = max(parts, key=lambda part: part[0])[1]
    if len(parts) == 1:
        result = results[0]
    else:
        from filmcal.correction.sphere import pool_corrected

        result = pool_corrected(results, [w for w, _, _ in parts], random_state=args.seed)
    out = result.to_dict()
    out.update(film=args.film, form="sphere-on-flat" if sphere else "wheel-rail",
               models={s["model"]: {"weight": w, "area_mm2": float(r.area_mm2), "area_ci90_mm2": r.area_ci90_mm2}
                       for (w, _, s), r in zip(parts, results)})
    if imprint is not None:
        details = {k: v for k, v in imprint.to_dict().items() if k not in ("area_mm2", "area_std_mm2")}
        out.update(measured_area_mm2=imprint.area_mm2, measured_area_std_mm2=imprint.area_std_mm2,
                   scan={"file": str(args.scan), **details})
    if args.outline_out is not None:
        outline = _corrected_outline(args, imprint, result, corrector)
        outline.write_csv(args.outline_out)
        out.update(outline_file=str(args.outline_out), outline_rule=outline.rule)
    if args.json:
        print_json(out)
    else:
        lo, hi = out["area_ci90_mm2"]
        if imprint is not None:
            print(f"imprint area {imprint.area_mm2:.2f} mm2 +/- {imprint.area_std_mm2:.2f} "
                  f"({imprint.n_regions} region(s), pixel {imprint.pixel_size_mm:.4f} mm)")
        print(f"corrected area {out['area_mm2']:.2f} mm2 +/- {out['area_std_mm2']:.2f} (90 % {lo:.2f} - {hi:.2f})")
        if args.outline_out is not None:
            print(f"outline without film ({out['outline_rule']}): {args.outline_out}")
    return 0


def _corrected_outline(args: argparse.Namespace, imprint, result, corrector):
    """The imprint's outline shrunk to the corrected area (the model's shift for wheel-rail)."""
    from filmcal.correction import correct_outline

    model = None if corrector is None else corrector.outline_model(args.offset_mm, args.force_kn * 1e3)
    return correct_outline(imprint.outlines_mm, result, model, field_side=args.field_side)
