"""The paper's preliminary study (section 2.1, Fig. 2): how much do the film's
Young's modulus E and Poisson's ratio nu move the contact area?

A 100-point optimal Latin hypercube over E (50-5000 MPa) and nu (0-0.49) is run
through the FE model for the two corner cases of the experiments, R300 / 25 kN
and R600 / 100 kN (frictionless at the sphere, film tied to the flat, small
strain), as a resumable campaign; failed runs (films so soft that they
collapse) stay in the record. The figure shows the contact area over (E, nu)
like the paper's Fig. 2, failures marked.

    python examples/fig2_preliminary_study.py [--out-dir out/fig2] [--samples 100] [--workers N]

Writes design.csv, runs.sqlite, runs.csv and fig2_area_vs_e_nu.png; running it
again reuses the finished runs.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from filmcal.campaign import Campaign, LocalPoolExecutor
from filmcal.doe import DesignSpace, Parameter, latin_design, write_design_csv
from filmcal.fem import evaluate_point

CASES = ((300.0, 25.0), (600.0, 100.0))


def run(out: Path, samples: int, workers: int | None, seed: int):
    space = DesignSpace((Parameter("modulus_mpa", 50.0, 5000.0, unit="MPa"),
                         Parameter("poisson", 0.0, 0.49)))
    design = latin_design(space, samples, seed=seed)
    write_design_csv(out / "design.csv", ["modulus_mpa", "poisson"], design.points)
    points = [dict(modulus_mpa=float(e), poisson=float(nu), sphere_radius_mm=r, force_kn=f)
              for r, f in CASES for e, nu in design.points]
    executor = LocalPoolExecutor(workers)
    try:
        campaign = Campaign(evaluate_point, out / "runs.sqlite", model_name="filmcal.fem:evaluate_point",
                            executor=executor)
        summary = campaign.run(points)
        campaign.export_csv(out / "runs.csv")
        return design, campaign.results(status=None), summary
    finally:
        executor.shutdown()


def _case(results, r, f):
    inp = results.inputs
    return (inp["sphere_radius_mm"] == r) & (inp["force_kn"] == f)


def smooth_residual_mm2(x: np.ndarray, area: np.ndarray) -> float:
    """RMS residual of the area about a cubic in log(x): how much x alone explains."""
    coef = np.polyfit(np.log(x), area, 3)
    return float(np.sqrt(np.mean((area - np.polyval(coef, np.log(x))) ** 2)))


def plot(results, path: Path) -> None:
    from matplotlib.figure import Figure

    from filmcal.fem import hertz_radius_mm, oedometric_modulus_mpa

    fig = Figure(figsize=(11, 8), layout="constrained")
    axes = fig.subplots(2, 2)
    inp, outp = results.inputs, results.outputs
    ok = results.status == "ok"
    for row, (r, f) in zip(axes, CASES):
        case = _case(results, r, f)
        good, bad = case & ok, case & ~ok
        e, nu, area = inp["modulus_mpa"][good], inp["poisson"][good], outp["contact_area_mm2"][good]
        a_h = hertz_radius_mm(r, f * 1e3)
        sc = row[0].scatter(e, area, c=nu, cmap="viridis", s=30, edgecolor="k", linewidth=0.3, vmin=0, vmax=0.49)
        fig.colorbar(sc, ax=row[0], label="film Poisson's ratio nu")
        row[1].scatter(oedometric_modulus_mpa(e, nu), area, c=nu, cmap="viridis", s=30, edgecolor="k",
                       linewidth=0.3, vmin=0, vmax=0.49)
        for ax in row:
            ax.axhline(np.pi * a_h**2, color="k", ls="--", lw=0.8, label="Hertz (no film)")
            ax.set_xscale("log")
            ax.set_ylabel("contact area (mm$^2$)")
            ax.grid(lw=0.3, which="both")
        if bad.any():
            row[0].plot(inp["modulus_mpa"][bad], np.full(bad.sum(), np.pi * a_h**2), "rx",
                        label=f"failed ({bad.sum()}): film collapsed")
        row[0].set_xlabel("film Young's modulus E (MPa)")
        row[1].set_xlabel("film oedometric modulus M = E(1-nu)/((1+nu)(1-2nu)) (MPa)")
        row[0].set_title(f"R{r:g}, {f:g} kN: area over E (colour: nu)")
        row[1].set_title(f"R{r:g}, {f:g} kN: the same runs over M")
        row[0].legend(fontsize=8)
    fig.savefig(path, dpi=130)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out-dir", default="out/fig2")
    ap.add_argument("--samples", type=int, default=100)
    ap.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    design, results, summary = run(out, args.samples, args.workers, args.seed)
    plot(results, out / "fig2_area_vs_e_nu.png")
    print(f"design: min distance {design.quality.min_distance:.3f}, phi_50 {design.quality.phi_p:.3f}")
    print(f"runs: {summary}")
    from filmcal.fem import oedometric_modulus_mpa
    ok = results.status == "ok"
    for r, f in CASES:
        case = _case(results, r, f) & ok
        e, nu = results.inputs["modulus_mpa"][case], results.inputs["poisson"][case]
        area = results.outputs["contact_area_mm2"][case]
        print(f"R{r:g}/{f:g} kN: {case.sum()} ok, area {area.min():.1f}-{area.max():.1f} mm2; scatter about a "
              f"smooth curve in E alone {smooth_residual_mm2(e, area):.2f} mm2, in M alone "
              f"{smooth_residual_mm2(oedometric_modulus_mpa(e, nu), area):.3f} mm2")
    print(f"wrote {out / 'fig2_area_vs_e_nu.png'}")


if __name__ == "__main__":
    main()
