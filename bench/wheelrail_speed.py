"""Speed of the half-space contact solver on wheel-rail sized grids.

Target: one solve with film springs on a 0.1 mm grid over a 24 x 24 mm region
(240 x 240 cells) in at most 1 s (median after a warm-up), so that the
wheel-rail model can run for every posterior sample of the film modulus.

Cases (quadratic gaps ``A x**2 + B y**2``, 100 kN, steel on steel):

* ``wheel-rail``: Hertz semi-axes about 7.5 x 5.4 mm (wheel radius 460 mm on
  a transversely curved rail head: A = 1/920, B = 1/500 per mm), region
  24 x 24 mm (240 x 240 cells);
* ``elongated``: Hertz semi-axes about 11.7 x 2.6 mm (a/b = 4.5), region
  32 x 16 mm (320 x 160 cells).

Each is solved with the HS film (E = 2800 MPa, nu = 0.33, t = 0.09 mm),
without film, and (for information, no target) with the film and a rough
wheel (Greenwood-Williamson law, Ra = 1.5 um, Newton iteration). "cold" is the first solve of a new solver, including the FFT of
the influence coefficients; "median" is over repeated solves from the default
start; "warm start" re-solves for a film modulus changed by 2 % starting from
the previous pressure (what a loop over posterior samples does).

With ``--accuracy`` it also prints the accuracy figures of the solver:

* grid convergence against Hertz for quadratic gaps with a/b = 1, 2, 3, 5
  (A = 1/920 per mm, a wheel of radius 460 mm; B from the eccentricity
  equation), F = 50 and 100 kN, cell sizes 0.25, 0.2, 0.1, 0.05 mm: errors
  of the sub-cell area, of the loaded-cell count, of the peak pressure and
  of the approach;
* contact radius ``sqrt(A/pi)`` of a steel sphere on a steel flat with a
  90 um film (nu = 0.33, E = 1000, 2800, 5000 MPa) for R = 300, 450, 600 mm
  and F = 25-100 kN, to compare with the axisymmetric finite-element model.

Wheel-rail problem (``filmcal.wheelrail.wheelrail``), always printed:

* one S1002/60E2 solve at eta = -3 mm, 100 kN with the HS film on the 0.1 mm
  grid: cold (new model: placement, sampled profiles, spectrum) and the
  median of repeated solves (what a loop over posterior samples costs);
  target <= 1 s median;
* the 20-case table of the paper (eta = -7 ... 2 mm in 1 mm steps, F = 50
  and 100 kN) without and with the film, from a new model: total time
  target <= 30 s, with the areas (FE edge reading and pressure > 0), the
  local Hertz area and the number of patches.

With ``--fe-table`` it prints the film representation against the
axisymmetric FE model (``filmcal.fem``, film tied to the flat and
frictionless at the sphere, 0.1 mm elements) on the ten Table 1 cases at
E = 1000, 2800 and 5000 MPa (nu = 0.33, t = 0.09 mm), and without film: the FE radius (edge
profile fit, ``filmcal.fem.result.read_contact_radius``) and the half-space
radius by three definitions: ``sqrt(A/pi)`` of the positive-pressure area,
the FE reading applied to the radial line of cells through the centre, and
``sqrt(A/pi)`` of the fitted outline (the definition the wheel-rail model
uses, ``filmcal.wheelrail.edge``); target |difference| <= 0.02 mm.

With ``--hertz-table`` it prints the wheel-rail areas without film against
the local Hertz solution for eta = -7 ... 2 mm in 0.5 mm steps.

Run: ``python bench/wheelrail_speed.py [--repeats 10] [--workers N] [--accuracy]
[--fe-table] [--hertz-table]``
"""
from __future__ import annotations

import argparse
import math
import statistics
import time

import numpy as np

from scipy.optimize import brentq

from filmcal.wheelrail.halfspace import (HalfSpaceContactSolver, SurfaceGrid,
                                         sphere_on_flat_contact)
