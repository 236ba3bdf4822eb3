"""Wheel-rail contact area with and without Prescale film: the paper's Figs. 6 and 7 in kind.

S1002 wheel (nominal radius 460 mm) on a 60E2 rail inclined 1:40, vertical
loads F = 50 and 100 kN, lateral offsets eta = -7 ... +2 mm (0.5 mm steps by
default, the paper's 1 mm steps included), three models as in the paper's
section 2.2:

* no film (hard steel-on-steel contact);
* HS film at its calibrated median under its preferred model (`HS_MODULUS_MPA`,
  edge reading, large strain), as `filmcal wheelrail` and the corrector solve
  it (`filmcal.wheelrail.film_contact.solve_film_contact`: the film law of
  `FilmModel.interface`, its reading and the transfer term);
* the same film on a rough wheel (Ra 1.5 um; the boundary-element law of the
  representative conditioned roughness inputs, in series with the film).

The area without film (``contact_area_mm2``) is the solver's zero-pressure
outline; a film's area is its imprint as calibrated
(``calibrated_imprint_area_mm2``: the imprint model's reading plus the transfer
term, whose standard deviation the CSV carries). Run::

    python examples/wheelrail_figures.py [--out-dir out/wheelrail_figures] [--step-mm 0.5]
                                         [--rail 60E2]

Writes into the output folder:

* ``wheelrail_area_curves.csv`` -- one row per (F, eta, model): areas, peak
  pressure, number of patches, centroid, local Hertz area (no film) and
  whether the case is Hertz-like;
* ``fig6_area_vs_offset.png`` -- A(eta) for both loads and the three models,
  and the ratio of the film areas to the area without film (the
  measurement error the film introduces);
* ``fig7_outlines_50kN.png`` -- contact outlines without (solid) and with
  (dashed) film at 50 kN for eta = -7 ... +2 mm in 1 mm steps, with the
  rail profile joints;
* ``hertz_comparison.png`` -- the area without film against the local Hertz
  solution.
"""
from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from filmcal.wheelrail.film_contact import FilmContactCase, WheelRoughness, solve_film_contact
from filmcal.wheelrail.wheelrail import WheelRailResult

FORCES_KN = (50.0, 100.0)
#: HS's posterior median under its preferred model (edge, large strain) in the full study (`filmcal pipeline`,
#: 27 Nov 2026), the modulus the shipped roughness conditioning used.
HS_MODULUS_MPA = 2564.0
HS_FILM = FilmContactCase(HS_MODULUS_MPA, film="HS", imprint_model="edge", kinematics="large")
MODELS = {
    "no film": (FilmContactCase(None), None),
    "HS film": (HS_FILM, None),
    "HS film + rough wheel": (HS_FILM, WheelRoughness(ra_um=1.5)),
}
STYLE = {"no film": ("tab:blue", "o"), "HS film": ("tab:orange", "s"),
         "HS film + rough wheel": ("tab:green", "^")}


def area_mm2(summary: dict) -> float:
    """A film's imprint as calibrated, or the area without film."""
    return float(summary.get("calibrated_imprint_area_mm2", summary["contact_area_mm2"]))


def solve_all(rail: str, offsets_mm: np.ndarray) -> dict:
    """``(result, summary)`` of `solve_film_contact`, keyed by (force_kn, model name, eta)."""
    results = {}
    for force in FORCES_KN:
        for eta in offsets_mm:
            for name, (case, roughness) in MODELS.items():
                results[(force, name, float(eta))] = solve_film_contact(float(eta), force * 1e3, case, roughness,
                                                                        rail=rail)
            line = " ".join(f"{name}: {area_mm2(results[(force, name, float(eta))][1]):7.2f}"
                            for name in MODELS)
            print(f"F = {force:5.0f} kN, eta = {eta:+5.1f} mm | {line} mm2", flush=True)
    return results


