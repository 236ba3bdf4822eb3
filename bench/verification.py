"""Each contact model against its independent reference, in one table of differences.

    python bench/verification.py [--points N] [--grid] [--study-dir D] [--json out.json] [--summary]

Rows:

* ``FE / Hertz``: the axisymmetric FE without film against Hertz's radius (Table 1's cases and a small
  patch, R 250 mm / 15 kN);
* ``FE / second formulation``: the FE at its default mesh with a film against the second formulation
  (`filmcal.fem.reference`, biquadratic, extrapolated from h = 0.05 and 0.025 mm) at films across nu 0.25-0.45
  (``bench/fe_reference.py`` runs 84 such cases);
* ``application / second formulation``: the application's film (half-space springs read by the edge model, plus
  the transfer term fitted to the FE at its default mesh) against the same converged second formulation, end to end;
* ``FE / second formulation, levels`` and ``application / second formulation, levels``: the activation and
  capsule readings at MS's, HS's and HHS's levels, of the FE at its default mesh and of the application's film
  with its transfer term, against the second formulation's pressure read from its own nodes (the fitted edge
  shape only within 2.5 elements of its closing-load edge) and extrapolated to h -> 0, at `LEVEL_CASES`;
* ``FE / second formulation, large strain``: the same with neo-Hookean films (the production film's kernel and
  the reference's are written independently; the reference extrapolated from h = 0.1 and 0.05 mm), down to
  MS's calibrated modulus at 100 kN (through-thickness strain 0.5);
* ``half-space / Hertz``: the wheel-rail model's half-space solver on a sphere without film (area-equivalent
  radius of its zero-pressure outline);
* ``half-space / thin-layer BEM``: the half-space with film springs (its outline's limit in the grid: 4
  phases at 0.2 / 0.1 / 0.05 mm, extrapolated) against the axisymmetric ring BEM of the same spring film (a
  second formulation of the same model);
* ``transfer`` per imprint model and kinematics: the film as a wheel-rail answer applies it (springs in
  series, read by `FilmModel.recorded_area_mm2`, plus the shipped transfer term of
  `filmcal.contact.transfer`) against the film the calibration runs (the continuum FE, read by the same
  imprint model), sphere-on-flat for MS, HS and HHS at N points of a Latin hypercube over Table 1's region
  (R 250-600 mm, 20-110 kN; seed 3) and N over the whole supported domain (R 150-1500 mm, 9-165 kN within the
  elastic limit; seed 17, rows marked ``whole domain``) that none of the shipped fit's designs contains:
  without the term (``raw``) and with it;
* ``sphere wheel / sphere-on-flat``: a sphere as the wheel profile on a flat rail through the wheel-rail model
  (`filmcal.wheelrail.profiles.sphere_wheel`, `flat_rail`) against `sphere_on_flat_contact` on the exact sphere's
  gap, where the transfer term was fitted and is checked: every reading of MS/HS/HHS at the points above;
* ``wheel-rail / CONTACT``: the wheel-rail model at its default grid against CONTACT's stored numbers
  (``tests/data/contact``, with the input decks that made them; CONTACT cannot be built everywhere):
  S1002 on 60E1 at 10 kN over the flange, and S1002 on 60E2 at 50/100 kN with and without MS/HS/HHS layers.
  Areas in mm^2 (``value_mm``/``reference_mm`` hold areas there), relative differences in per cent.

``--grid``: each reading of the half-space solution with the HS film on S1002/60E2 (50/100 kN, eta -5..+2 mm,
E 800-6300 MPa; the level readings at MS's, HS's and HHS's levels) at fixed grids 0.2 / 0.1 / 0.05 / 0.025 mm (the model's refinement of narrow patches off, the
wheel's slide solved to `GRID_SLIDE_TOL_CELLS`), each at `GRID_PHASES` phases of the grid (across and along the
rail): the observed orders of the phase means, the Richardson extrapolation of the finest three, and the
largest error of one phase at 0.1 mm against it; and the same readings of
sphere-on-flat through MS/HS/HHS films at 0.2 / 0.1 / 0.05 / 0.025 mm over 8 phases of the grid in both
directions (their observed orders).
``--thickness``: the transfer term at films of 0.045, 0.05, 0.09, 0.15 and 0.23 mm (inside the fitted
0.04-0.25 mm; 0.045 and 0.23 mm in its outer ninths, whose bands are raised to the rms of the rows they hold)
and 0.3 mm (beyond it, where the band carries `filmcal.contact.transfer.THICKNESS_STD_MM` more) at 8 points of
Table 1's region.
``--stiff``: the FE's level readings on stiff films (E 8000-20000 MPa, HS's and HHS's levels), calibrated on one
sphere-on-flat contact and applied at three others, against the second formulation (the modulus that makes the
FE read the reference at one contact, then the FE's miss at the others): how much of the FE's level error there
a calibration absorbs (`filmcal.contact.transfer.STIFF_LEVEL_STD_MM`); 16 second-formulation solves, about 15 min.
``--study-dir D``: Table 1 through the application model at each film's calibrated median E and preferred
model (residuals against the calibration's own FE at the same E; the FE's own least-squares E, one
Gauss-Newton step from the median, with the mean residual there, and the span of the mean residual over the
posterior's 90 % interval of E: how closely the data fix it; the median's Monte Carlo error and, for a
posterior of two parameters, its exact median by quadrature with the mean residual there), and the wheel-rail correction factor
A_0 / A_f at S1002/60E2, 100 kN, eta 0 per film before (the readings before the transfer term: contours of
``p**2``, no transfer term) and after.

Figures are differences of radii in mm (and relative), measured in this run. ``--summary`` also writes the
per-check summary the report's verification section prints (``filmcal/data/verification.json``, with the FE
revision it was measured for; with ``--study-dir`` also Table 1 through the application and the correction
factor, per film); run it again, on a full study of the paper's data, whenever a model changes.
"""
from __future__ import annotations

import argparse
import functools
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

#: (R mm, F kN, E MPa, nu) off Table 1's grid, across the calibrated range.
TRANSFER_POINTS = [(300.0, 35.0, 1200.0, 0.40), (375.0, 60.0, 2000.0, 0.33), (450.0, 75.0, 2800.0, 0.33),
                   (520.0, 40.0, 3500.0, 0.25), (600.0, 90.0, 6000.0, 0.33), (350.0, 50.0, 700.0, 0.30)]
HERTZ_CASES = [(250.0, 15.0), (300.0, 25.0), (300.0, 50.0), (450.0, 50.0), (450.0, 100.0), (600.0, 25.0),
               (600.0, 100.0)]