from filmcal.wheelrail.hertz import hertz_elliptic
from filmcal.hertz import contact_modulus_mpa
from filmcal.wheelrail.edge import read_contact_edge, read_radial_edge_mm
from filmcal.wheelrail.interface import FilmLayer, GreenwoodWilliamsonLaw, InterfaceLaw
from filmcal.wheelrail.wheelrail import WheelRailModel

TARGET_S = 1.0
FORCE_N = 100e3
CASES = {  # gap coefficients A, B (1/mm) and region (mm)
    "wheel-rail": ((1.0 / 920.0, 1.0 / 500.0), (24.0, 24.0)),
    "elongated": ((1.0 / 2000.0, 1.0 / 200.0), (32.0, 16.0)),
}


def time_case(name: str, coefficients: tuple[float, float], region: tuple[float, float],
              film: FilmLayer | None, law: InterfaceLaw | None, repeats: int,
              workers: int | None) -> dict:
    """Cold, median and warm-start times of one case on a 0.1 mm grid."""
    grid = SurfaceGrid.centred(region[0], region[1], 0.1)
    x, y = grid.mesh()
    gap = coefficients[0] * x ** 2 + coefficients[1] * y ** 2
    solver = HalfSpaceContactSolver(workers=workers)
    start = time.perf_counter()
    first = solver.solve(gap, FORCE_N, grid, film=film, law=law)
    cold = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = solver.solve(gap, FORCE_N, grid, film=film, law=law)
        times.append(time.perf_counter() - start)
    warm = []
    if film is not None:
        previous = result.pressure_mpa
        for k in range(repeats):
            other = FilmLayer(film.modulus_mpa * (1.0 + 0.02 * ((-1) ** k)), film.poisson,
                              film.thickness_mm)
            start = time.perf_counter()
            warm_result = solver.solve(gap, FORCE_N, grid, film=other, law=law,
                                       initial_pressure_mpa=previous)
            warm.append(time.perf_counter() - start)
            previous = warm_result.pressure_mpa
    hertz = hertz_elliptic(*coefficients, FORCE_N, solver.contact_modulus_mpa)
    return {
        "case": name,
        "film": ("HS" if film is not None else "none") + ("+GW" if law is not None else ""),
        "cells": f"{grid.nx}x{grid.ny}", "iterations": first.iterations,
        "cold_s": cold, "median_s": statistics.median(times), "min_s": min(times),
        "max_s": max(times), "warm_median_s": statistics.median(warm) if warm else float("nan"),
        "area_mm2": first.area_mm2, "hertz_area_mm2": hertz.area_mm2,
        "max_pressure_mpa": first.max_pressure_mpa,
    }


def hertz_convergence_table(solver: HalfSpaceContactSolver) -> None:
    """Errors against Hertz on refining grids (see the module notes)."""
    a_coef = 1.0 / 920.0

    def ratio_for(aspect: float) -> float:
        if aspect == 1.0:
            return 1.0
        return brentq(lambda k: (lambda h: h.semi_axis_x_mm / h.semi_axis_y_mm)(
            hertz_elliptic(a_coef, a_coef * k, 1.0)) - aspect, 1.0 + 1e-9, 1e3)

    print("\nHertz versus solver (relative errors, %); A = 1/920 per mm")
    print(f"{'a/b':>4} {'F kN':>5} {'a mm':>6} {'b mm':>6} {'h mm':>5} {'b/h':>5} "
          f"{'area':>7} {'cells':>7} {'p0':>7} {'delta':>7} {'its':>4}")
    for aspect in (1.0, 2.0, 3.0, 5.0):
        b_coef = a_coef * ratio_for(aspect)
        for force in (50e3, 100e3):
            hz = hertz_elliptic(a_coef, b_coef, force, solver.contact_modulus_mpa)
            for spacing in (0.25, 0.2, 0.1, 0.05):
                grid = SurfaceGrid.centred(
                    2 * max(1.15 * hz.semi_axis_x_mm, hz.semi_axis_x_mm + 3 * spacing),
                    2 * max(1.15 * hz.semi_axis_y_mm, hz.semi_axis_y_mm + 3 * spacing), spacing)
                x, y = grid.mesh()
                res = solver.solve(a_coef * x ** 2 + b_coef * y ** 2, force, grid)
                print(f"{aspect:>4.0f} {force / 1e3:>5.0f} {hz.semi_axis_x_mm:>6.2f} "
                      f"{hz.semi_axis_y_mm:>6.2f} {spacing:>5.2f} "
                      f"{hz.semi_axis_y_mm / spacing:>5.1f} "
                      f"{100 * (res.area_mm2 / hz.area_mm2 - 1):>+7.3f} "
                      f"{100 * (res.area_cells_mm2 / hz.area_mm2 - 1):>+7.3f} "
                      f"{100 * (res.max_pressure_mpa / hz.max_pressure_mpa - 1):>+7.3f} "
                      f"{100 * (res.approach_mm / hz.approach_mm - 1):>+7.3f} "
                      f"{res.iterations:>4d}")