def write_csv(results: dict, path: Path) -> None:
    """One row per case."""
    fields = ["force_kn", "offset_mm", "model", "contact_area_mm2", "transfer_std_mm2",
              "max_pressure_mpa", "n_patches", "centroid_y_mm", "centroid_rail_y_mm",
              "centroid_wheel_y_mm", "contact_angle_deg", "hertz_area_mm2", "hertz_like",
              "converged", "elapsed_s"]
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for (force, name, eta), (res, summary) in sorted(results.items(),
                                                          key=lambda kv: (kv[0][0], kv[0][1], kv[0][2])):
            writer.writerow({
                "force_kn": force, "offset_mm": eta, "model": name,
                "contact_area_mm2": f"{area_mm2(summary):.4f}",
                "transfer_std_mm2": f"{summary['transfer_std_mm2']:.4f}" if "transfer_std_mm2" in summary else "",
                "max_pressure_mpa": f"{res.max_pressure_mpa:.2f}", "n_patches": res.n_patches,
                "centroid_y_mm": f"{res.centroid_y_mm:.4f}",
                "centroid_rail_y_mm": f"{res.centroid_rail_y_mm:.4f}",
                "centroid_wheel_y_mm": f"{res.centroid_wheel_y_mm:.4f}",
                "contact_angle_deg": f"{math.degrees(res.contact_angle_rad):.4f}",
                "hertz_area_mm2": "" if res.hertz is None or res.film is not None
                else f"{res.hertz.area_mm2:.4f}",
                "hertz_like": res.hertz_like if res.film is None else "",
                "converged": res.converged, "elapsed_s": f"{res.elapsed_s:.3f}"})


def _areas(results: dict, force: float, name: str, offsets: np.ndarray) -> np.ndarray:
    return np.array([area_mm2(results[(force, name, float(e))][1]) for e in offsets])


def plot_area_curves(results: dict, offsets: np.ndarray, path: Path) -> None:
    """Fig. 6 analog: A(eta) per load and model, and the film's area ratio."""
    fig = Figure(figsize=(11, 7.5), layout="constrained")
    axes = fig.subplots(2, 2, sharex=True)
    for col, force in enumerate(FORCES_KN):
        ax = axes[0, col]
        for name in MODELS:
            color, marker = STYLE[name]
            label = name
            ax.plot(offsets, _areas(results, force, name, offsets), "-", color=color,
                    marker=marker, ms=4, label=label)
        ax.set_title(f"F = {force:g} kN")
        ax.set_ylabel("contact area A (mm$^2$)")
        ax.grid(True, lw=0.3)
        ratio_ax = axes[1, col]
        bare = _areas(results, force, "no film", offsets)
        for name in ("HS film", "HS film + rough wheel"):
            color, marker = STYLE[name]
            ratio_ax.plot(offsets, _areas(results, force, name, offsets) / bare, "-",
                          color=color, marker=marker, ms=4, label=name)
        ratio_ax.set_xlabel("lateral offset $\\eta$ (mm), flange towards the gauge corner $\\rightarrow$")
        ratio_ax.set_ylabel("A / A(no film, smooth)")
        ratio_ax.grid(True, lw=0.3)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncol=2, fontsize=8)
    fig.suptitle("S1002 on 60E2 (1:40, R0 = 460 mm): contact area with and without HS film "
                 f"(E = {HS_MODULUS_MPA:g} MPa, $\\nu$ = 0.33, t = 90 $\\mu$m, edge reading; "
                 "rough wheel Ra 1.5 $\\mu$m)", fontsize=10)
    fig.savefig(path, dpi=150)


def _rail_joints_track_y(res: WheelRailResult) -> list[float]:
    """Track y of the rail profile joints (section bounds) inside the placement overlap."""
    placement = res.placement
    theta = math.atan(placement.rail_inclination)
    lo, hi = placement.y_range_mm
    out = []
    for sec in placement.rail.sections[1:]:
        u = sec.y_start_mm
        y = u * math.cos(theta) - float(placement.rail.z(u)) * math.sin(theta)
        if lo < y < hi:
            out.append(y)
    return out


