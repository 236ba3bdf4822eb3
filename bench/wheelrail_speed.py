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

Run: ``python bench/wheelrail_speed.py [--repeats 10] [--workers N] [--accuracy]``
"""
from __future__ import annotations

import argparse
import statistics
import time

from scipy.optimize import brentq

from filmcal.wheelrail.halfspace import (HalfSpaceContactSolver, SurfaceGrid,
                                         sphere_on_flat_contact)
from filmcal.wheelrail.hertz import hertz_elliptic
from filmcal.hertz import contact_modulus_mpa
from filmcal.wheelrail.interface import FilmLayer, GreenwoodWilliamsonLaw, InterfaceLaw

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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=10,
                        help="timed solves per case after the cold one (default 10)")
    parser.add_argument("--workers", type=int, default=None,
                        help="FFT threads (default: all CPUs)")
    parser.add_argument("--accuracy", action="store_true",
                        help="also print the Hertz grid-convergence and film sphere tables")
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
    if args.accuracy:
        solver = HalfSpaceContactSolver(workers=args.workers)
        hertz_convergence_table(solver)
        film_sphere_table(solver)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
