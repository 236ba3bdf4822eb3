"""Table 1 against the calibrated film model: for each film type and (R, F) case,
the measured radius error (Table 1) beside the posterior predictive mean and
90 % interval of the calibrated model, and how many cases fall inside.

The posterior of each film type under one calibrated model (--imprint-model and
--kinematics, default edge and small) is asked of the study folder (`filmcal.study.Study.calibrate`): a
posterior recorded with the same settings is reused (a folder made by
`filmcal pipeline` keeps its FE sizes, seed and step cap), a missing one is
calibrated there on the FE surrogate. The predictive distribution
(`CalibrationResult.predictive`) includes the posterior of E, the inferred
experimental scatter sigma and the surrogate's own uncertainty; the data it
is checked against are the data it was calibrated on, so this is a
goodness-of-fit check, not a test on new cases (examples/loo_sphere_correction.py
is the held-out one).

    python examples/table1_comparison.py [--films MS,HS,HHS] [--forces-kn 50-100] [--imprint-model edge] [--kinematics small]
        [--study-dir filmcal-study] [--out-dir out/table1_comparison]

Writes table1_comparison.csv, table1_comparison.md and
table1_predictive_<film>.png per film.
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from filmcal.calibration import FILM_TYPES, CalibrationResult
from filmcal.calibration.plots import plot_predictive
from filmcal.study import Study


def comparison_rows(result: CalibrationResult) -> list[dict]:
    """Measured and predicted radius errors (radius minus Hertz radius) per case, by load then radius."""
    pc = result.predictive
    rows = []
    for k in np.lexsort((pc.sphere_radius_mm, pc.force_n)):
        hertz = float(pc.hertz_radius_mm[k])
        rows.append({
            "film": result.film, "sphere_radius_mm": float(pc.sphere_radius_mm[k]),
            "force_kn": float(pc.force_n[k]) / 1e3, "hertz_radius_mm": hertz,
            "measured_error_mm": float(pc.measured_radius_mm[k]) - hertz,
            "predicted_error_mean_mm": float(pc.mean_mm[k]) - hertz, "predicted_std_mm": float(pc.std_mm[k]),
            "predicted_error_lo_mm": float(pc.lower_mm[k]) - hertz,
            "predicted_error_hi_mm": float(pc.upper_mm[k]) - hertz,
            "standardized_residual": float(pc.standardized_residual[k]), "pit": float(pc.pit[k]),
            "inside": bool(not pc.outside[k])})
    return rows


def markdown(rows: list[dict], results: dict[str, CalibrationResult]) -> str:
    lines = []
    for film, result in results.items():
        film_rows = [r for r in rows if r["film"] == film]
        hits = sum(r["inside"] for r in film_rows)
        post = result.modulus_mpa
        lines += [f"### {film} (calibrated on loads {result.loads or 'all'} kN): E = {post['median']:.0f} MPa "
                  f"[{post['ci90'][0]:.0f}, {post['ci90'][1]:.0f}], sigma = {result.sigma_mm['median']:.3f} mm; "
                  f"{hits} of {len(film_rows)} inside the 90 % interval", "",
                  "| R (mm) | F (kN) | Table 1 error (mm) | predicted mean (mm) | 90 % interval (mm) | "
                  "standardised residual | inside |", "|---|---|---|---|---|---|---|"]
        for r in film_rows:
            lines.append(f"| {r['sphere_radius_mm']:g} | {r['force_kn']:g} | {r['measured_error_mm']:.2f} | "
                         f"{r['predicted_error_mean_mm']:.3f} | [{r['predicted_error_lo_mm']:.3f}, "
                         f"{r['predicted_error_hi_mm']:.3f}] | {r['standardized_residual']:+.2f} | "
                         f"{'yes' if r['inside'] else 'NO'} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--films", default="MS,HS,HHS", help="comma-separated film types (default MS,HS,HHS)")
    ap.add_argument("--forces-kn", default=None,
                    help="load range in kN of the calibration data, e.g. 50-100 (default all)")
    ap.add_argument("--imprint-model", default="edge", choices=("edge", "activation", "capsule"),
                    help="calibrated imprint model (default edge)")
    ap.add_argument("--kinematics", default="small", choices=("small", "large"),
                    help="film kinematics of the calibrated model (default small)")
    ap.add_argument("--study-dir", default="filmcal-study",
                    help="study folder (created when missing); its posteriors are reused, missing ones calibrated")
    ap.add_argument("--out-dir", default="out/table1_comparison", help="output folder")
    args = ap.parse_args()
    films = [f.strip().upper() for f in args.films.split(",")]
    unknown = [f for f in films if f not in FILM_TYPES]
    if unknown:
        ap.error(f"--films: unknown film type(s) {', '.join(unknown)}; choose from {', '.join(FILM_TYPES)}")
    t0 = time.perf_counter()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    study = Study(args.study_dir, create=True)
    with study.writing("examples/table1_comparison.py"):
        results = {film: study.calibrate(study.spec_like_pipeline(film, args.imprint_model, args.kinematics, args.forces_kn))[0] for film in films}
    rows = []
    for film, result in results.items():
        plot_predictive(result, out / f"table1_predictive_{film}.png", dpi=130)
        film_rows = comparison_rows(result)
        rows += film_rows
        missed = [f"R{r['sphere_radius_mm']:g}/{r['force_kn']:g} kN" for r in film_rows if not r["inside"]]
        rms = np.sqrt(np.mean([(r["measured_error_mm"] - r["predicted_error_mean_mm"]) ** 2 for r in film_rows]))
        print(f"{film}: {len(film_rows) - len(missed)} of {len(film_rows)} inside the 90 % interval "
              f"(outside: {', '.join(missed) or 'none'}); RMS of measured - predicted mean {rms:.3f} mm",
              flush=True)
    with open(out / "table1_comparison.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    text = markdown(rows, results)
    (out / "table1_comparison.md").write_text(text)
    print(text)
    print(f"wrote {out}/ in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