def film_sphere_table(solver: HalfSpaceContactSolver) -> None:
    """Equivalent contact radius of a sphere on a flat with a film in between."""
    print("\nSphere on flat with film (t = 0.09 mm, nu = 0.33, grid 0.1 mm): "
          "contact radius sqrt(A/pi) in mm, and error against Hertz (no film)")
    print(f"{'R mm':>5} {'F kN':>5} {'Hertz':>7} " + " ".join(
        f"{'E=' + str(int(e)):>15}" for e in (1000, 2800, 5000)))
    for radius in (300.0, 450.0, 600.0):
        for force in (25e3, 50e3, 75e3, 100e3):
            a = (3 * force * radius / (4 * solver.contact_modulus_mpa)) ** (1 / 3)
            cells = []
            for modulus in (1000.0, 2800.0, 5000.0):
                res = sphere_on_flat_contact(radius, force, film=FilmLayer(modulus),
                                             solver=solver)
                radius_eq = res.equivalent_radius_mm
                cells.append(f"{radius_eq:7.3f} ({radius_eq - a:+.3f})")
            print(f"{radius:>5.0f} {force / 1e3:>5.0f} {a:>7.3f} " + " ".join(cells))


HS_FILM = FilmLayer(2800.0, 0.33, 0.09)
PAPER_OFFSETS_MM = tuple(float(e) for e in range(-7, 3))
PAPER_FORCES_N = (50e3, 100e3)
TABLE_TARGET_S = 30.0
TABLE1_CASES = ((300, 25), (450, 25), (600, 25), (300, 50), (450, 50), (600, 50), (450, 75),
                (600, 75), (450, 100), (600, 100))


def wheel_rail_timing(repeats: int, workers: int | None) -> float:
    """Cold and median time of one wheel-rail solve with the HS film; returns the median."""
    model = WheelRailModel(solver=HalfSpaceContactSolver(workers=workers))
    start = time.perf_counter()
    first = model.solve(-3.0, 100e3, film=HS_FILM)
    cold = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        model.solve(-3.0, 100e3, film=HS_FILM)
        times.append(time.perf_counter() - start)
    median = statistics.median(times)
    print(f"\nwheel-rail S1002/60E2, eta = -3 mm, 100 kN, HS film, grid 0.1 mm "
          f"({first.grid.nx}x{first.grid.ny} cells, {first.contact.iterations} CG iterations): "
          f"cold {cold:.3f} s, median {median:.3f} s (min {min(times):.3f}, max {max(times):.3f}); "
          f"target {TARGET_S:.1f} s -> {'met' if median <= TARGET_S else 'NOT met'} "
          f"(ratio {TARGET_S / median:.1f}x); area {first.area_mm2:.2f} mm2")
    return median


