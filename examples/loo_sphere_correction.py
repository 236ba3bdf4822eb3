"""Leave-one-case-out cross-validation of the sphere-on-flat correction on Table 1.

For each film type and each of its 10 (R, F) cases: calibrate the film modulus
without that case (FE surrogate, emcee), correct the case's measured radius
(Hertz + Table 1 error) into a contact area without film with its 90 %
interval, and check whether the Hertz area (the truth of these experiments)
falls inside. Prints one table per film and the count of hits. (`filmcal
pipeline` runs the same folds in parallel and puts them in its report.)

    python examples/loo_sphere_correction.py [--study-dir filmcal-study] [--films MS,HS,HHS] [--out out/loo.md]
"""
from __future__ import annotations

import argparse
from pathlib import Path

from filmcal.calibration import Priors
from filmcal.correction import leave_one_case_out
from filmcal.study import SurrogateDomain, SurrogateRadiusModel, build_radius_surrogate


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study-dir", default="filmcal-study")
    ap.add_argument("--films", default="MS,HS,HHS")
    ap.add_argument("--out", default="out/loo.md")
    args = ap.parse_args()
    domain = SurrogateDomain()
    surrogate, _ = build_radius_surrogate(args.study_dir, domain=domain, progress=False)
    model = SurrogateRadiusModel(surrogate, domain)
    lines = []
    for film in args.films.split(","):
        cv = leave_one_case_out(model, film, priors=Priors(modulus_range_mpa=domain.modulus_mpa),
                                log=lambda msg: print(msg, flush=True))
        lines += [f"### {film}", "", "| R (mm) | F (kN) | measured r (mm) | corrected area (mm2) | 90 % interval | "
                  "Hertz area | inside |", "|---|---|---|---|---|---|---|"]
        for r, f, m, a, sd, (lo, hi), h, ok in zip(cv.sphere_radius_mm, cv.force_n, cv.measured_radius_mm,
                                                    cv.area_mm2, cv.area_std_mm2, cv.area_ci90_mm2,
                                                    cv.hertz_area_mm2, cv.inside):
            lines.append(f"| {r:g} | {f / 1e3:g} | {m:.3f} | {a:.1f} +/- {sd:.1f} | [{lo:.1f}, {hi:.1f}] | {h:.1f} | "
                         f"{'yes' if ok else 'NO'} |")
        lines += ["", f"{film}: Hertz area inside the 90 % interval in {cv.hits} of {len(cv.inside)} cases", ""]
        print(f"{film}: {cv.hits}/{len(cv.inside)} inside", flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