def _row(kind: str, case: str, value: float, reference: float) -> dict:
    return {"check": kind, "case": case, "value_mm": value, "reference_mm": reference,
            "difference_mm": value - reference, "relative": value / reference - 1.0}


def fe_against_hertz() -> list[dict]:
    from filmcal.fem import get_model

    rows = []
    for r, f in HERTZ_CASES:
        res = get_model(r).solve(None, f * 1e3)
        rows.append(_row("FE / Hertz", f"R{r:g} {f:g} kN", res.contact_radius_mm, res.hertz_radius_mm))
    return rows


#: What each check is compared with (the report prints it beside the summary).
REFERENCES = {
    "FE / Hertz": "Hertz's closed form, no film (Table 1's cases and R 250 mm / 15 kN)",
    "FE / second formulation": "biquadratic FE with the closing-load edge, extrapolated to h -> 0, films at nu 0.25-0.45",
    "FE / second formulation, levels": "the same converged FE's pressure read from its nodes (the edge shape within "
                                       "2.5 elements only): activation and capsule at MS's, HS's and HHS's levels, "
                                       "6 films of E 600-6000 MPa",
    "application / second formulation, levels": "the same: the application's film with its transfer term, "
                                                "activation and capsule at MS's, HS's and HHS's levels, end to end",
    "FE / second formulation, levels, stiff films": "the same, 4 films of E 8000-20000 MPa (above 6000 MPa, "
                                                    "where a level reading's band carries the FE's level error, "
                                                    "0.0031 mm)",
    "application / second formulation, levels, stiff films": "the same, end to end, 4 films of E 8000-20000 MPa",
    "FE / second formulation, large strain": "the same with neo-Hookean films in both (independent kernels), strains up to 0.5",
    "application / second formulation": "the same converged FE: the application's film (half-space springs, "
                                        "sphere-on-flat, edge reading) with its transfer term, fitted to the FE at "
                                        "its default mesh",
    "half-space / Hertz": "Hertz's closed form, no film",
    "half-space / thin-layer BEM": "axisymmetric ring BEM of the same spring film (rings of 0.005 mm), against the "
                                   "half-space outline's limit in the grid",
    "sphere wheel / sphere-on-flat": "the same half-space film read on the exact sphere's gap "
                                     "(sphere_on_flat_contact): a sphere as the wheel profile on a flat rail through "
                                     "the wheel-rail model, every reading of MS/HS/HHS",
    "wheel-rail / CONTACT flange": "CONTACT, refined and extrapolated: S1002 on 60E1, 10 kN, eta -3..+8 mm, an HS layer at +5 mm",
    "wheel-rail / CONTACT layer": "CONTACT's elastic layer: S1002 on 60E2, 50/100 kN, eta -5..+2 mm, no film and MS/HS/HHS",
}


def summarise(rows: list[dict]) -> dict:
    """Per check: cases, mean and largest difference (mm or mm2), largest relative difference (%); the transfer
    per reading; with ``--grid``, per reading its largest error of one phase at 0.1 mm (%) and its observed
    orders from 0.1 mm (median, and how many in 1.5-2.5); with ``--study-dir``, Table 1 through the application and the correction factor before and
    after, per film (empty lists without it)."""
    from filmcal.contact.names import APPLICATION_MODEL_REVISION, FE_MODEL_REVISION

    checks = []
    for kind in REFERENCES:
        sel = [r for r in rows if r["check"] == kind]
        if not sel:
            continue
        d = np.array([r["difference_mm"] for r in sel])
        checks.append({"check": kind, "reference": REFERENCES[kind], "n": len(sel),
                       "unit": "mm2" if kind.startswith("wheel-rail") else "mm", "mean": float(d.mean()),
                       "rms": float(np.sqrt(np.mean(d * d))), "max_abs": float(np.abs(d).max()),
                       "max_abs_rel_pct": float(100 * max(abs(r["relative"]) for r in sel))})
    transfer = [{k: r[k] for k in ("check", "n", "raw_mean_mm", "raw_max_mm", "mean_mm", "rms_mm", "max_mm", "std_mm",
                                   "not_converged", "one_sided")}
                for r in rows if r["check"].startswith("transfer ") and not r["check"].startswith("transfer per film")]
    per_film = {}
    for r in rows:
        if r["check"].startswith("transfer per film"):
            f = per_film.setdefault(r["film"], {"film": r["film"], "n": 0, "mean_min_mm": math.inf,
                                                "mean_max_mm": -math.inf, "max_mm": 0.0})
            f["n"] += r["n"]
            f["mean_min_mm"] = min(f["mean_min_mm"], r["mean_mm"])
            f["mean_max_mm"] = max(f["mean_max_mm"], r["mean_mm"])
            f["max_mm"] = max(f["max_mm"], r["max_mm"])
    table1 = [{k: r[k] for k in ("case", "mean_residual_mm", "rms_mm", "calibration_mean_residual_mm",
                                 "calibration_rms_mm", "quadrature_median_mpa", "quadrature_mean_residual_mm")}
              for r in rows if r["check"] == "Table 1 through the application"]
    factor = [{k: r[k] for k in ("case", "before", "after", "reading_change_mm2", "transfer_shift_mm2",
                                 "transfer_std_mm2")}
              for r in rows if r["check"].startswith("correction factor")]
    grid = []
    for kind in dict.fromkeys(r["check"] for r in rows if r["check"].startswith("grid ")):
        sel = [r for r in rows if r["check"] == kind]
        fine = np.array([r["orders"][1] for r in sel if len(r["orders"]) > 1])  # 0.1-0.05-0.025 mm, where solved
        fine = fine[np.isfinite(fine)]
        grid.append({"reading": kind.removeprefix("grid "), "n": len(sel), "n_fine": int(fine.size),
                     "max_error_at_0.1_pct": float(100 * max(abs(r["error_at_0.1_rel"]) for r in sel)),
                     "order_median": float(np.median(fine)) if fine.size else float("nan"),
                     "orders_in_1.5_2.5": int(np.sum((fine >= 1.5) & (fine <= 2.5)))})
    return {"made": time.strftime("%Y-%m-%d"), "script": "bench/verification.py --summary",
            "fe_model_revision": FE_MODEL_REVISION, "application_model_revision": APPLICATION_MODEL_REVISION,
            "checks": checks, "transfer": transfer, "transfer_per_film": list(per_film.values()), "table1": table1,
            "correction_factor": factor, "grid": grid}


