"""The paper's Fig. 3 in kind: the range of film modulus E that reproduces each
measured radius of Table 1 on its own, per film type, beside the pooled posterior.

For each film type (MS, HS, HHS) the posterior of E under one calibrated model
(--imprint-model and --kinematics, default edge and small) is asked of the study folder
(`filmcal.study.Study.calibrate`): a posterior recorded with the same settings
is reused, a missing one is calibrated there on the FE surrogate (which takes a
few minutes the first time, FE runs and surrogate included). A folder made by
`filmcal pipeline` keeps its FE sizes, seed and step cap, so its posteriors are
the ones read. Its per-case intervals are the E for which the model
radius lies within +/- the posterior median sigma of the measured radius
(`CalibrationResult.case_intervals`). A case disagrees with the pooled
posterior when its range and the pooled 90 % interval do not overlap; the
paper found this at 25 kN, where the E needed depended on the sphere's
curvature. The dashed line marks the paper's HS value, E = 2800 MPa.

    python examples/fig3_modulus_ranges.py [--films MS,HS,HHS] [--forces-kn 50-100] [--imprint-model edge] [--kinematics small]
        [--study-dir filmcal-study] [--out-dir out/fig3_modulus_ranges]

Writes fig3_<film>.png per film, fig3_modulus_ranges.csv and fig3_modulus_ranges.md.
"""
from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

from filmcal.calibration import FILM_TYPES, CalibrationResult
from filmcal.calibration.plots import plot_case_intervals
from filmcal.study import Study

PAPER_HS_MODULUS_MPA = 2800.0  # the paper's calibrated HS film (dashed line of its Fig. 3)


def case_rows(result: CalibrationResult) -> list[dict]:
    """One row per case: its E range, and whether it overlaps the pooled 90 % interval."""
    ci = result.case_intervals
    pooled_lo, pooled_hi = result.modulus_mpa["ci90"]
    rows = []
    for k in range(len(ci.status)):
        lo, hi = float(ci.lower_mpa[k]), float(ci.upper_mpa[k])
        rows.append({
            "film": result.film, "sphere_radius_mm": float(ci.sphere_radius_mm[k]),
            "force_kn": float(ci.force_n[k]) / 1e3, "measured_radius_mm": float(ci.measured_radius_mm[k]),
            "modulus_exact_mpa": float(ci.modulus_mpa[k]), "modulus_lower_mpa": lo, "modulus_upper_mpa": hi,
            "status": ci.status[k], "tolerance_mm": ci.tolerance_mm,
            "pooled_median_mpa": result.modulus_mpa["median"], "pooled_lo_mpa": pooled_lo,
            "pooled_hi_mpa": pooled_hi, "agrees_with_pooled": bool(lo <= pooled_hi and hi >= pooled_lo)})
    rows.sort(key=lambda r: (r["force_kn"], r["sphere_radius_mm"]))
    return rows


def spread_by_load(rows: list[dict]) -> dict[float, tuple[float, float]]:
    """Smallest and largest exact E over the sphere radii at each load (finite values only)."""
    spread = {}
    for r in rows:
        e = r["modulus_exact_mpa"]
        if 0.0 < e < math.inf:
            lo, hi = spread.get(r["force_kn"], (math.inf, 0.0))
            spread[r["force_kn"]] = (min(lo, e), max(hi, e))
    return spread


def _fmt(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.0f}"


def markdown(rows: list[dict], results: dict[str, CalibrationResult]) -> str:
    lines = []
    for film, result in results.items():
        post = result.modulus_mpa
        lines += [f"### {film} (loads {result.loads or 'all'} kN): pooled E = {post['median']:.0f} MPa "
                  f"[{post['ci90'][0]:.0f}, {post['ci90'][1]:.0f}], tolerance +/- "
                  f"{result.case_intervals.tolerance_mm:.3f} mm", "",
                  "| R (mm) | F (kN) | E exact (MPa) | E range (MPa) | status | agrees with pooled 90 % |",
                  "|---|---|---|---|---|---|"]
        for r in rows:
            if r["film"] == film:
                lines.append(f"| {r['sphere_radius_mm']:g} | {r['force_kn']:g} | {_fmt(r['modulus_exact_mpa'])} | "
                             f"[{_fmt(r['modulus_lower_mpa'])}, {_fmt(r['modulus_upper_mpa'])}] | {r['status']} | "
                             f"{'yes' if r['agrees_with_pooled'] else 'NO'} |")
        lines += ["", "Spread of the exact E over the sphere radii, per load (max / min): "
                  + ", ".join(f"{f:g} kN {hi / lo:.2f}" for f, (lo, hi)
                              in spread_by_load([r for r in rows if r["film"] == film]).items()), ""]
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
    ap.add_argument("--out-dir", default="out/fig3_modulus_ranges", help="output folder")
    args = ap.parse_args()
    films = [f.strip().upper() for f in args.films.split(",")]
    unknown = [f for f in films if f not in FILM_TYPES]
    if unknown:
        ap.error(f"--films: unknown film type(s) {', '.join(unknown)}; choose from {', '.join(FILM_TYPES)}")
    t0 = time.perf_counter()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    study = Study(args.study_dir, create=True)
    with study.writing("examples/fig3_modulus_ranges.py"):
        results = {film: study.calibrate(study.spec_like_pipeline(film, args.imprint_model, args.kinematics, args.forces_kn))[0] for film in films}
    rows = []
    for film, result in results.items():
        fig = plot_case_intervals(result)
        ax = fig.axes[0]
        lo, hi = ax.get_xlim()
        if lo <= PAPER_HS_MODULUS_MPA <= hi:
            ax.axvline(PAPER_HS_MODULUS_MPA, color="0.3", ls="--", lw=1, label="paper, HS: 2800 MPa")
            ax.legend(loc="lower right", fontsize=8)
        fig.savefig(out / f"fig3_{film}.png", dpi=130)
        film_rows = case_rows(result)
        rows += film_rows
        off = [f"R{r['sphere_radius_mm']:g}/{r['force_kn']:g} kN" for r in film_rows if not r["agrees_with_pooled"]]
        print(f"{film}: pooled E {result.modulus_mpa['median']:.0f} MPa "
              f"[{result.modulus_mpa['ci90'][0]:.0f}, {result.modulus_mpa['ci90'][1]:.0f}]; "
              f"disagree: {', '.join(off) or 'none'}", flush=True)
    with open(out / "fig3_modulus_ranges.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    text = markdown(rows, results)
    (out / "fig3_modulus_ranges.md").write_text(text)
    print(text)
    print(f"wrote {out}/ in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
