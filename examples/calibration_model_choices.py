"""How the FE model's choices move the calibrated modulus of HS film, and a check
that the surrogate does not drive the answer.

For HS (loads 50-100 kN, the paper's choice, and all loads) the least-squares
film modulus is computed with the FE model in the loop (a few tens of FE solves
per setting) under four model settings: frictionless sphere / film tied to the
flat (the default) and Coulomb friction 0.4 at both interfaces, each with a
small-strain and a large-strain (neo-Hookean) film. For the default setting the
Bayesian posterior on the FE surrogate (`filmcal calibrate`) is compared with
the FE-in-the-loop estimate.

    python examples/calibration_model_choices.py [--study-dir filmcal-study] [--out out/model_choices.md]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from filmcal.calibration import Priors, calibrate_film
from filmcal.calibration.inversion import least_squares_modulus
from filmcal.fem import ContactOptions, oedometric_modulus_mpa
from filmcal.study import FERadiusModel, SurrogateDomain, SurrogateRadiusModel, build_radius_surrogate

SETTINGS = {
    "frictionless sphere / tied flat, small strain (default)": ContactOptions(),
    "frictionless sphere / tied flat, large strain": ContactOptions(large_strain=True),
    "friction 0.4 both, small strain": ContactOptions(sphere_contact="friction", flat_contact="friction"),
    "friction 0.4 both, large strain": ContactOptions(sphere_contact="friction", flat_contact="friction",
                                                      large_strain=True),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study-dir", default="filmcal-study")
    ap.add_argument("--out", default="out/model_choices.md")
    args = ap.parse_args()
    lines = ["| FE setting | loads (kN) | E least squares, FE in the loop (MPa) | M (MPa) | RMS residual (mm) | FE solves | s |",
             "|---|---|---|---|---|---|---|"]
    fe_default = {}
    for name, options in SETTINGS.items():
        for loads in ("50-100", None):
            t0 = time.perf_counter()
            fit = least_squares_modulus("HS", FERadiusModel(options), loads)
            if options == ContactOptions():
                fe_default[loads] = fit
            row = (f"| {name} | {loads or 'all'} | {fit.modulus_mpa:.0f} | "
                   f"{oedometric_modulus_mpa(fit.modulus_mpa, 0.33):.0f} | {fit.rms_residual_mm:.3f} | "
                   f"{fit.evaluations * len(fit.residuals_mm)} | {time.perf_counter() - t0:.0f} |")
            print(row, flush=True)
            lines.append(row)
    domain = SurrogateDomain()
    surrogate, _ = build_radius_surrogate(args.study_dir, domain=domain, progress=False)
    model = SurrogateRadiusModel(surrogate, domain)
    lines += ["", "| loads (kN) | E posterior median on the surrogate (MPa) [90 %] | E least squares on the surrogate | "
              "E least squares, FE in the loop | posterior median / FE - 1 |", "|---|---|---|---|---|"]
    for loads in ("50-100", None):
        post = calibrate_film("HS", model, loads, priors=Priors(modulus_range_mpa=domain.modulus_mpa))
        ls = least_squares_modulus("HS", model, loads)
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