#: (R mm, F kN, E MPa, nu): films across the supported nu range, off the fits' designs.
SECOND_FORMULATION_CASES = [(300.0, 35.0, 1200.0, 0.40), (450.0, 75.0, 2800.0, 0.33), (520.0, 40.0, 3500.0, 0.25),
                            (350.0, 90.0, 8000.0, 0.45), (600.0, 25.0, 600.0, 0.30)]


@functools.lru_cache(maxsize=None)
def _second_formulation(r: float, f: float, e: float, nu: float) -> tuple:
    """The second formulation at h = 0.05 and 0.025 mm (extrapolated to h -> 0 by the callers)."""
    from filmcal.fem.reference import QuadraticSphereOnFlat

    return tuple(QuadraticSphereOnFlat(r, element_size_mm=h, contact_zone_mm=12.0).solve(f * 1e3, e, nu)
                 for h in (0.05, 0.025))


def fe_against_second_formulation() -> list[dict]:
    from filmcal.fem import Film, get_model

    from dataclasses import replace

    from filmcal.contact.film import FilmModel
    from filmcal.films import get_film
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    rows = []
    for r, f, e, nu in SECOND_FORMULATION_CASES:
        a = [ref.contact_radius_mm for ref in _second_formulation(r, f, e, nu)]
        converged = 2.0 * a[1] - a[0]
        res = get_model(r).solve(Film(e, nu), f * 1e3)
        rows.append(_row("FE / second formulation", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}", res.contact_radius_mm,
                         converged))
        # end to end: the application's film with its transfer term (edge reading) against the converged FE
        model = FilmModel(replace(get_film("HS"), poisson=nu), "edge", "small")
        film, law, _ = model.interface(e)
        applied = sphere_on_flat_contact(r, f * 1e3, film=film, law=law)
        area = model.recorded_area_mm2(applied) + model.transfer_term(e, applied).shift_mm2
        rows.append(_row("application / second formulation", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}",
                         math.sqrt(area / math.pi), converged))
    return rows


#: (R mm, F kN, E MPa, nu): the level readings' cases, `SECOND_FORMULATION_CASES` and five more: HHS's calibrated
#: modulus at 100 kN, a film at 6000 MPa and three stiff ones (10000-20000 MPa). Those above
#: `filmcal.contact.transfer.STIFF_LEVEL_MODULUS_MPA` are checks of their own (the band their readings carry).
LEVEL_CASES = SECOND_FORMULATION_CASES + [(500.0, 100.0, 3400.0, 0.33), (550.0, 30.0, 6000.0, 0.42),
                                          (300.0, 60.0, 15000.0, 0.40), (400.0, 50.0, 20000.0, 0.30),
                                          (250.0, 80.0, 10000.0, 0.35)]


def levels_against_second_formulation() -> list[dict]:
    """The level readings (activation and capsule, at MS's, HS's and HHS's levels) of the FE at its default mesh
    and of the application's film with its transfer term, against the second formulation's pressure read from
    its own nodes (the fitted edge shape only within 2.5 elements of its closing-load edge, against the 0.3 mm
    that the default mesh needs) and extrapolated to h -> 0, at `LEVEL_CASES`."""
    from dataclasses import replace

    from filmcal.contact.film import FilmModel
    from filmcal.contact.reading import film_tip_length_mm
    from filmcal.fem import Film, get_model
    from filmcal.films import get_film
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    from filmcal.contact.transfer import STIFF_LEVEL_MODULUS_MPA

    rows = []
    for r, f, e, nu in LEVEL_CASES:
        stiff = ", stiff films" if e > STIFF_LEVEL_MODULUS_MPA else ""
        refs = _second_formulation(r, f, e, nu)
        fe = get_model(r).solve(Film(e, nu), f * 1e3)
        for name in ("MS", "HS", "HHS"):
            film = replace(get_film(name), poisson=nu)
            tip = film_tip_length_mm(film.thickness_mm, Film(e, nu).oedometric_modulus_mpa, nu)
            for imprint in ("activation", "capsule"):
                at_h = [ref.read_imprint(imprint, film, tip) for ref in refs]
                converged = 2.0 * at_h[1] - at_h[0]
                case = f"{name} {imprint} R{r:g} {f:g} kN E{e:g} nu{nu:g}"
                rows.append(_row("FE / second formulation, levels" + stiff, case, fe.read_imprint(imprint, film),
                                 converged))
                model = FilmModel(film, imprint, "small")
                spring, law, _ = model.interface(e)
                applied = sphere_on_flat_contact(r, f * 1e3, film=spring, law=law)
                area = model.recorded_area_mm2(applied) + model.transfer_term(e, applied).shift_mm2
                rows.append(_row("application / second formulation, levels" + stiff, case,
                                 math.sqrt(area / math.pi), converged))
    return rows


#: (R mm, F kN, E MPa, nu): large-strain films, from MS's calibrated modulus at 100 kN to a stiff one.
LARGE_STRAIN_CASES = [(450.0, 100.0, 538.0, 0.33), (300.0, 35.0, 1200.0, 0.40), (520.0, 40.0, 3500.0, 0.25)]


def fe_against_second_formulation_large_strain() -> list[dict]:
    from filmcal.fem import ContactOptions, Film, get_model
    from filmcal.fem.reference import QuadraticSphereOnFlat

    rows = []
    for r, f, e, nu in LARGE_STRAIN_CASES:
        a = [QuadraticSphereOnFlat(r, element_size_mm=h, contact_zone_mm=12.0).solve(
            f * 1e3, e, nu, kinematics="large").contact_radius_mm for h in (0.1, 0.05)]
        res = get_model(r).solve(Film(e, nu), f * 1e3, ContactOptions(kinematics="large"))
        rows.append(_row("FE / second formulation, large strain", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}",
                         res.contact_radius_mm, 2.0 * a[1] - a[0]))
    return rows


def wheelrail_against_contact() -> list[dict]:
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parent / "contact"))
    from compare import SETS, compare

    rows = []
    for name in sorted(SETS):
        for c in compare(name, 0.1):
            rows.append(_row(f"wheel-rail / CONTACT {name}", c["case"], c["filmcal_area_mm2"], c["contact_area_mm2"]))
    return rows


def halfspace_against_hertz() -> list[dict]:
    from filmcal.hertz import hertz_radius_mm
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    rows = []
    for r, f in HERTZ_CASES[:3]:
        res = sphere_on_flat_contact(r, f * 1e3)
        rows.append(_row("half-space / Hertz", f"R{r:g} {f:g} kN", res.equivalent_radius_mm,
                         float(hertz_radius_mm(r, f * 1e3))))
    return rows


