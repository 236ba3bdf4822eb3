"""`filmcal correct`: the contact area without film behind an imprint, with its uncertainty."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from filmcal.commands._common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "correct", help="correct a contact area measured with film (wheel-rail or sphere-on-flat imprint)",
        description="Remove the film's enlargement from a measured imprint, using the film type's calibrated "
                    "posterior (from the study folder; calibrated first if missing, which takes a few minutes "
                    "once). Wheel-rail form: --measured-area-mm2 --offset-mm --force-kn (S1002 on 60E2 by "
                    "default). Sphere-on-flat form: --measured-radius-mm --sphere-radius-mm --force-kn. Instead of "
                    "the measured area or radius, --imprint reads a scanned imprint (PNG or TIFF; red stain on "
                    "white, thresholded by Otsu's method): its stained area (sphere-on-flat: the radius of the "
                    "circle of that area), whose uncertainty adds in quadrature to --measurement-std-mm2 / "
                    "--measurement-std-mm; --outline-out then writes the outline without film. Prints the "
                    "posterior mean area, its standard deviation and 90 %% interval (with --imprint, --json adds "
                    "measured_area_mm2 and measured_area_std_mm2, the image's own uncertainty, and the imprint's "
                    "details).")
    p.add_argument("--film", required=True, help="film type: MS, HS or HHS")
    p.add_argument("--force-kn", type=float, required=True, help="normal force (wheel load) in kN")
    p.add_argument("--measured-area-mm2", type=float, help="wheel-rail: imprint area on the film (mm2)")
    p.add_argument("--offset-mm", type=float, help="wheel-rail: lateral offset eta (mm, the paper's convention)")
    p.add_argument("--measurement-std-mm2", type=float, default=0.0,
                   help="wheel-rail: standard uncertainty of the measured area (mm2, default 0)")
    p.add_argument("--rail", default="60E2", help="rail profile: 60E2 (default), 60E1 or a CSV file")
    p.add_argument("--wheel", default="S1002", help="wheel profile: S1002 (default) or a CSV file")
    p.add_argument("--inclination", type=float, default=1 / 40, help="rail inclination (default 0.025 = 1:40)")
    p.add_argument("--wheel-radius-mm", type=float, default=460.0, help="nominal rolling radius (default 460)")
    p.add_argument("--measured-radius-mm", type=float, help="sphere-on-flat: imprint radius on the film (mm)")
    p.add_argument("--sphere-radius-mm", type=float, help="sphere-on-flat: sphere radius R (mm)")
    p.add_argument("--measurement-std-mm", type=float, default=0.0,
                   help="sphere-on-flat: standard uncertainty of the measured radius (mm, default 0)")
    p.add_argument("--imprint", metavar="PATH",
                   help="scanned imprint (PNG or TIFF) instead of --measured-area-mm2 / --measured-radius-mm")
    p.add_argument("--dpi", type=float,
                   help="--imprint: scan resolution in dots per inch (default: the file's resolution metadata)")
    p.add_argument("--mm-per-pixel", type=float, help="--imprint: pixel size in mm (instead of --dpi)")
    p.add_argument("--threshold", type=float,
                   help="--imprint: stain intensity 0-1 (1 - green channel) above which a pixel is stained "
                        "(default: Otsu's threshold)")
    p.add_argument("--min-region-mm2", type=float,
                   help="--imprint: smallest stained region kept, smaller specks are dust (mm2, default 1)")
    p.add_argument("--outline-out", metavar="FILE.csv",
                   help="--imprint: write the outline without film as CSV with columns part,ring,x_mm,y_mm; "
                        "part is measured (the imprint), mean (posterior mean area), lo and hi (5 %% and 95 %% "
                        "area quantiles: the inner and outer edge of the band); ring numbers the closed polygons "
                        "(two for a two-patch contact); x to the right, y up, mm from the image's lower-left "
                        "corner. Wheel-rail: shrunk by the model's film enlargement round the patch; "
                        "sphere-on-flat: a uniform inward offset")
    p.add_argument("--field-side", choices=("right", "left", "up", "down"), default="right",
                   help="--outline-out, wheel-rail: direction of the rail's field side in the scan (default "
                        "right); the rolling direction is the other image axis")
    p.add_argument("--loads", help="calibration data: load range in kN, e.g. 50-100 (default: all loads)")
    p.add_argument("--study-dir", default="filmcal-study", help="study folder (default ./filmcal-study)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration and of the scatter draws")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def _posterior(args, options) -> tuple[dict, Path]:
    """The study's posterior samples of the film, calibrated once first when missing."""
    from filmcal.study import calibrate_from_study, load_posterior_samples

    try:
        return load_posterior_samples(args.study_dir, args.film, args.loads, options, args.seed)
    except FileNotFoundError:
        sys.stderr.write(f"no posterior for {args.film.upper()} in {args.study_dir}: calibrating (once)\n")
        calibrate_from_study(args.study_dir, args.film, args.loads, options, seed=args.seed)
        return load_posterior_samples(args.study_dir, args.film, args.loads, options, args.seed)


