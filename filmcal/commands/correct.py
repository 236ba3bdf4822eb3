"""`filmcal correct`: the contact area without film behind an imprint, with its uncertainty."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from filmcal.commands._common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "correct", help="correct a contact area measured with film (wheel-rail or sphere-on-flat imprint)",
        description="Remove the film's enlargement from a measured imprint, using the film type's calibrated "
                    "posterior (from the study folder; calibrated first if missing, which takes a few minutes "
                    "once). Wheel-rail form: --measured-area-mm2 --offset-mm --force-kn (S1002 on 60E2 by "
                    "default). Sphere-on-flat form: --measured-radius-mm --sphere-radius-mm --force-kn. Prints the "
                    "posterior mean area, its standard deviation and 90 %% interval.")
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
    p.add_argument("--loads", help="calibration data: load range in kN, e.g. 50-100 (default: all loads)")
    p.add_argument("--study-dir", default="filmcal-study", help="study folder (default ./filmcal-study)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration and of the scatter draws")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def _posterior(args, options) -> tuple[dict, Path]:
    from filmcal.study import posterior_tag

    path = Path(args.study_dir) / f"posterior-{posterior_tag(args.film, args.loads, options, seed=args.seed)}.json"
    if not path.exists():
        from filmcal.study import calibrate_from_study
        sys.stderr.write(f"no posterior for {args.film.upper()} in {args.study_dir}: calibrating (once)\n")
        calibrate_from_study(args.study_dir, args.film, args.loads, options, seed=args.seed)
    samples = json.loads(path.read_text(encoding="utf-8"))["samples"]
    return samples, path


def run(args: argparse.Namespace) -> int:
    from filmcal.calibration import load_table1
    from filmcal.fem import ContactOptions

    sphere = args.measured_radius_mm is not None or args.sphere_radius_mm is not None
    wheel_rail = args.measured_area_mm2 is not None or args.offset_mm is not None
    if sphere == wheel_rail:
        raise ValueError("give either --measured-area-mm2 with --offset-mm (wheel-rail) or --measured-radius-mm "
                         "with --sphere-radius-mm (sphere on flat)")
    load_table1(args.film, args.loads)  # validates film and loads
    for name in ("force_kn", "measured_area_mm2", "measured_radius_mm", "sphere_radius_mm"):
        value = getattr(args, name)
        if value is not None and not (value > 0 and value < float("inf")):
            raise ValueError(f"{name} must be finite and > 0, got {value}")
    for name in ("measurement_std_mm2", "measurement_std_mm"):
        if not getattr(args, name) >= 0:
            raise ValueError(f"{name} must be >= 0, got {getattr(args, name)}")
    options = ContactOptions()
    if sphere:
        if args.measured_radius_mm is None or args.sphere_radius_mm is None:
            raise ValueError("sphere-on-flat needs both --measured-radius-mm and --sphere-radius-mm")
        from filmcal.correction import SphereCorrector
        from filmcal.study import SurrogateDomain, SurrogateRadiusModel, surrogate_path
        from filmcal.surrogate import load_surrogate

        samples, path = _posterior(args, options)
        model = SurrogateRadiusModel(load_surrogate(surrogate_path(args.study_dir, options)), SurrogateDomain())
        result = SphereCorrector(model, samples, random_state=args.seed).correct(
            args.measured_radius_mm, args.sphere_radius_mm, args.force_kn * 1e3, args.measurement_std_mm)
    else:
        if args.measured_area_mm2 is None or args.offset_mm is None:
            raise ValueError("wheel-rail needs both --measured-area-mm2 and --offset-mm")
        from filmcal.correction import WheelRailCorrector

        samples, path = _posterior(args, options)
        result = WheelRailCorrector(samples, wheel=args.wheel, rail=args.rail, rail_inclination=args.inclination,
                                    nominal_radius_mm=args.wheel_radius_mm, random_state=args.seed).correct(
            args.measured_area_mm2, args.offset_mm, args.force_kn * 1e3, args.measurement_std_mm2)
    out = result.to_dict()
    out.update(film=args.film.upper(), posterior_file=str(path),
               form="sphere-on-flat" if sphere else "wheel-rail")
    if args.json:
        print_json(out)
    else:
        lo, hi = out["area_ci90_mm2"]
        print(f"corrected area {out['area_mm2']:.2f} mm2 +/- {out['area_std_mm2']:.2f} (90 % {lo:.2f} - {hi:.2f})")
    return 0