def sphere_wheel_against_sphere_on_flat() -> list[dict]:
    """A sphere as the wheel profile on a flat rail through the wheel-rail model (its placement, contact plane,
    sampled profiles, grid and phase) against sphere-on-flat on the exact sphere's gap, where the transfer term
    was fitted: each imprint model's radius with MS/HS/HHS at `TRANSFER_POINTS`."""
    from dataclasses import replace

    from filmcal.contact.film import FilmModel
    from filmcal.contact.imprint import imprint_models_for
    from filmcal.films import get_film
    from filmcal.wheelrail.halfspace import HalfSpaceContactSolver, sphere_on_flat_contact
    from filmcal.wheelrail.profiles import flat_rail, sphere_wheel
    from filmcal.wheelrail.wheelrail import WheelRailModel

    solver = HalfSpaceContactSolver()
    rows = []
    for r, f, e, nu in TRANSFER_POINTS:
        wheel_rail = WheelRailModel(sphere_wheel(r), flat_rail(), rail_inclination=0.0, nominal_radius_mm=r,
                                    solver=solver)
        for name in ("MS", "HS", "HHS"):
            film_type = replace(get_film(name), poisson=nu)
            models = [FilmModel(film_type, imprint, "large") for imprint in imprint_models_for(film_type)]
            film, law, _ = models[0].interface(e)
            applied = wheel_rail.solve(0.0, f * 1e3, film=film, roughness=law)
            sphere = sphere_on_flat_contact(r, f * 1e3, film=film, law=law, solver=solver)
            for m in models:
                rows.append(_row("sphere wheel / sphere-on-flat", f"R{r:g} {f:g} kN E{e:g} {name} {m.imprint}",
                                 math.sqrt(m.recorded_area_mm2(applied) / math.pi),
                                 math.sqrt(m.recorded_area_mm2(sphere) / math.pi)))
    return rows


