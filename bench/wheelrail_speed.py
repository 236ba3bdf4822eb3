"""Speed of the wheel-rail contact solve, with iteration and FFT counts and a peer.

Default output (the acceptance figures of the speed work):

* ``acceptance``: S1002 on 60E2, eta = -3 mm, 50 kN, 0.1 mm grid, with the
  HS film (E = 2800 MPa, the paper's HS match; nu and thickness from the film
  registry) and without film: one warm-up solve, then 5 solves; median
  ``elapsed_s`` of the wheel-rail result (targets 0.1 s with film, 0.15 s
  without), median ``time.process_time`` per solve, the contact solve's own
  time, CG iterations, FFTs per solve (counted by wrapping ``scipy.fft`` in
  the solver module, so the same count works on older code), contact cells;
* ``exponent``: the same case without film at 0.2, 0.1 and 0.05 mm: cost
  (elapsed and process time, median of 3) against contact cells, and the
  least-squares exponent of ``cost ~ cells**k`` (target k <= 1.2);
* ``sweeps`` (needs ``WheelRailModel.solve_many(..., warm_start=)``): a
  modulus sweep (E = 2000-4000 MPa at eta = -3 mm) and an offset sweep
  (eta = -7 ... 2 mm, HS film) warm started from the neighbour against cold
  starts, and warm with the solver tolerance relaxed from 1e-9 to 1e-6:
  iterations, FFTs, process time, largest area difference from cold;
* ``flange``: 60E1, 10 kN, eta = +5, +6, +7 mm (patches 8-9 cells of 0.1 mm
  across): area, the refined spacing across the rail, cells across, time;
* ``peer``: tamaas (``pip install tamaas``; periodic Polonsky-Keer-Rey) on a
  Hertz window: sphere R450 on a flat, 75 kN, 24 x 24 mm at 0.1 mm (240 x 240
  cells), both one thread, process time and iterations, as a ratio;
  skipped with a note when tamaas is not installed.

The machine's load (``os.getloadavg()``) is printed before and after; on a
shared machine wall times are noisy, so compare counts and process times.

Options: ``--synthetic`` (quadratic-gap cases with and without film and a
rough wheel), ``--paper-table`` (the 20 cases of the paper),
``--accuracy`` (Hertz grid convergence, film sphere table), ``--hertz-table``
(wheel-rail areas against local Hertz over eta), ``--dump-areas PATH`` (areas
of 56 wheel-rail cases as JSON, to compare two versions case by case).

Run: ``OMP_NUM_THREADS=1 python bench/wheelrail_speed.py [--repeats 5] [--workers N]
[--skip-sweeps] [--synthetic] [--paper-table] [--accuracy] [--hertz-table]``

The film springs against the axisymmetric FE model (the transfer term) are in ``bench/verification.py``.
"""
from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np
import scipy.fft as _scipy_fft
from scipy.optimize import brentq

import filmcal.wheelrail.halfspace as _halfspace
from filmcal.films import get_film
from filmcal.hertz import contact_modulus_mpa
from filmcal.wheelrail.halfspace import (HalfSpaceContactSolver, SurfaceGrid,
                                         sphere_on_flat_contact)
from filmcal.wheelrail.hertz import hertz_elliptic
from filmcal.contact.laws import FilmLayer, GreenwoodWilliamsonLaw, InterfaceLaw
from filmcal.wheelrail.wheelrail import WheelRailModel

_HS_TYPE = get_film("HS")
#: The paper's HS match (E = 2800 MPa), registry thickness and Poisson's ratio.
HS_FILM = FilmLayer(2800.0, _HS_TYPE.poisson, _HS_TYPE.thickness_mm)
FILM_TARGET_S = 0.1
BARE_TARGET_S = 0.15
EXPONENT_TARGET = 1.2


class _CountingFFT:
    """``scipy.fft`` with a count of the transforms the solver module calls."""

    _COUNTED = {"rfft2", "irfft2", "rfftn", "irfftn", "fft2", "ifft2", "rfft", "irfft"}

    def __init__(self) -> None:
        self.count = 0

    def __getattr__(self, name):
        target = getattr(_scipy_fft, name)
        if name not in self._COUNTED:
            return target

        def counted(*args, **kwargs):
            self.count += 1
            return target(*args, **kwargs)

        return counted