def _check_imprint_options(args: argparse.Namespace) -> None:
    """--imprint replaces the measured area or radius; its options need it."""
    if args.imprint is not None and (args.measured_area_mm2 is not None or args.measured_radius_mm is not None):
        raise ValueError("give either --imprint or --measured-area-mm2 / --measured-radius-mm, not both")
    if args.imprint is None:
        for name in ("dpi", "mm_per_pixel", "threshold", "min_region_mm2", "outline_out"):
            if getattr(args, name) is not None:
                raise ValueError(f"--{name.replace('_', '-')} needs --imprint")
    elif args.outline_out is not None and not Path(args.outline_out).resolve().parent.is_dir():
        raise FileNotFoundError(f"folder of --outline-out not found: {Path(args.outline_out).parent}")


def _read_imprint(args: argparse.Namespace):
    from filmcal.correction import read_imprint

    min_region = 1.0 if args.min_region_mm2 is None else args.min_region_mm2
    return read_imprint(args.imprint, dpi=args.dpi, mm_per_pixel=args.mm_per_pixel, threshold=args.threshold,
                        min_region_mm2=min_region)


def run(args: argparse.Namespace) -> int:
    from filmcal.calibration import load_table1
    from filmcal.fem import ContactOptions

    sphere = args.measured_radius_mm is not None or args.sphere_radius_mm is not None
    wheel_rail = args.measured_area_mm2 is not None or args.offset_mm is not None
    if sphere == wheel_rail:
        raise ValueError("give either --measured-area-mm2 (or --imprint) with --offset-mm (wheel-rail) or "
                         "--measured-radius-mm (or --imprint) with --sphere-radius-mm (sphere on flat)")
    _check_imprint_options(args)
    load_table1(args.film, args.loads)  # validates film and loads
    for name in ("force_kn", "measured_area_mm2", "measured_radius_mm", "sphere_radius_mm"):
        value = getattr(args, name)
        if value is not None and not (value > 0 and value < float("inf")):
            raise ValueError(f"{name} must be finite and > 0, got {value}")
    for name in ("measurement_std_mm2", "measurement_std_mm"):
        if not getattr(args, name) >= 0:
            raise ValueError(f"{name} must be >= 0, got {getattr(args, name)}")
    imprint = None if args.imprint is None else _read_imprint(args)
    options = ContactOptions()
    corrector = None
    if sphere:
        if imprint is not None:
            radius = imprint.equivalent_radius_mm
            radius_std = math.hypot(args.measurement_std_mm, imprint.area_std_mm2 / (2.0 * math.pi * radius))
        else:
            radius, radius_std = args.measured_radius_mm, args.measurement_std_mm
        if radius is None or args.sphere_radius_mm is None:
            raise ValueError("sphere-on-flat needs --measured-radius-mm (or --imprint) and --sphere-radius-mm")
        from filmcal.correction import SphereCorrector
        from filmcal.study import SurrogateDomain, SurrogateRadiusModel, surrogate_path
        from filmcal.surrogate import load_surrogate

        samples, path = _posterior(args, options)
        model = SurrogateRadiusModel(load_surrogate(surrogate_path(args.study_dir, options)), SurrogateDomain())
        result = SphereCorrector(model, samples, random_state=args.seed).correct(
            radius, args.sphere_radius_mm, args.force_kn * 1e3, radius_std)
    else:
        if imprint is not None:
            area, area_std = imprint.area_mm2, math.hypot(args.measurement_std_mm2, imprint.area_std_mm2)
        else:
            area, area_std = args.measured_area_mm2, args.measurement_std_mm2
        if area is None or args.offset_mm is None:
            raise ValueError("wheel-rail needs --measured-area-mm2 (or --imprint) and --offset-mm")
        from filmcal.correction import WheelRailCorrector

        samples, path = _posterior(args, options)
        corrector = WheelRailCorrector(samples, wheel=args.wheel, rail=args.rail, rail_inclination=args.inclination,
                                       nominal_radius_mm=args.wheel_radius_mm, random_state=args.seed)
        result = corrector.correct(area, args.offset_mm, args.force_kn * 1e3, area_std)
    out = result.to_dict()
    out.update(film=args.film.upper(), posterior_file=str(path),
               form="sphere-on-flat" if sphere else "wheel-rail")
    if imprint is not None:
        details = {k: v for k, v in imprint.to_dict().items() if k not in ("area_mm2", "area_std_mm2")}
        out.update(measured_area_mm2=imprint.area_mm2, measured_area_std_mm2=imprint.area_std_mm2,
                   imprint={"file": str(args.imprint), **details})
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
    """The imprint's outline shrunk to the corrected area (model shift for wheel-rail)."""
    import numpy as np

    from filmcal.correction import correct_outline, wheel_rail_outlines

    model = None
    if corrector is not None:
        from filmcal.wheelrail import FilmLayer

        film = FilmLayer(float(np.median(corrector.modulus_mpa_)), corrector.poisson_, corrector.film_thickness_mm)
        model = wheel_rail_outlines(args.offset_mm, args.force_kn * 1e3, film, **corrector.settings)
    return correct_outline(imprint.outlines_mm, result, model, field_side=args.field_side)