def sphere_phase_solves(solver, radius_mm: float, force_n: float, film, spacing_mm: float, offsets):
    """Sphere-on-flat on a square grid of `spacing_mm` at each of `offsets` (fractions of a cell in x and y,
    the grid's phases), covering 1.6 Hertz radii: the contact results, one per phase."""
    from filmcal.wheelrail.halfspace import SurfaceGrid

    half = 1.6 * (3.0 * force_n * radius_mm / (4.0 * solver.contact_modulus_mpa)) ** (1.0 / 3.0)
    n = 2 * int(math.ceil(half / spacing_mm)) + 1
    out = []
    for px, py in offsets:
        grid = SurfaceGrid(n, n, spacing_mm, spacing_mm, -(n // 2 - px) * spacing_mm, -(n // 2 - py) * spacing_mm)
        x, y = grid.mesh()
        r2 = x * x + y * y
        out.append(solver.solve(r2 / (radius_mm + np.sqrt(radius_mm**2 - r2)), force_n, grid, film=film,
                                check_resolution=False))
    return out


def halfspace_against_thin_layer() -> list[dict]:
    from filmcal.contact.laws import FilmLayer
    from filmcal.fem.thinlayer import thin_layer_contact
    from filmcal.wheelrail.halfspace import HalfSpaceContactSolver

    solver = HalfSpaceContactSolver()
    phases = np.random.default_rng(1).random((4, 2))
    rows = []
    for r, f, e, nu in TRANSFER_POINTS[:3]:
        # the half-space's outline in the limit of the grid (the Richardson extrapolation of its means over four
        # phases at 0.2 / 0.1 / 0.05 mm at their observed order) against the ring model's edge (rings of 0.005 mm,
        # the zero of its linear pressure: within 0.0001 mm of finer rings)
        film = FilmLayer(e, nu, 0.09)
        means = [float(np.mean([res.area_mm2 for res in sphere_phase_solves(solver, r, f * 1e3, film, h, phases)]))
                 for h in (0.2, 0.1, 0.05)]
        d1, d2 = means[0] - means[1], means[1] - means[2]
        order = math.log2(d1 / d2) if d1 / d2 > 0 else 2.0
        limit = means[2] - d2 / (2.0 ** min(max(order, 1.0), 3.0) - 1.0)
        bem = thin_layer_contact(r, f * 1e3, e, nu, 0.09, ring_width_mm=0.005)
        rows.append(_row("half-space / thin-layer BEM", f"R{r:g} {f:g} kN E{e:g} nu{nu:g}",
                         math.sqrt(limit / math.pi), bem.contact_radius_mm))
    return rows


def transfer_check(n_points: int) -> list[dict]:
    """The applied film with and without the transfer term against the calibrated FE film (see the docstring):
    `n_points` over Table 1's region and as many over the whole supported domain."""
    from filmcal.contact.transfer import load_transfer_fit
    from filmcal.correction.transfer import (
        check_transfer,
        measure_transfer,
        transfer_design,
    )
    from filmcal.films import get_film

    fit = load_transfer_fit()
    films = [get_film(n) for n in ("MS", "HS", "HHS")]
    (thickness,) = {f.thickness_mm for f in films}  # the band is that of the films' thickness
    out = []
    for region, seed in (("core", 3), ("whole", 17)):
        rows = measure_transfer(transfer_design(n_points, seed, region=region), films)
        for key, r in sorted(check_transfer(fit, rows).items()):
            out.append({"check": f"transfer {key}" + ("" if region == "core" else ", whole domain"), "n": r["n"],
                        "raw_mean_mm": r["raw_mean_mm"], "raw_max_mm": r["raw_max_mm"], "mean_mm": r["mean_mm"],
                        "rms_mm": r["rms_mm"], "max_mm": r["max_mm"],
                        "std_mm": fit.std_for(*key.split("/"), thickness),
                        "not_converged": r["not_converged"], "one_sided": r["one_sided"]})
        for film in films:  # the systematic term left per film (pooled above over the three)
            for key, r in sorted(check_transfer(fit, [row for row in rows if row["film"] == film.name]).items()):
                out.append({"check": f"transfer per film {key}" + ("" if region == "core" else ", whole domain"),
                            "film": film.name, "n": r["n"], "mean_mm": r["mean_mm"], "rms_mm": r["rms_mm"],
                            "max_mm": r["max_mm"], "std_mm": fit.std_for(*key.split("/"), thickness)})
    return out


#: Film thicknesses of the ``--thickness`` check (mm): the built-in films' 0.09 mm, four others inside the fitted
#: range (0.045 and 0.23 mm in its outer ninths of ln t, whose bands are raised to the rms of the rows they hold:
#: the one check of those bands on points of their own) and one beyond it.
THICKNESS_CHECK_MM = (0.045, 0.05, 0.09, 0.15, 0.23, 0.3)


#: (E MPa, nu) of the stiff films and (R mm, F kN) of the contacts of ``--stiff``.
STIFF_FILMS = [(8000.0, 0.45), (15000.0, 0.40), (20000.0, 0.30), (10000.0, 0.35)]
STIFF_CONTACTS = [(300.0, 30.0), (600.0, 110.0), (250.0, 100.0), (500.0, 20.0)]


def stiff_levels_calibrated_elsewhere() -> list[dict]:
    """The FE's level readings on stiff films against the second formulation, as they are (``raw``) and after
    calibrating the modulus on one contact and applying it at the three others (``applied``), per film, film
    type (HS, HHS) and reading."""
    from dataclasses import replace

    from scipy.optimize import brentq

    from filmcal.contact.reading import film_tip_length_mm
    from filmcal.fem import Film, get_model
    from filmcal.films import get_film

    out = []
    for e, nu in STIFF_FILMS:
        refs = {g: _second_formulation(g[0], g[1], e, nu) for g in STIFF_CONTACTS}
        for name in ("HS", "HHS"):
            film = replace(get_film(name), poisson=nu)
            tip = film_tip_length_mm(film.thickness_mm, Film(e, nu).oedometric_modulus_mpa, nu)
            for imprint in ("activation", "capsule"):
                converged = {}
                for g, pair in refs.items():
                    at_h = [x.read_imprint(imprint, film, tip) for x in pair]
                    converged[g] = 2.0 * at_h[1] - at_h[0]

                def fe(modulus: float, g: tuple) -> float:
                    return get_model(g[0]).solve(Film(modulus, nu), g[1] * 1e3).read_imprint(imprint, film)

                raw = [fe(e, g) - converged[g] for g in STIFF_CONTACTS]
                applied = []
                for gc in STIFF_CONTACTS:
                    e_cal = brentq(lambda m: fe(m, gc) - converged[gc], e / 3.0, 3.0 * e, xtol=1e-3)
                    applied += [fe(e_cal, g) - converged[g] for g in STIFF_CONTACTS if g != gc]
                out.append({"check": "stiff levels", "case": f"{name} {imprint} E{e:g} nu{nu:g}", "raw_mm": raw,
                            "applied_mm": applied})
    return out


def transfer_thickness_check(n_points: int = 8) -> list[dict]:
    """The transfer at films of several thicknesses: MS/HS/HHS's levels and Poisson's ratios at
    `THICKNESS_CHECK_MM`, `n_points` of a Latin hypercube over Table 1's region (seed 23, in none of the fit's
    designs), against the calibrated FE at that thickness."""
    from dataclasses import replace

    from filmcal.contact.transfer import load_transfer_fit
    from filmcal.correction.transfer import check_transfer, measure_transfer, transfer_design
    from filmcal.films import get_film

    fit = load_transfer_fit()
    points = transfer_design(n_points, 23)
    out = []
    for t in THICKNESS_CHECK_MM:
        films = [replace(get_film(n), thickness_mm=t) for n in ("MS", "HS", "HHS")]
        for key, r in sorted(check_transfer(fit, measure_transfer(points, films)).items()):
            out.append({"check": f"transfer {key}, {t:g} mm", "n": r["n"], "raw_mean_mm": r["raw_mean_mm"],
                        "raw_max_mm": r["raw_max_mm"], "mean_mm": r["mean_mm"], "rms_mm": r["rms_mm"],
                        "max_mm": r["max_mm"], "std_mm": fit.std_for(*key.split("/"), t),
                        "not_converged": r["not_converged"],
                        "one_sided": r["one_sided"]})
    return out


def _print_transfer(rows: list[dict]) -> None:
    print(f"{'model':40} {'n':>4} {'raw mean':>9} {'raw max':>8} | {'mean':>8} {'rms':>7} {'max':>7} | {'term std':>8}"
          " | left out: FE not converged, one model records nothing")
    for r in rows:
        if "film" in r:  # one film's rows (transfer_check): the systematic term left for that film
            continue
        print(f"{r['check']:40} {r['n']:4d} {r['raw_mean_mm']:+9.4f} {r['raw_max_mm']:8.4f} | {r['mean_mm']:+8.4f} "
              f"{r['rms_mm']:7.4f} {r['max_mm']:7.4f} | {r['std_mm']:8.4f} | {r['not_converged']} {r['one_sided']}")
    for film in dict.fromkeys(r["film"] for r in rows if "film" in r):
        own = [r for r in rows if r.get("film") == film]
        print(f"summary transfer, {film} alone: {sum(r['n'] for r in own)} readings, means "
              f"{min(r['mean_mm'] for r in own):+.4f} .. {max(r['mean_mm'] for r in own):+.4f} mm (the systematic "
              f"term left), largest {max(r['max_mm'] for r in own):.4f} mm")


GRID_CASES = [(f, eta, e) for f in (50e3, 100e3) for eta in (-5.0, -1.5, 2.0) for e in (800.0, 2800.0, 6300.0)]


#: Phases of the grid at each spacing: shifts of k / GRID_PHASES of a cell across the rail, paired with
#: ALONG_PHASES[k] / GRID_PHASES of a cell along it (a Latin square's diagonal: each direction takes every
#: phase once). The readings are averaged over them, so that an outline's phase in its cells (noise of the size
#: of the differences between grids) does not hide the order of the systematic error.
GRID_PHASES = 4
ALONG_PHASES = (0, 2, 1, 3)
#: The slide's tolerance of the grid study (cells; the model's default is `SLIDE_TOL_CELLS`, 0.02).
GRID_SLIDE_TOL_CELLS = 1e-4


def _grid_label(model) -> str:
    """The grid study's name of a reading: the edge, or a level reading at a film's levels ("capsule MS")."""
    return model.imprint if model.imprint == "edge" else f"{model.imprint} {model.film.name}"


def grid_convergence() -> list[dict]:
    """Readings at 0.2 / 0.1 / 0.05 / 0.025 mm averaged over the grid's phase: the observed orders of the coarse
    and the fine triplet, the Richardson extrapolation of the fine one and the largest error at 0.1 mm over the
    phases."""
    from filmcal.contact.film import FilmModel
    from filmcal.films import get_film
    from filmcal.wheelrail import WheelRailModel
    from filmcal.wheelrail.wheelrail import ContactRegion

    # fixed grids: the model's refinement of patches narrower than FILM_MIN_CELLS_ACROSS cells would refine the
    # 0.2 mm grid (in one direction or both) in every 50 kN case and at 100 kN for E 2800 and 6300 MPa; and the
    # wheel's slide solved far below its default (2 % of a cell: an error of first order in the cell, up to
    # 0.03 % in area, which hid the readings' own order)
    spacings = (0.2, 0.1, 0.05, 0.025)
    fixed = {h: WheelRailModel(grid_mm=h, film_min_cells_across=0, slide_tol_cells=GRID_SLIDE_TOL_CELLS)
             for h in spacings}
    out = []
    hs = get_film("HS")
    # the HS film's solutions, read by the edge and by the level readings at each film's levels (MS 10, HS 50,
    # HHS 130 MPa; capsule ranges 10-50, 50-130, 130-300 MPa): MS's read in the edge zone of the softer films
    models = [FilmModel(hs, "edge", "small")] + [FilmModel(get_film(name), imprint, "small")
                                                 for name in ("MS", "HS", "HHS") for imprint in ("activation", "capsule")]
    for force, eta, e in GRID_CASES:
        solver_film, _, _ = models[0].interface(e)
        # one region for every grid: the loaded cells of the 0.2 mm solution and 0.4 mm around them; the grid
        # across the rail starts at the region's side, so shifting the region shifts the grid's phase
        base = fixed[0.2].solve(eta, force, film=solver_film).contact
        x, y = base.grid.mesh()
        loaded = base.pressure_mpa > 0
        half_x = float(np.abs(x[loaded]).max()) + 0.4
        s_lo, s_hi = float(y[loaded].min()) - 0.4, float(y[loaded].max()) + 0.4
        areas = {_grid_label(m): np.full((len(spacings), GRID_PHASES), np.nan) for m in models}
        for i, h in enumerate(spacings):
            for k in range(GRID_PHASES):
                shift = h * k / GRID_PHASES
                try:
                    res = fixed[h].solve(eta, force, film=solver_film,
                                         region=ContactRegion(half_x, s_lo + shift, s_hi + shift,
                                                              x_offset_mm=h * ALONG_PHASES[k] / GRID_PHASES))
                except ValueError as exc:  # the largest patches at 0.025 mm exceed the model's grid bound
                    if i < len(spacings) - 1 or "cells" not in str(exc):
                        raise
                    break
                for m in models:
                    areas[_grid_label(m)][i, k] = m.recorded_area_mm2(res)
        for imprint, a in areas.items():
            a = a[np.isfinite(a).all(axis=1)]
            mean = a.mean(axis=1)
            d = mean[:-1] - mean[1:]
            orders = [math.log2(d[i] / d[i + 1]) if d[i + 1] != 0 and d[i] / d[i + 1] > 0 else float("nan")
                      for i in range(len(d) - 1)]
            p = orders[-1] if 1.0 <= orders[-1] <= 3.0 else 2.0
            limit = mean[-1] - d[-1] / (2**p - 1)
            worst = a[1][np.argmax(np.abs(a[1] - limit))]
            out.append({"check": f"grid {imprint}", "case": f"{force / 1e3:g} kN eta {eta:+g} E{e:g}",
                        "areas_mm2": mean.tolist(), "phase_spread_mm2": np.ptp(a, axis=1).tolist(),
                        "orders": orders, "extrapolated_mm2": limit, "error_at_0.1_rel": worst / limit - 1.0})
    return out


#: (film, E MPa, R mm, F kN) of the sphere-on-flat grid study.
SPHERE_GRID_CASES = [("MS", 800.0, 300.0, 20.0), ("HS", 2800.0, 450.0, 50.0), ("HHS", 6300.0, 600.0, 100.0)]


def sphere_grid_convergence(phases: int = 8) -> list[dict]:
    """The three readings of sphere-on-flat through a film at 0.2 / 0.1 / 0.05 / 0.025 mm, each the mean over
    `phases` random offsets of the grid in both directions (the wheel-rail grid is centred on the contact
    along the rail, so there only its phase across the rail can be moved): the observed orders."""
    from filmcal.contact.film import FilmModel
    from filmcal.films import get_film
    from filmcal.wheelrail.halfspace import HalfSpaceContactSolver

    solver = HalfSpaceContactSolver()
    offsets = np.random.default_rng(1).random((phases, 2))
    spacings = (0.2, 0.1, 0.05, 0.025)
    out = []
    for name, e, radius, force_kn in SPHERE_GRID_CASES:
        film = get_film(name)
        models = [FilmModel(film, imprint, "small") for imprint in ("edge", "activation", "capsule")]
        solver_film, _, _ = models[0].interface(e)
        areas = np.empty((len(models), len(spacings), phases))
        for i, h in enumerate(spacings):
            for k, res in enumerate(sphere_phase_solves(solver, radius, force_kn * 1e3, solver_film, h, offsets)):
                for j, m in enumerate(models):
                    areas[j, i, k] = m.recorded_area_mm2(res)
        for j, m in enumerate(models):
            mean = areas[j].mean(axis=1)
            d = -np.diff(mean)
            orders = [math.log2(d[i] / d[i + 1]) if d[i + 1] != 0 and d[i] / d[i + 1] > 0 else float("nan")
                      for i in range(len(d) - 1)]
            out.append({"check": f"sphere grid {m.imprint}", "case": f"{name} E{e:g} R{radius:g} {force_kn:g} kN",
                        "areas_mm2": mean.tolist(), "phase_sd_mm2": areas[j].std(axis=1).tolist(), "orders": orders})
    return out


def study_checks(study_dir: str) -> list[dict]:
    """Table 1 through the application model, and the correction factor before and after (docstring)."""
    from filmcal.calibration.datasets import load_table1
    from filmcal.contact.film import FilmModel
    from filmcal.contact.imprint import get_imprint_model
    from filmcal.contact.options import ContactOptions
    from filmcal.fem import Film, get_model
    from filmcal.films import get_film
    from filmcal.wheelrail import solve_wheel_rail
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact
    from filmcal.calibration import load_result
    from filmcal.calibration.diagnostics import compute_diagnostics, quadrature_quantiles
    from filmcal.study import Study

    with open(f"{study_dir}/summary.json", encoding="utf-8") as fh:
        summary = json.load(fh)
    study = Study(study_dir)
    out = []
    for film_name, s in summary["films"].items():
        preferred = s.get("preferred_model") or {"model": s["model"], "modulus_mpa": s["modulus_mpa"]}
        imprint, kinematics = preferred["model"].split("/")
        e = float(preferred["modulus_mpa"]["median"])
        film = get_film(film_name)
        model = FilmModel(film, imprint, kinematics)
        data = load_table1(film_name)
        applied, calibrated, slope = [], [], []
        solver_film, solver_law, _ = model.interface(e)

        def fe_radius(modulus: float, r: float, f: float) -> float:
            fe = get_model(r).solve(Film(modulus, film.poisson), f, ContactOptions(kinematics=kinematics))
            return fe.contact_radius_mm if imprint == "edge" else fe.read_imprint(imprint, film)

        for r, f, measured in zip(data.sphere_radius_mm, data.force_n, data.measured_radius_mm):
            hs = sphere_on_flat_contact(float(r), float(f), film=solver_film, law=solver_law)
            area = model.recorded_area_mm2(hs) + model.transfer_term(e, hs).shift_mm2
            applied.append(measured - math.sqrt(area / math.pi))
            calibrated.append(measured - fe_radius(e, float(r), float(f)))
            slope.append((fe_radius(1.01 * e, float(r), float(f)) - fe_radius(e / 1.01, float(r), float(f))) / 0.02)
        applied, calibrated, slope = np.array(applied), np.array(calibrated), np.array(slope)
        # the FE's own least-squares modulus (one Gauss-Newton step in ln E from the median, residuals linear
        # there) and the plain mean residual there; the mean residual over the posterior's 90 % interval of E
        step = float(np.sum(slope * calibrated) / np.sum(slope**2))
        lo, hi = (float(v) for v in preferred["modulus_mpa"]["ci90"])
        # the median's own error: its Monte Carlo standard error, and the exact median of the recorded
        # posterior by quadrature when it has two parameters (ln E, ln sigma)
        path = study.layout.posterior(Path(s["posterior_file"]).stem)  # relative to the study (before 2 Dec: the cwd)
        mcse = compute_diagnostics({"E": load_result(path).samples["modulus_mpa"]}).mcse["E"]["median"]
        problem = study.problem(path)
        exact = (quadrature_quantiles(problem, e)["median"]
                 if problem.parameter_names == ["log_modulus", "log_sigma"] else None)
        shift = float(np.mean(slope)) * math.log(exact / e) if exact is not None else math.nan
        out.append({"check": "Table 1 through the application", "case": f"{film_name} {preferred['model']} E{e:.0f}",
                    "mean_residual_mm": float(applied.mean()), "rms_mm": float(np.sqrt(np.mean(applied**2))),
                    "calibration_mean_residual_mm": float(calibrated.mean()),
                    "calibration_rms_mm": float(np.sqrt(np.mean(calibrated**2))),
                    "fe_least_squares_mpa": e * math.exp(step),
                    "fe_least_squares_mean_residual_mm": float(np.mean(calibrated - step * slope)),
                    "ci90_mean_residual_mm": sorted(float(np.mean(calibrated - math.log(v / e) * slope))
                                                    for v in (lo, hi)),
                    "mcse_median_mpa": mcse, "mcse_mean_residual_mm": abs(float(np.mean(slope))) * mcse / e,
                    "quadrature_median_mpa": exact, "quadrature_mean_residual_mm": float(applied.mean()) - shift})
        a0 = solve_wheel_rail(0.0, 100e3).area_mm2
        res = solve_wheel_rail(0.0, 100e3, film=solver_film, roughness=solver_law)
        after = model.recorded_area_mm2(res)
        term = model.transfer_term(e, res)
        grid = res.contact.grid
        # the reading of before: the contour of p**2 (the edge model: its p**2 edge), no transfer term
        before = get_imprint_model(imprint).area_mm2(grid.x_mm, grid.y_mm, res.contact.pressure_mpa, film,
                                                     through_film=False)
        out.append({"check": "correction factor S1002/60E2 100 kN eta 0", "case": f"{film_name} {preferred['model']}",
                    "before": a0 / before, "after": a0 / (after + term.shift_mm2),
                    "transfer_shift_mm2": term.shift_mm2, "transfer_std_mm2": term.std_mm2,
                    "reading_change_mm2": after - before})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=32, help="points of the transfer check (default 32)")
    ap.add_argument("--grid", action="store_true", help="also the grid convergence of the wheel-rail readings")
    ap.add_argument("--thickness", action="store_true",
                    help="also the transfer at films of 0.045, 0.05, 0.09, 0.15 and 0.23 mm (inside the fitted "
                         "thicknesses) and 0.3 mm (beyond them)")
    ap.add_argument("--stiff", action="store_true",
                    help="also the FE's level readings on stiff films calibrated on one contact, applied at others")
    ap.add_argument("--study-dir", metavar="D", help="also Table 1 and the correction factor with D's posteriors")
    ap.add_argument("--json", metavar="FILE", help="also write the rows as JSON")
    ap.add_argument("--summary", action="store_true",
                    help="also write the per-check summary the report prints (filmcal/data/verification.json)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    rows = (fe_against_hertz() + fe_against_second_formulation() + levels_against_second_formulation()
            + fe_against_second_formulation_large_strain()
            + halfspace_against_hertz()
            + halfspace_against_thin_layer() + sphere_wheel_against_sphere_on_flat() + wheelrail_against_contact())
    print(f"{'check':34} {'case':30} {'value mm':>10} {'ref mm':>10} {'diff mm':>9} {'rel %':>8}")
    for row in rows:
        print(f"{row['check']:34} {row['case'][:30]:30} {row['value_mm']:10.4f} {row['reference_mm']:10.4f} "
              f"{row['difference_mm']:+9.4f} {100 * row['relative']:+8.3f}")
    for kind in sorted({r["check"] for r in rows}):
        d = np.array([r["difference_mm"] for r in rows if r["check"] == kind])
        rel = 100 * np.array([r["relative"] for r in rows if r["check"] == kind])
        unit = "mm2" if kind.startswith("wheel-rail") else "mm"
        print(f"summary {kind:34} mean {d.mean():+.4f} {unit}, rms {np.sqrt(np.mean(d * d)):.4f} {unit}, range "
              f"{d.min():+.4f} .. {d.max():+.4f} {unit}; "
              f"largest |rel| {np.abs(rel).max():.3f} %")
    transfer = transfer_check(args.points)
    print(f"\ntransfer: calibrated FE film minus applied springs, sphere-on-flat, MS/HS/HHS at {args.points} points "
          "of Table 1's region (seed 3) and of the whole domain (seed 17), radius in mm")
    _print_transfer(transfer)
    rows += transfer
    if args.thickness:
        thick = transfer_thickness_check()
        from filmcal.contact.transfer import load_transfer_fit

        th0, th1 = load_transfer_fit().domain["thickness_mm"]
        print(f"\ntransfer at films of {'/'.join(f'{t:g}' for t in THICKNESS_CHECK_MM)} mm (the fit was made on "
              f"{th0:g}-{th1:g} mm): MS/HS/HHS's levels at 8 points of Table 1's region (seed 23), radius in mm")
        _print_transfer(thick)
        for t in THICKNESS_CHECK_MM:
            part = [r for r in thick if r["check"].endswith(f", {t:g} mm")]
            print(f"summary transfer at {t:g} mm: rms {min(r['rms_mm'] for r in part):.4f}-"
                  f"{max(r['rms_mm'] for r in part):.4f} mm, largest {max(r['max_mm'] for r in part):.4f} mm")
        rows += thick
    if args.stiff:
        stiff = stiff_levels_calibrated_elsewhere()
        print("\nthe FE's level readings on stiff films minus the second formulation's (mm): as they are, and "
              "calibrated on one contact, applied at the three others")
        for r in stiff:
            print(f"{r['case']:34} raw " + " ".join(f"{v:+.4f}" for v in r["raw_mm"])
                  + f"  applied rms {np.sqrt(np.mean(np.square(r['applied_mm']))):.4f}")
        for label, key in (("as they are", "raw_mm"), ("calibrated elsewhere", "applied_mm")):
            d = np.concatenate([r[key] for r in stiff])
            print(f"summary stiff levels, {label}: {d.size} readings, mean {d.mean():+.4f} mm, rms "
                  f"{np.sqrt(np.mean(d * d)):.4f} mm, largest {np.abs(d).max():.4f} mm")
        rows += stiff
    if args.grid:
        grid = grid_convergence()
        print(f"\nreadings of the HS film's solutions on S1002/60E2 (the level readings at MS/HS/HHS's levels): areas at 0.2 / 0.1 / 0.05 / 0.025 mm (mm2, the mean of "
              f"{GRID_PHASES} phases of the grid; the phases' spread at 0.1 mm), observed orders of the means "
              "(0.2-0.1-0.05, 0.1-0.05-0.025), largest error of one phase at 0.1 mm against the extrapolation")
        for r in grid:
            print(f"{r['check']:18} {r['case']:24} " + " ".join(f"{v:9.3f}" for v in r["areas_mm2"]).ljust(39)
                  + f"  spread {r['phase_spread_mm2'][1]:6.3f}  p " + " ".join(f"{p:5.2f}" for p in r["orders"])
                  + f"  {100 * r['error_at_0.1_rel']:+7.3f} %")
        for kind in sorted({r["check"] for r in grid}):
            worst = max(abs(r["error_at_0.1_rel"]) for r in grid if r["check"] == kind)
            print(f"summary {kind:18} largest |error at 0.1 mm| {100 * worst:.3f} %")
            for j, triplet in enumerate(("0.2-0.1-0.05", "0.1-0.05-0.025")):
                orders = np.array([r["orders"][j] for r in grid if r["check"] == kind and len(r["orders"]) > j])
                finite = orders[np.isfinite(orders)]
                print(f"        observed order {triplet}: median {np.median(finite):.2f}, range {finite.min():.2f} .. "
                      f"{finite.max():.2f}, {np.sum((finite >= 1.5) & (finite <= 2.5))} of {orders.size} cases in "
                      f"1.5-2.5 ({orders.size - finite.size} not monotone)")
        rows += grid
        sphere = sphere_grid_convergence()
        print("\nreadings of sphere-on-flat through a film: areas at 0.2 / 0.1 / 0.05 / 0.025 mm (mm2, the mean of 8 "
              "phases of the grid in both directions), the phases' sd at 0.1 mm, observed orders of the means")
        for r in sphere:
            a = r["areas_mm2"]
            print(f"{r['check']:24} {r['case']:24} " + " ".join(f"{v:9.3f}" for v in a)
                  + f"  sd {r['phase_sd_mm2'][1]:6.4f}  p " + " ".join(f"{p:5.2f}" for p in r["orders"]))
        rows += sphere
    if args.study_dir:
        checks = study_checks(args.study_dir)
        print(f"\nwith the posteriors of {args.study_dir}")
        for r in checks:
            if "rms_mm" in r:
                print(f"Table 1 {r['case']:28} application: mean {r['mean_residual_mm']:+.4f} rms {r['rms_mm']:.4f} mm"
                      f" | calibration's FE: mean {r['calibration_mean_residual_mm']:+.4f} "
                      f"rms {r['calibration_rms_mm']:.4f} mm")
                lo, hi = r["ci90_mean_residual_mm"]
                print(f"        the FE's least-squares E {r['fe_least_squares_mpa']:.0f} MPa: mean residual "
                      f"{r['fe_least_squares_mean_residual_mm']:+.4f} mm; over the posterior's 90 % interval of E "
                      f"the mean residual spans {lo:+.4f} .. {hi:+.4f} mm")
                print(f"        the median's Monte Carlo error {r['mcse_median_mpa']:.2f} MPa "
                      f"(+/- {r['mcse_mean_residual_mm']:.4f} mm in the mean residual); the exact median "
                      + (f"by quadrature {r['quadrature_median_mpa']:.2f} MPa: application mean residual there "
                         f"{r['quadrature_mean_residual_mm']:+.4f} mm" if r["quadrature_median_mpa"] else "n/a"))
            else:
                print(f"A0/Af 100 kN eta 0 {r['case']:22} before {r['before']:.4f} after {r['after']:.4f} "
                      f"({100 * (r['after'] / r['before'] - 1):+.2f} %; reading {r['reading_change_mm2']:+.2f} mm2, "
                      f"transfer {r['transfer_shift_mm2']:+.2f} +/- {r['transfer_std_mm2']:.2f} mm2)")
        rows += checks
    print(f"({time.perf_counter() - t0:.0f} s)", file=sys.stderr)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    if args.summary:
        from pathlib import Path

        out = Path(__file__).resolve().parent.parent / "filmcal" / "data" / "verification.json"
        out.write_text(json.dumps(summarise(rows), indent=1) + "\n")
        print(f"wrote {out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