FFT = _CountingFFT()
_halfspace.sfft = FFT


def _load() -> str:
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} {five:.2f} {fifteen:.2f} on {os.cpu_count()} CPUs"


def _timed_solves(model: WheelRailModel, offset_mm: float, force_n: float, film, repeats: int):
    """Warm-up solve, then `repeats` timed solves; per-solve figures and the last result."""
    model.solve(offset_mm, force_n, film=film)
    rows = []
    for _ in range(repeats):
        FFT.count = 0
        cpu = time.process_time()
        res = model.solve(offset_mm, force_n, film=film)
        rows.append({"elapsed_s": res.elapsed_s, "process_s": time.process_time() - cpu,
                     "contact_s": res.contact.elapsed_s, "iterations": res.contact.iterations,
                     "ffts": FFT.count})
    return rows, res


def _median(rows, key):
    return statistics.median(r[key] for r in rows)


def acceptance(repeats: int, workers: int | None) -> None:
    """S1002/60E2, eta -3 mm, 50 kN, 0.1 mm, with and without the HS film."""
    print("\nS1002/60E2, eta = -3 mm, 50 kN, grid 0.1 mm (median of "
          f"{repeats} solves after a warm-up; {_load()})")
    print("  elapsed s: WheelRailResult.elapsed_s; process s: CPU time of the whole solve; "
          "contact s: the half-space solve's elapsed_s")
    print(f"{'film':<5} {'elapsed s':>9} {'target':>6} {'process s':>9} {'contact s':>9} "
          f"{'its':>4} {'FFTs':>5} {'cells':>6} {'grid':>9} {'area mm2':>9}")
    for film, target in ((HS_FILM, FILM_TARGET_S), (None, BARE_TARGET_S)):
        model = WheelRailModel(solver=HalfSpaceContactSolver(workers=workers))
        rows, res = _timed_solves(model, -3.0, 50e3, film, repeats)
        elapsed = _median(rows, "elapsed_s")
        print(f"{'HS' if film else 'none':<5} {elapsed:>9.3f} {target:>6.2f} "
              f"{_median(rows, 'process_s'):>9.3f} {_median(rows, 'contact_s'):>9.3f} "
              f"{rows[0]['iterations']:>4d} {rows[0]['ffts']:>5d} "
              f"{int(res.contact.contact_mask.sum()):>6d} {res.grid.nx:>4d}x{res.grid.ny:<4d} "
              f"{res.area_mm2:>9.3f}   "
              f"{'met' if elapsed <= target else 'NOT met'}")


def exponent(workers: int | None) -> None:
    """No-film cost against contact cells from 0.2 to 0.05 mm."""
    print(f"\nNo film, same case, grids 0.2/0.1/0.05 mm (median of 3; {_load()})")
    print(f"{'grid mm':>7} {'cells':>6} {'its':>4} {'FFTs':>5} {'elapsed s':>9} {'process s':>9} "
          f"{'area mm2':>9}")
    cells, elapsed, process = [], [], []
    for spacing in (0.2, 0.1, 0.05):
        model = WheelRailModel(grid_mm=spacing, solver=HalfSpaceContactSolver(workers=workers))
        rows, res = _timed_solves(model, -3.0, 50e3, None, 3)
        cells.append(int(res.contact.contact_mask.sum()))
        elapsed.append(_median(rows, "elapsed_s"))
        process.append(_median(rows, "process_s"))
        print(f"{spacing:>7.2f} {cells[-1]:>6d} {rows[0]['iterations']:>4d} {rows[0]['ffts']:>5d} "
              f"{elapsed[-1]:>9.3f} {process[-1]:>9.3f} {res.area_mm2:>9.3f}")
    log_cells = np.log(cells)
    for name, cost in (("elapsed", elapsed), ("process", process)):
        k = float(np.polyfit(log_cells, np.log(cost), 1)[0])
        print(f"cost exponent ({name} time) k = {k:.2f}, target <= {EXPONENT_TARGET} -> "
              f"{'met' if k <= EXPONENT_TARGET else 'NOT met'}")