def paper_table(workers: int | None) -> float:
    """The 20 cases of the paper without and with the HS film, from a new model; returns the total time."""
    model = WheelRailModel(solver=HalfSpaceContactSolver(workers=workers))
    print("\n20-case table (S1002/60E2, inclination 1/40, R0 460 mm, grid 0.1 mm); areas in mm2: "
          "A = contact area (FE edge reading with film), A>0 = pressure > 0")
    print(f"{'eta':>5} {'F kN':>5} | {'A':>7} {'A>0':>7} {'Hertz':>7} {'patch':>5} {'s':>5} | "
          f"{'A film':>7} {'A>0':>7} {'s':>5} | {'ratio':>6}")
    totals = {"none": 0.0, "film": 0.0}
    start_all = time.perf_counter()
    for force in PAPER_FORCES_N:
        for eta in PAPER_OFFSETS_MM:
            bare = model.solve(eta, force)
            film = model.solve(eta, force, film=HS_FILM)
            totals["none"] += bare.elapsed_s
            totals["film"] += film.elapsed_s
            hertz = bare.hertz.area_mm2 if bare.hertz is not None else float("nan")
            print(f"{eta:>5.1f} {force / 1e3:>5.0f} | {bare.area_mm2:>7.2f} {bare.support_area_mm2:>7.2f} "
                  f"{hertz:>7.2f} {bare.n_patches:>5d} {bare.elapsed_s:>5.2f} | {film.area_mm2:>7.2f} "
                  f"{film.support_area_mm2:>7.2f} {film.elapsed_s:>5.2f} | "
                  f"{film.area_mm2 / bare.area_mm2:>6.3f}")
    total = time.perf_counter() - start_all
    print(f"total {total:.1f} s (without film {totals['none']:.1f} s, with film {totals['film']:.1f} s); "
          f"target {TABLE_TARGET_S:.0f} s -> {'met' if total <= TABLE_TARGET_S else 'NOT met'} "
          f"(ratio {TABLE_TARGET_S / total:.1f}x)")
    return total


