"""The paper's Fig. 1 in kind: the axisymmetric FE model of the Hertzian
experiments for the R300 sphere, with the film between sphere and flat.

The mesh is the one `filmcal.fem.SphereOnFlat` solves on (default
`MeshSettings`: 50 x 50 mm bodies, 0.1 mm elements in the contact zone
grading to 1.25 mm, one 90 um layer of 0.1 mm wide film elements). The figure
shows the whole model and two zooms: on the axis, where the film is
compressed most, and at the edge of the Hertz contact, where the sphere lifts
off the film. The model is then solved once with an HS-like film
(E = 2800 MPa, nu = 0.33; 75 kN by default -- the experiments loaded R300 only
up to 50 kN, the FE model is linear elastic) to draw the compressed film on
the axis zoom and the film's thickness and pressure along r.

    python examples/fig1_model_mesh.py [--sphere-radius-mm 300] [--force-kn 75]
        [--film-modulus-mpa 2800] [--out-dir out/fig1_model_mesh]

Writes fig1_model_mesh.png, fig1_film_under_load.png, pressure_profile.png,
fig1_mesh_summary.csv / .md and film_profile.csv.
"""
from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from filmcal._validation import check_positive
from filmcal.fem import ContactOptions, Film, FEResult, SphereOnFlat
from filmcal.fem.mesh import BodyGrid
from filmcal.report.figures import plot_pressure_profile

BODY_COLOURS = {"sphere": "#c9d6e8", "film": "#f2a541", "flat": "#d9d9d9"}


def bodies(model: SphereOnFlat) -> dict[str, BodyGrid]:
    return {"sphere": model.sphere, "film": model.film, "flat": model.flat}


def draw_mesh(ax, grids: dict[str, BodyGrid], lw: float) -> None:
    """Quad elements of each body, filled in its colour, edges in black."""
    for name, grid in grids.items():
        quads = grid.mesh.p[:, grid.mesh.t].transpose(2, 1, 0)  # (n_elements, 4 corners, (r, z))
        ax.add_collection(PolyCollection(quads, facecolors=BODY_COLOURS[name], edgecolors="k", linewidths=lw,
                                         label=name))


def element_sizes(grid: BodyGrid) -> tuple[float, float]:
    """Smallest and largest radial element size of a body (mm)."""
    r = grid.mesh.p[0, grid.node_at[:, 0]]
    dr = np.diff(r)
    return float(dr.min()), float(dr.max())


def mesh_summary(model: SphereOnFlat) -> list[dict]:
    rows = []
    for name, grid in bodies(model).items():
        h_min, h_max = element_sizes(grid)
        r_lo, r_hi = grid.mesh.p[0].min() + 0.0, grid.mesh.p[0].max() + 0.0
        z_lo, z_hi = grid.mesh.p[1].min() + 0.0, grid.mesh.p[1].max() + 0.0
        rows.append({"body": name, "elements": grid.mesh.t.shape[1], "nodes": grid.mesh.p.shape[1],
                     "r_extent_mm": f"{r_lo:g}-{r_hi:g}", "z_extent_mm": f"{z_lo:.3f}-{z_hi:.3f}",
                     "min_radial_element_mm": round(h_min, 4), "max_radial_element_mm": round(h_max, 4),
                     "contact_zone_mm": round(float(grid.r_face_mm[-1]), 4)})
    return rows


def plot_mesh(model: SphereOnFlat, result: FEResult, path: Path) -> None:
    """Whole model, zoom on the axis (with the compressed film) and zoom at the Hertz contact edge."""
    grids = bodies(model)
    t = model.film_thickness_mm
    fig = Figure(figsize=(13, 5.2), layout="constrained")
    axes = fig.subplots(1, 3, width_ratios=[1.0, 1.2, 1.2])
    a_h, a_f = result.hertz_radius_mm, result.contact_radius_mm
    views = [("whole model", (0.0, model.mesh.body_size_mm), None, 0.15),
             ("zoom on the axis", (0.0, 1.0), (-0.35, 0.45), 0.6),
             ("zoom at the contact edge", (a_h - 0.4, a_f + 0.6), (-0.35, 0.6), 0.6)]
    for ax, (title, r_lim, z_lim, lw) in zip(axes, views):
        draw_mesh(ax, grids, lw)
        ax.set_xlim(*r_lim)
        if z_lim is None:
            ax.set_ylim(-model.mesh.body_size_mm - 1, model.mesh.body_size_mm + t + 1)
        else:
            ax.set_ylim(*z_lim)
        ax.set_aspect("equal")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("r (mm)")
    axes[0].set_ylabel("z (mm)")
    compressed = t * (1.0 + result.film_strain)
    axes[1].plot(result.r_mm, compressed, "-", color="tab:red", lw=2,
                 label=f"film top under {result.force_n / 1e3:g} kN\n(relative to its bottom; "
                       f"strain {result.film_strain_max:.0%})")
    axes[1].legend(handles=axes[1].lines, fontsize=8, loc="upper right")
    for x, style, label in ((a_h, "-.", "a Hertz, no film"), (a_f, "--", "a with film")):
        axes[2].axvline(x, color="tab:red", ls=style, lw=1.2, label=f"{label} = {x:.2f} mm")
    axes[2].legend(handles=axes[2].lines, fontsize=8, loc="upper left")
    handles = list(axes[0].collections)
    fig.legend(handles, [h.get_label() for h in handles], loc="outside lower center", ncol=3, fontsize=9)
    fig.suptitle(f"Axisymmetric model, sphere R{model.sphere_radius_mm:g} on flat with a {1000 * t:g} um film: "
                 f"{sum(g.mesh.t.shape[1] for g in grids.values())} elements, {model.n_dofs} DOFs", fontsize=11)
    fig.savefig(path, dpi=150)


