"""Correction curves with credible bands: how much the calibrated film enlarges the
S1002/60E2 contact area over the lateral offset, at 50 and 100 kN.

For each film type the posterior of its modulus under one calibrated model
(--imprint-model and --kinematics, default edge and small) is asked of the study folder
(`filmcal.study.Study.calibrate`: a posterior recorded with the same settings
is reused, a missing one is calibrated there; a folder made by `filmcal
pipeline` keeps its FE sizes, seed and step cap). With ``--imprint-model mixture`` the
study's compared models are used instead, weighted as `filmcal pipeline`
weighed them (read only: run the pipeline first). The posterior is propagated
through the wheel-rail model (`filmcal.correction.correction_curves`, the area
each model records): Delta A = A_film - A_no_film and the correction factor
A_no_film / A_film, medians and 90 % credible bands, smooth wheel (and a
rough wheel of --wheel-roughness-ra-um, its bands over 8 conditioned draws of the
roughness inputs, `filmcal.correction.RoughConfiguration`). The interpolation
error of the propagation is printed beside the bands.

    python examples/correction_curves.py [--films HS] [--imprint-model edge|mixture] [--kinematics small]
        [--study-dir filmcal-study] [--out-dir out/curves] [--calibration-forces-kn 50-100]
        [--wheel-roughness-ra-um 1.5] [--offsets-mm -7,-6,...,2] [--forces-kn 50,100]
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from filmcal.contact.rough_imprint import load_roughness_inputs
from filmcal.correction import CURVE_COLUMNS, RoughConfiguration, curve_table
from filmcal.correction.wheelrail import nominal_modulus_mpa
from filmcal.study import Study
from filmcal.study.core import curve_components, film_model

OFFSETS_MM = tuple(float(x) for x in np.arange(-7.0, 2.01, 1.0))
FORCES_KN = (50.0, 100.0)


def components_of(study: Study, film: str, forces_kn: str | None, imprint_model: str, kinematics: str) -> list[tuple]:
    """``[(FilmModel, modulus samples, weight)]`` of a film: one calibrated model, or the study's mixture."""
    if imprint_model == "mixture":
        return curve_components(study, film, loads=forces_kn)
    with study.writing("examples/correction_curves.py"):
        result, _, spec = study.calibrate(study.spec_like_pipeline(film, imprint_model, kinematics, forces_kn))
    fm = film_model(study, spec)
    return [(fm, nominal_modulus_mpa(result.samples, fm.film.poisson), 1.0)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--films", default="HS")
    ap.add_argument("--imprint-model", default="edge", choices=("edge", "activation", "capsule", "mixture"),
                    help="calibrated imprint model (default edge; calibrated when missing), or 'mixture': the "
                         "study's compared models with their weights (from `filmcal pipeline`)")
    ap.add_argument("--kinematics", default="small", choices=("small", "large"),
                    help="film kinematics of the calibrated model (default small; not with mixture)")
    ap.add_argument("--study-dir", default="filmcal-study", help="study folder (created when missing)")
    ap.add_argument("--out-dir", default="out/curves")
    ap.add_argument("--calibration-forces-kn", default=None,
                    help="calibration data: load range in kN, e.g. 50-100 (default all)")
    ap.add_argument("--wheel-roughness-ra-um", type=float, default=None,
                    help="also a rough wheel of this Ra (um): synthetic surfaces of 8 conditioned draws of the "
                         "roughness inputs")
    ap.add_argument("--offsets-mm", default=",".join(f"{x:g}" for x in OFFSETS_MM),
                    help="lateral offsets eta in mm, comma-separated (default -7 to 2 in steps of 1)")
    ap.add_argument("--forces-kn", default=",".join(f"{x:g}" for x in FORCES_KN),
                    help="loads in kN, comma-separated (default 50,100)")
    args = ap.parse_args()
    try:
        offsets_mm = np.array([float(x) for x in args.offsets_mm.split(",")])
        forces_n = np.array([float(x) * 1e3 for x in args.forces_kn.split(",")])
    except ValueError:
        ap.error("--offsets-mm and --forces-kn take comma-separated numbers")
    if args.wheel_roughness_ra_um is not None and not args.wheel_roughness_ra_um > 0:
        ap.error("--wheel-roughness-ra-um must be > 0")
    study = Study(args.study_dir, create=args.imprint_model != "mixture")
    from matplotlib.figure import Figure

    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    rough = []
    if args.wheel_roughness_ra_um:
        rough.append(RoughConfiguration(args.wheel_roughness_ra_um, None, tuple(load_roughness_inputs()[:8])))
    rows = []
    for film in args.films.split(","):
        components = components_of(study, film, args.calibration_forces_kn, args.imprint_model, args.kinematics)
        table = [dict(zip(CURVE_COLUMNS, r)) for r in curve_table(film, components, offsets_mm, forces_n / 1e3, rough)]
        rows += table
        fig = Figure(figsize=(max(8.0, 5.5 * len(forces_n)), 7.5), layout="constrained")
        axes = fig.subplots(2, len(forces_n), sharex=True, squeeze=False)
        for label in dict.fromkeys(r["wheel"] for r in table):
            for k, force in enumerate(forces_n):
                c = [r for r in table if r["wheel"] == label and r["force_kn"] == force / 1e3]
                eta = [r["offset_mm"] for r in c]
                line = axes[0, k].plot(eta, [r["delta_area_median_mm2"] for r in c], "o-", label=label)[0]
                axes[0, k].fill_between(eta, [r["delta_area_lo_mm2"] for r in c], [r["delta_area_hi_mm2"] for r in c],
                                        color=line.get_color(), alpha=0.25)
                axes[1, k].plot(eta, [r["ratio_median"] for r in c], "o-", color=line.get_color(), label=label)
                axes[1, k].fill_between(eta, [r["ratio_lo"] for r in c], [r["ratio_hi"] for r in c],
                                        color=line.get_color(), alpha=0.25)
                err = max(r["interpolation_error_rel"] for r in c)
                axes[0, k].set_title(f"{film}, F = {force / 1e3:g} kN (max interpolation error {100 * err:.3f} %)",
                                     fontsize=10)
                print(f"{film} {label} F={force / 1e3:g} kN: Delta A "
                      f"{min(r['delta_area_median_mm2'] for r in c):.1f}-{max(r['delta_area_median_mm2'] for r in c):.1f}"
                      f" mm2, ratio {min(r['ratio_median'] for r in c):.3f}-{max(r['ratio_median'] for r in c):.3f}, "
                      f"interpolation error <= {100 * err:.3f} %", flush=True)
        for ax in axes[0]:
            ax.set_ylabel("Delta A = A(film) - A(no film) (mm$^2$)")
            ax.grid(lw=0.3)
            ax.legend(fontsize=8)
        for ax in axes[1]:
            ax.set_ylabel("correction factor A(no film) / A(film)")
            ax.set_xlabel("lateral offset eta (mm)")
            ax.grid(lw=0.3)
        label = args.imprint_model if args.imprint_model == "mixture" else f"{args.imprint_model}/{args.kinematics}"
        fig.suptitle(f"{film} film ({label}) on S1002/60E2: posterior medians and 90 % credible bands")
        fig.savefig(out / f"correction_curves_{film}.png", dpi=120)
    with open(out / "correction_curves.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