def plot_outlines(results: dict, offsets: np.ndarray, force: float, path: Path) -> None:
    """Fig. 7 analog: outlines with and without film, one panel per offset."""
    shown = [e for e in offsets if abs(e - round(e)) < 1e-9]
    ncol = 5
    nrow = int(math.ceil(len(shown) / ncol))
    fig = Figure(figsize=(2.6 * ncol, 3.3 * nrow), layout="constrained")
    axes = np.atleast_2d(fig.subplots(nrow, ncol, sharex=True, sharey=True))
    rings = [ring for eta in shown for name in ("no film", "HS film")
             for ring in results[(force, name, float(eta))][0].outline_mm]
    y_lo = min(float(r[:, 1].min()) for r in rings) - 1.5
    y_hi = max(float(r[:, 1].max()) for r in rings) + 1.5
    x_hi = max(float(np.abs(r[:, 0]).max()) for r in rings) + 1.0
    for ax, eta in zip(axes.flat, shown):
        bare = results[(force, "no film", float(eta))][0]
        film = results[(force, "HS film", float(eta))][0]
        for y in _rail_joints_track_y(bare):
            ax.axvline(y, color="0.6", lw=0.8, ls="-.")
        for res, style, label in ((bare, "-", "no film"), (film, "--", "HS film")):
            for k, ring in enumerate(res.outline_mm):
                ax.plot(ring[:, 1], ring[:, 0], style, color="k" if res is bare else "tab:orange",
                        lw=1.2, label=label if k == 0 else None)
        point = bare.placement.contact
        ax.plot(point.y_mm, 0.0, "+", color="tab:red", ms=8)
        a_film = area_mm2(results[(force, "HS film", float(eta))][1])
        ax.set_title(f"$\\eta$ = {eta:+g} mm\nA = {bare.area_mm2:.0f} / {a_film:.0f} mm$^2$",
                     fontsize=8)
        ax.set_xlim(y_lo, y_hi)
        ax.set_ylim(-x_hi, x_hi)
        ax.set_aspect("equal")
        ax.grid(True, lw=0.3)
    for ax in axes.flat[len(shown):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("y (mm), field side $\\rightarrow$")
    for ax in axes[:, 0]:
        ax.set_ylabel("x (mm), along the rail")
    axes.flat[0].legend(fontsize=7, loc="lower left")
    fig.suptitle(f"Contact outlines at F = {force:g} kN without (solid) and with HS film (dashed); "
                 "+ first contact point, dash-dotted: rail profile joints (R200 | R70)", fontsize=10)
    fig.savefig(path, dpi=150)


def plot_hertz(results: dict, offsets: np.ndarray, path: Path) -> None:
    """Area without film against the local Hertz solution."""
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    for force, color in zip(FORCES_KN, ("tab:blue", "tab:red")):
        res = [results[(force, "no film", float(e))][0] for e in offsets]
        ax.plot(offsets, [r.area_mm2 for r in res], "-o", color=color, ms=4,
                label=f"{force:g} kN, half-space solution")
        hertz = np.array([r.hertz.area_mm2 if r.hertz is not None else np.nan for r in res])
        like = np.array([r.hertz_like for r in res])
        ax.plot(offsets, hertz, ":", color=color, lw=1.0, label=f"{force:g} kN, local Hertz")
        ax.plot(offsets[like], hertz[like], "x", color=color, ms=7,
                label=f"{force:g} kN, Hertz-like cases")
    ax.set_xlabel("lateral offset $\\eta$ (mm)")
    ax.set_ylabel("contact area without film (mm$^2$)")
    ax.set_title("Local Hertz applies on the crown (one point, relative curvature within x2);\n"
                 "near-conformal at eta -1.5 ... -0.5, two points merge at eta = 0, "
                 "the R200 | R70 joint for eta > 0", fontsize=9)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.savefig(path, dpi=150)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out-dir", default="out/wheelrail_figures", help="output folder")
    parser.add_argument("--step-mm", type=float, default=0.5, choices=(0.5, 1.0),
                        help="offset step (mm): 0.5 (default) or 1 (the paper's)")
    parser.add_argument("--rail", default="60E2", choices=("60E2", "60E1"), help="rail profile")
    args = parser.parse_args()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    offsets = np.round(np.arange(-7.0, 2.0 + 1e-9, args.step_mm), 6)
    start = time.perf_counter()
    results = solve_all(args.rail, offsets)
    write_csv(results, out / "wheelrail_area_curves.csv")
    plot_area_curves(results, offsets, out / "fig6_area_vs_offset.png")
    plot_outlines(results, offsets, 50.0, out / "fig7_outlines_50kN.png")
    plot_hertz(results, offsets, out / "hertz_comparison.png")
    print(f"{len(results)} cases in {time.perf_counter() - start:.1f} s; wrote {out}/")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