def sweeps(workers: int | None) -> None:
    """Warm-started sweeps against cold starts."""
    model = WheelRailModel(solver=HalfSpaceContactSolver(workers=workers))
    model.solve(-3.0, 50e3, film=HS_FILM)
    moduli = (2000.0, 2500.0, 3000.0, 3500.0, 4000.0)
    plans = {
        "moduli 2000-4000 MPa, eta -3, 50 kN": [
            (-3.0, 50e3, FilmLayer(e, HS_FILM.poisson, HS_FILM.thickness_mm)) for e in moduli],
        "offsets -7..2 mm, 50 kN, HS": [(float(e), 50e3, HS_FILM) for e in range(-7, 3)],
    }
    for eta in range(-7, 3):  # placements cached before timing either start
        model.geometry(float(eta))
    print(f"\nSweeps, each solve warm started from its neighbour against cold starts ({_load()})")
    print(f"{'sweep':<38} {'start':<14} {'its':>5} {'FFTs':>6} {'process s':>9} {'max |dA|/A':>10}")
    for name, cases in plans.items():
        out = {}
        for warm in (False, True):
            FFT.count = 0
            cpu = time.process_time()
            results = model.solve_many(cases, warm_start=warm)
            out[warm] = (results, FFT.count, time.process_time() - cpu)
        loose_model = WheelRailModel(solver=HalfSpaceContactSolver(tol=1e-6, workers=workers))
        for eta in range(-7, 3):
            loose_model.geometry(float(eta))
        loose_model.solve(-3.0, 50e3, film=HS_FILM)
        FFT.count = 0
        cpu = time.process_time()
        loose = loose_model.solve_many(cases)
        out["loose"] = (loose, FFT.count, time.process_time() - cpu)
        for key, label in ((False, "cold"), (True, "warm"), ("loose", "warm, tol 1e-6")):
            results, ffts, cpu = out[key]
            its = sum(r.contact.iterations for r in results)
            diff = max(abs(r.area_mm2 / c.area_mm2 - 1.0) for r, c in zip(results, out[False][0]))
            print(f"{name:<38} {label:<14} {its:>5d} {ffts:>6d} {cpu:>9.3f} {diff:>10.1e}")


def flange(workers: int | None) -> None:
    """Narrow flange patches: refined across the rail instead of refused."""
    model = WheelRailModel(rail="60E1", solver=HalfSpaceContactSolver(workers=workers))
    print(f"\nFlange contact, S1002/60E1, 10 kN, grid 0.1 mm ({_load()})")
    print(f"{'eta':>4} {'area mm2':>9} {'dx mm':>6} {'ds mm':>7} {'across':>6} {'its':>4} "
          f"{'process s':>9}")
    for eta in (5.0, 6.0, 7.0):
        cpu = time.process_time()
        try:
            res = model.solve(eta, 10e3)
        except ValueError as err:
            print(f"{eta:>4.0f} refused: {err}")
            continue
        across = int(res.contact.contact_mask.sum(axis=1).max())
        print(f"{eta:>4.0f} {res.area_mm2:>9.3f} {res.grid.dx_mm:>6.3f} {res.grid.dy_mm:>7.4f} "
              f"{across:>6d} {res.contact.iterations:>4d} {time.process_time() - cpu:>9.3f}")


def peer(workers: int | None) -> None:
    """tamaas against this solver on one Hertz window (same grid, same load)."""
    try:
        import tamaas as tm
    except ImportError:
        print("\ntamaas is not installed (pip install tamaas): no peer comparison")
        return
    n, length, radius, force = 240, 24.0, 450.0, 75e3
    solver = HalfSpaceContactSolver(workers=1 if workers is None else workers)
    e_star = solver.contact_modulus_mpa
    grid = SurfaceGrid.centred(length, length, length / n)
    x, y = grid.mesh()
    gap = (x * x + y * y) / (2.0 * radius)
    solver.solve(gap, force, grid)
    cpu = time.process_time()
    ours = solver.solve(gap, force, grid)
    ours_s = time.process_time() - cpu
    tm.set_log_level(tm.LogLevel.error)
    model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [length, length], [n, n])
    model.E, model.nu = e_star, 0.0  # tamaas: rigid flat against a body of E/(1-nu^2) = E*
    peer_solver = tm.PolonskyKeerRey(model, -gap, 1e-12, tm.PolonskyKeerRey.pressure,
                                     tm.PolonskyKeerRey.pressure)
    cpu = time.process_time()
    peer_error = peer_solver.solve(force / length ** 2)
    peer_s = time.process_time() - cpu
    p = np.asarray(model.traction).reshape(n, n)
    a = (3.0 * force * radius / (4.0 * e_star)) ** (1.0 / 3.0)
    print(f"\nPeer: tamaas {tm.__version__} (periodic PKR, tol 1e-12) against filmcal "
          f"(non-periodic, tol 1e-9), Hertz R{radius:.0f}, {force / 1e3:.0f} kN, "
          f"{n}x{n} cells of {length / n:g} mm, one thread ({_load()})")
    print(f"  filmcal: {ours_s:.3f} s process, {ours.iterations} iterations, loaded cells "
          f"{ours.area_cells_mm2:.2f} mm2, sub-cell area {ours.area_mm2:.2f} mm2")
    print(f"  tamaas:  {peer_s:.3f} s process, final error {peer_error:.1e}, loaded cells "
          f"{(p > 0).sum() * grid.cell_area_mm2:.2f} mm2 (periodic images of the window)")
    print(f"  Hertz area {math.pi * a * a:.2f} mm2; time ratio tamaas/filmcal "
          f"{peer_s / ours_s:.1f}")