def plot_film(result: FEResult, thickness_mm: float, path: Path) -> None:
    """Film thickness and through-thickness strain along r, with the contact pressure."""
    fig = Figure(figsize=(7.5, 4.2), layout="constrained")
    ax = fig.subplots()
    ax.plot(result.r_mm, 1000 * thickness_mm * (1 + result.film_strain), "-", color="tab:red",
            label="film thickness under load")
    ax.axhline(1000 * thickness_mm, color="k", ls=":", lw=1, label="unloaded thickness")
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("film thickness (um)")
    ax.set_xlim(0, 1.3 * result.contact_radius_mm)
    ax_p = ax.twinx()
    ax_p.plot(result.r_mm, result.pressure_mpa, "-", color="tab:blue", lw=1, label="contact pressure")
    ax_p.set_ylabel("contact pressure (MPa)", color="tab:blue")
    for x, style, label in ((result.contact_radius_mm, "--", "a with film"),
                            (result.hertz_radius_mm, "-.", "a Hertz, no film")):
        ax.axvline(x, color="0.4", ls=style, lw=1, label=f"{label} = {x:.2f} mm")
    ax.legend(fontsize=8, loc="center left")
    ax.grid(lw=0.3)
    ax.set_title(f"R{result.radius_mm:g}, {result.force_n / 1e3:g} kN, film E = {result.film_modulus_mpa:g} MPa, "
                 f"nu = {result.film_poisson:g}", fontsize=10)
    fig.savefig(path, dpi=130)


def write_csv(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sphere-radius-mm", type=float, default=300.0, help="sphere radius R (mm), default 300")
    ap.add_argument("--force-kn", type=float, default=75.0, help="normal force F (kN) of the solve, default 75")
    ap.add_argument("--film-modulus-mpa", type=float, default=2800.0, help="film E (MPa), default 2800")
    ap.add_argument("--film-poisson", type=float, default=0.33, help="film nu, default 0.33")
    ap.add_argument("--out-dir", default="out/fig1_model_mesh", help="output folder")
    args = ap.parse_args()
    force_n = 1e3 * check_positive("force_kn", args.force_kn)
    film = Film(args.film_modulus_mpa, args.film_poisson)
    t0 = time.perf_counter()
    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    print(f"building the R{args.sphere_radius_mm:g} model ...", flush=True)
    model = SphereOnFlat(args.sphere_radius_mm)
    print(f"built in {model.setup_time_s:.1f} s: {model.n_dofs} DOFs, {model.n_face} contact-face nodes", flush=True)
    result = model.solve(film, force_n, ContactOptions())
    if not result.converged:
        raise SystemExit(f"the FE solve did not converge: {result.reason}")
    print(f"solved in {result.elapsed_s:.2f} s: a = {result.contact_radius_mm:.3f} mm (Hertz "
          f"{result.hertz_radius_mm:.3f} mm, error {result.radius_error_mm:+.3f} mm), max pressure "
          f"{result.max_pressure_mpa:.0f} MPa, film strain on the axis {-result.film_strain[0]:.1%}", flush=True)
    summary = mesh_summary(model)
    write_csv(summary, out / "fig1_mesh_summary.csv")
    keys = list(summary[0])
    (out / "fig1_mesh_summary.md").write_text("\n".join(
        ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
        + ["| " + " | ".join(str(row[k]) for k in keys) + " |" for row in summary]) + "\n")
    for row in summary:
        print("  " + ", ".join(f"{k} {v}" for k, v in row.items()))
    write_csv([{"r_mm": r, "pressure_mpa": p, "film_strain": e,
                "film_thickness_mm": model.film_thickness_mm * (1 + e)}
               for r, p, e in zip(result.r_mm, result.pressure_mpa, result.film_strain)], out / "film_profile.csv")
    plot_mesh(model, result, out / "fig1_model_mesh.png")
    plot_film(result, model.film_thickness_mm, out / "fig1_film_under_load.png")
    plot_pressure_profile(result, str(out / "pressure_profile.png"))
    print(f"wrote {out}/ in {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