def fe_film_table(workers: int | None) -> None:
    """Film springs of the half-space model against the axisymmetric FE model (30 cases)."""
    from filmcal.fem import Film, get_model

    solver = HalfSpaceContactSolver(workers=workers)
    print("\nFilm representation against the axisymmetric FE model (t = 0.09 mm, nu = 0.33, "
          "grid/elements 0.1 mm); radii in mm")
    print("  FE: edge-profile fit of the FE pressures; BEM: sqrt(A/pi) of p > 0 | FE reading on "
          "the radial line of cells | sqrt(A/pi) of the fitted outline (wheel-rail definition)")
    print(f"{'R':>4} {'F kN':>5} {'E MPa':>6} {'FE':>8} | {'p>0':>8} {'diff':>7} | {'line':>8} "
          f"{'diff':>7} | {'outline':>8} {'diff':>7}")
    worst = {"support": 0.0, "line": 0.0, "outline": 0.0}
    for radius, force_kn in TABLE1_CASES:
        model = get_model(float(radius))
        for modulus in (1000.0, 2800.0, 5000.0, None):
            fe = model.solve(None if modulus is None else Film(modulus, 0.33), force_kn * 1e3)
            film = None if modulus is None else FilmLayer(modulus, 0.33, 0.09)
            bem = sphere_on_flat_contact(radius, force_kn * 1e3, film=film, solver=solver)
            grid = bem.grid
            row = bem.pressure_mpa[grid.nx // 2]
            half = grid.y_mm >= 0.0
            radii = {"support": bem.equivalent_radius_mm,
                     "line": read_radial_edge_mm(grid.y_mm[half], row[half]),
                     "outline": math.sqrt(read_contact_edge(bem).area_mm2 / math.pi)}
            diff = {k: v - fe.contact_radius_mm for k, v in radii.items()}
            for k, v in diff.items():
                worst[k] = max(worst[k], abs(v))
            label = "none" if modulus is None else f"{modulus:.0f}"
            print(f"{radius:>4d} {force_kn:>5d} {label:>6} {fe.contact_radius_mm:>8.4f} | "
                  f"{radii['support']:>8.4f} {diff['support']:>+7.4f} | {radii['line']:>8.4f} "
                  f"{diff['line']:>+7.4f} | {radii['outline']:>8.4f} {diff['outline']:>+7.4f}")
    print("largest |difference| (target 0.02 mm): " + ", ".join(
        f"{k} {v:.4f} mm ({'met' if v <= 0.02 else 'NOT met'})" for k, v in worst.items()))


def hertz_table(workers: int | None) -> None:
    """Wheel-rail contact without film against the local Hertz solution."""
    model = WheelRailModel(solver=HalfSpaceContactSolver(workers=workers))
    print("\nWheel-rail without film against local Hertz (S1002/60E2, 1/40, 0.1 mm grid); "
          "'Hertz-like': one patch, one contact point, relative curvature within x2 over the ellipse")
    print(f"{'F kN':>5} {'eta':>5} {'y_c':>7} {'theta':>6} {'A':>8} {'Hertz':>8} {'dev %':>7} "
          f"{'p0':>6} {'p0 H':>6} {'patches':>7} {'Hertz-like':>10}")
    worst = 0.0
    for force in PAPER_FORCES_N:
        for eta in np.arange(-7.0, 2.01, 0.5):
            res = model.solve(float(eta), force)
            hz = res.hertz
            dev = 100.0 * (res.area_mm2 / hz.area_mm2 - 1.0) if hz is not None else float("nan")
            if res.hertz_like:
                worst = max(worst, abs(dev))
            point = res.placement.contact
            print(f"{force / 1e3:>5.0f} {eta:>5.1f} {point.y_mm:>7.2f} "
                  f"{math.degrees(point.contact_angle_rad):>6.2f} {res.area_mm2:>8.2f} "
                  f"{hz.area_mm2 if hz else float('nan'):>8.2f} {dev:>+7.2f} "
                  f"{res.max_pressure_mpa:>6.0f} {hz.max_pressure_mpa if hz else float('nan'):>6.0f} "
                  f"{res.n_patches:>7d} {str(res.hertz_like):>10}")
    print(f"largest |deviation| over the Hertz-like cases: {worst:.2f} % (target 3 %)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=10,
                        help="timed solves per case after the cold one (default 10)")
    parser.add_argument("--workers", type=int, default=None,
                        help="FFT threads (default: all CPUs)")
    parser.add_argument("--accuracy", action="store_true",
                        help="also print the Hertz grid-convergence and film sphere tables")
    parser.add_argument("--fe-table", action="store_true",
                        help="also print the film representation against the axisymmetric FE "
                             "model (30 cases)")
    parser.add_argument("--hertz-table", action="store_true",
                        help="also print the wheel-rail areas against local Hertz over eta")
    args = parser.parse_args()
    film = FilmLayer(2800.0, 0.33, 0.09)
    rough = GreenwoodWilliamsonLaw(1.5, contact_modulus_mpa(2800.0, 0.33, 210000.0, 0.3))
    rows = [time_case(name, coefs, region, f, law, args.repeats, args.workers)
            for name, (coefs, region) in CASES.items()
            for f, law in ((film, None), (None, None), (film, rough))]
    header = (f"{'case':<11} {'film':<7} {'cells':<8} {'its':>4} {'cold s':>7} "
              f"{'median s':>9} {'min s':>6} {'max s':>6} {'warm s':>7} {'target/median':>13} "
              f"{'area mm2':>9} {'Hertz':>8} {'p0 MPa':>7}")
    print(header)
    for r in rows:
        print(f"{r['case']:<11} {r['film']:<7} {r['cells']:<8} {r['iterations']:>4d} "
              f"{r['cold_s']:>7.3f} {r['median_s']:>9.3f} {r['min_s']:>6.3f} {r['max_s']:>6.3f} "
              f"{r['warm_median_s']:>7.3f} {TARGET_S / r['median_s']:>13.1f} "
              f"{r['area_mm2']:>9.2f} {r['hertz_area_mm2']:>8.2f} {r['max_pressure_mpa']:>7.1f}")
    worst = max(r["median_s"] for r in rows if r["film"] == "HS")
    print(f"slowest film solve: median {worst:.3f} s, target {TARGET_S:.1f} s -> "
          f"{'met' if worst <= TARGET_S else 'NOT met'} (ratio {TARGET_S / worst:.1f}x)")
    wheel_rail_timing(args.repeats, args.workers)
    paper_table(args.workers)
    if args.accuracy:
        solver = HalfSpaceContactSolver(workers=args.workers)
        hertz_convergence_table(solver)
        film_sphere_table(solver)
    if args.fe_table:
        fe_film_table(args.workers)
    if args.hertz_table:
        hertz_table(args.workers)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
