"""Correction curves with credible bands: how much the calibrated film enlarges the
S1002/60E2 contact area over the lateral offset, at 50 and 100 kN.

For each film type the posterior of its modulus (from the study folder;
calibrated first when missing) is propagated through the wheel-rail model:
Delta A = A_film - A_no_film and the correction factor A_no_film / A_film,
medians and 90 % credible bands, smooth wheel (and rough wheel with
--rough-ra-um). The interpolation error of the propagation is printed beside
the bands.

    python examples/correction_curves.py [--films HS] [--study-dir filmcal-study] [--out-dir out/curves]
        [--loads 50-100] [--rough-ra-um 1.5]
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from filmcal.correction import correction_curves
from filmcal.study import load_or_calibrate

OFFSETS_MM = np.arange(-7.0, 2.01, 1.0)
FORCES_N = (50e3, 100e3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--films", default="HS")
    ap.add_argument("--study-dir", default="filmcal-study")
    ap.add_argument("--out-dir", default="out/curves")
    ap.add_argument("--loads", default=None)
    ap.add_argument("--rough-ra-um", type=float, default=None, help="also a rough wheel (Greenwood-Williamson)")
    args = ap.parse_args()
    from matplotlib.figure import Figure

    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    variants = [("smooth wheel", None)]
    if args.rough_ra_um:
        from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, contact_modulus_mpa
        from filmcal.wheelrail import GreenwoodWilliamsonLaw

        def rough_law(modulus_mpa: float, ra_um: float = args.rough_ra_um) -> GreenwoodWilliamsonLaw:
            # the wheel's asperities press into the film: film-steel contact modulus
            return GreenwoodWilliamsonLaw(ra_um, contact_modulus_mpa(modulus_mpa, 0.33, STEEL_MODULUS_MPA,
                                                                     STEEL_POISSON))
        variants.append((f"rough wheel, Ra {args.rough_ra_um:g} um", rough_law))
    rows = []
    for film in args.films.split(","):
        e = np.asarray(load_or_calibrate(args.study_dir, film, args.loads).samples["modulus_mpa"], dtype=float)
        fig = Figure(figsize=(11, 7.5), layout="constrained")
        axes = fig.subplots(2, len(FORCES_N), sharex=True)
        for label, law in variants:
            c = correction_curves(e, OFFSETS_MM, FORCES_N, roughness=law)
            for k, force in enumerate(FORCES_N):
                line = axes[0, k].plot(c.offsets_mm, c.delta_area_median_mm2[k], "o-", label=label)[0]
                axes[0, k].fill_between(c.offsets_mm, *c.delta_area_ci90_mm2[k].T, color=line.get_color(), alpha=0.25)
                axes[1, k].plot(c.offsets_mm, c.ratio_median[k], "o-", color=line.get_color(), label=label)
                axes[1, k].fill_between(c.offsets_mm, *c.ratio_ci90[k].T, color=line.get_color(), alpha=0.25)
                axes[0, k].set_title(f"{film}, F = {force / 1e3:g} kN (max interpolation error "
                                     f"{100 * c.interpolation_error_rel[k].max():.3f} %)", fontsize=10)
                for j, eta in enumerate(c.offsets_mm):
                    rows.append({"film": film, "wheel": label, "force_kn": force / 1e3, "offset_mm": eta,
                                 "area_no_film_mm2": c.area_no_film_mm2[k, j],
                                 "delta_area_median_mm2": c.delta_area_median_mm2[k, j],
                                 "delta_area_lo_mm2": c.delta_area_ci90_mm2[k, j, 0],
                                 "delta_area_hi_mm2": c.delta_area_ci90_mm2[k, j, 1],
                                 "ratio_median": c.ratio_median[k, j], "ratio_lo": c.ratio_ci90[k, j, 0],
                                 "ratio_hi": c.ratio_ci90[k, j, 1],
                                 "interpolation_error_rel": c.interpolation_error_rel[k, j]})
                print(f"{film} {label} F={force / 1e3:g} kN: Delta A {c.delta_area_median_mm2[k].min():.1f}-"
                      f"{c.delta_area_median_mm2[k].max():.1f} mm2, ratio {c.ratio_median[k].min():.3f}-"
                      f"{c.ratio_median[k].max():.3f}, interpolation error <= "
                      f"{100 * c.interpolation_error_rel[k].max():.3f} %", flush=True)
        for ax in axes[0]:
            ax.set_ylabel("Delta A = A(film) - A(no film) (mm$^2$)")
            ax.grid(lw=0.3)
            ax.legend(fontsize=8)
        for ax in axes[1]:
            ax.set_ylabel("correction factor A(no film) / A(film)")
            ax.set_xlabel("lateral offset eta (mm)")
            ax.grid(lw=0.3)
        fig.suptitle(f"{film} film on S1002/60E2: posterior medians and 90 % credible bands")
        fig.savefig(out / f"correction_curves_{film}.png", dpi=120)
    with open(out / "correction_curves.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
