"""Leave-one-case-out cross-validation of the sphere-on-flat correction on Table 1.

For each film type and each of its 10 (R, F) cases: calibrate the film modulus
without that case (FE surrogate, emcee), correct the case's measured radius
(Hertz + Table 1 error) into a contact area without film with its 90 %
interval, and check whether the Hertz area (the truth of these experiments)
falls inside. Prints one table per film and the count of hits.

    python examples/loo_sphere_correction.py [--study-dir filmcal-study] [--films MS,HS,HHS] [--out out/loo.md]
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from filmcal.calibration import Priors, calibrate, load_table1
from filmcal.correction import SphereCorrector
from filmcal.hertz import hertz_radius_mm
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
        data = load_table1(film)
        hits = 0
        lines += [f"### {film}", "", "| R (mm) | F (kN) | measured r (mm) | corrected area (mm2) | 90 % interval | "
                  "Hertz area | inside |", "|---|---|---|---|---|---|---|"]
        for i in range(len(data)):
            keep = np.ones(len(data), bool)
            keep[i] = False
            result = calibrate(data.select(keep), model, film=film,
                               priors=Priors(modulus_range_mpa=domain.modulus_mpa), seed=i)
            corrected = SphereCorrector(model, result.samples, random_state=i).correct(
                data.measured_radius_mm[i], data.sphere_radius_mm[i], data.force_n[i])
            truth = np.pi * hertz_radius_mm(data.sphere_radius_mm[i], data.force_n[i]) ** 2
            lo, hi = corrected.area_ci90_mm2
            inside = lo <= truth <= hi
            hits += inside
            line = (f"| {data.sphere_radius_mm[i]:g} | {data.force_n[i] / 1e3:g} | {data.measured_radius_mm[i]:.3f} | "
                    f"{corrected.area_mm2:.1f} +/- {corrected.area_std_mm2:.1f} | [{lo:.1f}, {hi:.1f}] | {truth:.1f} | "
                    f"{'yes' if inside else 'NO'} |")
            print(film, line, flush=True)
            lines.append(line)
        lines += ["", f"{film}: Hertz area inside the 90 % interval in {hits} of {len(data)} cases", ""]
        print(f"{film}: {hits}/{len(data)} inside", flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
