"""How the FE model's choices move the calibrated modulus of HS film, and a check
that the surrogate does not drive the answer.

For HS (loads 50-100 kN, the paper's choice, and all loads) the least-squares
film modulus is computed with the FE model in the loop (a few tens of FE solves
per setting, `filmcal.surrogate.radius.FERadiusModel`) under four model
settings: frictionless sphere / film tied to the flat (the default) and
Coulomb friction 0.4 at both interfaces, each with a small-strain and a
large-strain (neo-Hookean) film. For the default setting the Bayesian
posterior on the FE surrogate is asked of the study folder
(`filmcal.study.Study.calibrate`, as `filmcal calibrate` does: a posterior
recorded with the same settings is reused, a missing one calibrated, the FE
runs and surrogate made there when missing; a folder made by `filmcal
pipeline` keeps its FE sizes, seed and step cap) and compared with the
FE-in-the-loop estimate.

    python examples/calibration_model_choices.py [--study-dir filmcal-study] [--out out/model_choices.md]
        [--forces-kn 50-100,all] [--default-only]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from filmcal.calibration.inversion import least_squares_modulus
from filmcal.fem import ContactOptions, oedometric_modulus_mpa
from filmcal.study import CalibrationSpec, Study
from filmcal.surrogate.radius import FERadiusModel

SETTINGS = {
    "frictionless sphere / tied flat, small strain (default)": ContactOptions(),
    "frictionless sphere / tied flat, large strain": ContactOptions(kinematics="large"),
    "friction 0.4 both, small strain": ContactOptions(sphere_contact="friction", flat_contact="friction"),
    "friction 0.4 both, large strain": ContactOptions(sphere_contact="friction", flat_contact="friction",
                                                      kinematics="large"),
}


def calibration_spec(study: Study, loads: str | None) -> CalibrationSpec:
    """HS, edge of contact, default FE options: the FE sizes, seed and step cap of the study's pipeline when it
    has them (its posteriors are then reused), else those of `filmcal calibrate`."""
    return study.spec_like_pipeline("HS", "edge", "small", loads)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study-dir", default="filmcal-study", help="study folder (created when missing)")
    ap.add_argument("--out", default="out/model_choices.md")
    ap.add_argument("--forces-kn", default="50-100,all", help="load ranges of the calibration data in kN, "
                    "comma-separated, 'all' for every load (default 50-100,all)")
    ap.add_argument("--default-only", action="store_true",
                    help="FE in the loop under the default setting only (the one the surrogate is compared with)")
    args = ap.parse_args()
    load_ranges = [None if x.strip() == "all" else x.strip() for x in args.forces_kn.split(",")]
    settings = {k: v for k, v in SETTINGS.items() if v == ContactOptions() or not args.default_only}
    study = Study(args.study_dir, create=True)
    lines = ["| FE setting | loads (kN) | E least squares, FE in the loop (MPa) | M (MPa) | RMS residual (mm) | FE solves | s |",
             "|---|---|---|---|---|---|---|"]
    fe_default = {}
    for name, options in settings.items():
        for loads in load_ranges:
            t0 = time.perf_counter()
            fit = least_squares_modulus("HS", FERadiusModel(options), loads)
            if options == ContactOptions():
                fe_default[loads] = fit
            row = (f"| {name} | {loads or 'all'} | {fit.modulus_mpa:.0f} | "
                   f"{oedometric_modulus_mpa(fit.modulus_mpa, 0.33):.0f} | {fit.rms_residual_mm:.3f} | "
                   f"{fit.evaluations * len(fit.residuals_mm)} | {time.perf_counter() - t0:.0f} |")
            print(row, flush=True)
            lines.append(row)
    lines += ["", "| loads (kN) | E posterior median on the surrogate (MPa) [90 %] | E least squares on the surrogate | "
              "E least squares, FE in the loop | posterior median / FE - 1 |", "|---|---|---|---|---|"]
    for loads in load_ranges:
        with study.writing("examples/calibration_model_choices.py"):
            spec = calibration_spec(study, loads)
            post, _, _ = study.calibrate(spec)
            model, _, _ = study.radius_model(study.as_calibrated(spec).fe, "contact_radius_mm")
        ls = least_squares_modulus("HS", model, loads, modulus_range_mpa=spec.fe.domain.modulus_mpa)
        fe = fe_default[loads].modulus_mpa
        ci = post.modulus_mpa["ci90"]
        row = (f"| {loads or 'all'} | {post.modulus_mpa['median']:.0f} [{ci[0]:.0f}, {ci[1]:.0f}] | "
               f"{ls.modulus_mpa:.0f} | {fe:.0f} | {100 * (post.modulus_mpa['median'] / fe - 1):+.2f} % |")
        print(row, flush=True)
        lines.append(row)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