def dump_areas(path: str, workers: int | None) -> None:
    """Areas of 56 cases as JSON (to compare two versions of the solver case by case).

    S1002 on 60E2 at eta = -7 ... 2 mm and on 60E1 at eta = -6, -3, 0, 2 mm,
    50 and 100 kN, without and with the HS film: positive-pressure area (the
    solver's own), reported area, peak pressure and CG iterations.
    """
    import json

    rows = []
    for rail, offsets in (("60E2", range(-7, 3)), ("60E1", (-6, -3, 0, 2))):
        model = WheelRailModel(rail=rail, solver=HalfSpaceContactSolver(workers=workers))
        for force in PAPER_FORCES_N:
            for eta in offsets:
                for film in (None, HS_FILM):
                    res = model.solve(float(eta), force, film=film)
                    rows.append({"rail": rail, "offset_mm": float(eta), "force_n": force,
                                 "film": film is not None, "area_mm2": res.area_mm2, "max_pressure_mpa": res.max_pressure_mpa,
                                 "iterations": res.contact.iterations})
    with open(path, "w", encoding="utf-8") as handle:
        json.dump(rows, handle, indent=1)
    print(f"\n{len(rows)} cases written to {path}")


SYNTHETIC_CASES = {  # gap coefficients A, B (1/mm) and region (mm)
    "wheel-rail": ((1.0 / 920.0, 1.0 / 500.0), (24.0, 24.0)),
    "elongated": ((1.0 / 2000.0, 1.0 / 200.0), (32.0, 16.0)),
}
FORCE_N = 100e3


def time_case(name: str, coefficients: tuple[float, float], region: tuple[float, float],
              film: FilmLayer | None, law: InterfaceLaw | None, repeats: int,
              workers: int | None) -> dict:
    """Cold, median and warm-start times of one quadratic-gap case on a 0.1 mm grid."""
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


def synthetic_table(repeats: int, workers: int | None) -> None:
    """Quadratic-gap cases with the HS film, without film and with film and a rough wheel."""
    rough = GreenwoodWilliamsonLaw(1.5, contact_modulus_mpa(HS_FILM.modulus_mpa,
                                                            HS_FILM.poisson, 210000.0, 0.3))
    rows = [time_case(name, coefs, region, f, law, repeats, workers)
            for name, (coefs, region) in SYNTHETIC_CASES.items()
            for f, law in ((HS_FILM, None), (None, None), (HS_FILM, rough))]
    print(f"\nQuadratic gaps, 100 kN, 0.1 mm ({_load()})")
    print(f"{'case':<11} {'film':<7} {'cells':<8} {'its':>4} {'cold s':>7} "
          f"{'median s':>9} {'min s':>6} {'max s':>6} {'warm s':>7} "
          f"{'area mm2':>9} {'Hertz':>8} {'p0 MPa':>7}")
    for r in rows:
        print(f"{r['case']:<11} {r['film']:<7} {r['cells']:<8} {r['iterations']:>4d} "
              f"{r['cold_s']:>7.3f} {r['median_s']:>9.3f} {r['min_s']:>6.3f} {r['max_s']:>6.3f} "
              f"{r['warm_median_s']:>7.3f} "
              f"{r['area_mm2']:>9.2f} {r['hertz_area_mm2']:>8.2f} {r['max_pressure_mpa']:>7.1f}")


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
    print("\nSphere on flat with film (t = 0.09 mm, nu = 0.33, grid 0.1 mm, refined below 80 cells "
          "across): contact radius sqrt(A/pi) in mm, and error against Hertz (no film)")
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


PAPER_OFFSETS_MM = tuple(float(e) for e in range(-7, 3))
PAPER_FORCES_N = (50e3, 100e3)
TABLE_TARGET_S = 30.0
TABLE1_CASES = ((300, 25), (450, 25), (600, 25), (300, 50), (450, 50), (600, 50), (450, 75),
                (600, 75), (450, 100), (600, 100))


def paper_table(workers: int | None) -> float:
    """The 20 cases of the paper without and with the HS film, from a new model; returns the total time."""
    model = WheelRailModel(solver=HalfSpaceContactSolver(workers=workers))
    print("\n20-case table (S1002/60E2, inclination 1/40, R0 460 mm, grid 0.1 mm); areas in mm2: "
          "A = contact area (pressure > 0)")
    print(f"{'eta':>5} {'F kN':>5} | {'A':>7} {'Hertz':>7} {'patch':>5} {'s':>5} | "
          f"{'A film':>7} {'s':>5} | {'ratio':>6}")
    totals = {"none": 0.0, "film": 0.0}
    start_all = time.perf_counter()
    for force in PAPER_FORCES_N:
        for eta in PAPER_OFFSETS_MM:
            bare = model.solve(eta, force)
            film = model.solve(eta, force, film=HS_FILM)
            totals["none"] += bare.elapsed_s
            totals["film"] += film.elapsed_s
            hertz = bare.hertz.area_mm2 if bare.hertz is not None else float("nan")
            print(f"{eta:>5.1f} {force / 1e3:>5.0f} | {bare.area_mm2:>7.2f} "
                  f"{hertz:>7.2f} {bare.n_patches:>5d} {bare.elapsed_s:>5.2f} | {film.area_mm2:>7.2f} "
                  f"{film.elapsed_s:>5.2f} | "
                  f"{film.area_mm2 / bare.area_mm2:>6.3f}")
    total = time.perf_counter() - start_all
    print(f"total {total:.1f} s (without film {totals['none']:.1f} s, with film {totals['film']:.1f} s); "
          f"target {TABLE_TARGET_S:.0f} s -> {'met' if total <= TABLE_TARGET_S else 'NOT met'} "
          f"(ratio {TABLE_TARGET_S / total:.1f}x)")
    return total


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
    parser.add_argument("--repeats", type=int, default=5,
                        help="timed solves per case after the warm-up (default 5)")
    parser.add_argument("--workers", type=int, default=None,
                        help="FFT threads (default: chosen per grid by the solver)")
    parser.add_argument("--skip-sweeps", action="store_true",
                        help="skip the warm-start sweeps (for code without them)")
    parser.add_argument("--skip-peer", action="store_true", help="skip the tamaas comparison")
    parser.add_argument("--synthetic", action="store_true",
                        help="also time quadratic-gap cases (film, no film, rough wheel)")
    parser.add_argument("--paper-table", action="store_true",
                        help="also solve the 20 cases of the paper with and without film")
    parser.add_argument("--accuracy", action="store_true",
                        help="also print the Hertz grid-convergence and film sphere tables")
    parser.add_argument("--hertz-table", action="store_true",
                        help="also print the wheel-rail areas against local Hertz over eta")
    parser.add_argument("--dump-areas", metavar="PATH",
                        help="also write the areas of 56 wheel-rail cases to a JSON file")
    args = parser.parse_args()
    print(f"start: {_load()}")
    acceptance(args.repeats, args.workers)
    exponent(args.workers)
    if not args.skip_sweeps:
        sweeps(args.workers)
    flange(args.workers)
    if not args.skip_peer:
        peer(args.workers)
    if args.synthetic:
        synthetic_table(args.repeats, args.workers)
    if args.paper_table:
        paper_table(args.workers)
    if args.accuracy:
        solver = HalfSpaceContactSolver(workers=args.workers)
        hertz_convergence_table(solver)
        film_sphere_table(solver)
    if args.hertz_table:
        hertz_table(args.workers)
    if args.dump_areas:
        dump_areas(args.dump_areas, args.workers)
    print(f"end: {_load()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
