"""Correction curves: the film's effect on the wheel-rail contact area, with credible bands.

For each (offset eta, force F) the wheel-rail model is solved without film and
with the film at three moduli spanning the posteriors of all the film's models
(0.1 % to 99.9 % quantiles, log-spaced); models of one film kinematics differ
only in what they read of a solve (edge, activation contour, capsule), so one
solve per modulus serves them all, and a rough wheel's law is computed once
per modulus for every kinematics. Each solve starts from its neighbour's
pressure (the previous modulus, the bare contact first). For each calibrated
model log(A_film / A_0) is fitted quadratically in log E through the three
moduli, A_film being the area that model records, and evaluated at every
posterior sample; the models' samples are pooled by their weights, giving the
posterior of Delta A = A_film - A_0 and of the ratio A_0 / A_film. A_film is
the area the calibrated film records: the application's reading plus the
transfer term (`FilmModel.transfer_term`), whose standard deviation widens
each sample (relative, interpolated in log E; drawn with a seed of the (force,
offset) cell). The fit's
error is measured by one more solve, between the first two moduli, and
reported beside the bands: the error of a quadratic through three points is
odd about the middle one to leading order, so one check measures both halves.
(Over today's posteriors that error is about 1e-3, the size of the cell-count
noise of the areas themselves.)
"""
from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from filmcal._io import atomic_open
from filmcal.correction.moduli import modulus_grid
from filmcal.wheelrail.wheelrail import get_wheel_rail_model

__all__ = ["CorrectionCurves", "correction_curves", "curve_moduli", "CURVE_COLUMNS", "curve_rows", "curve_table",
           "rough_law_tasks", "write_curves_csv", "read_curves_csv", "rough_bodies", "wheel_label"]

#: Solver tolerance of the sweeps: areas within 1e-6 (relative) of the default 1e-9, a fifth faster.
SWEEP_TOL = 1e-6


@dataclass
class CorrectionCurves:
    """Posterior summaries over an (offset, force) grid; arrays of shape (n_forces, n_offsets).

    Attributes
    ----------
    offsets_mm, forces_n : ndarray
    area_no_film_mm2 : ndarray
    area_film_median_mm2 : ndarray
    delta_area_median_mm2, delta_area_ci90_mm2 : ndarray (ci90 has a last axis of 2)
        A_film - A_0.
    ratio_median, ratio_ci90 : ndarray
        A_0 / A_film, the factor that corrects a measured area.
    interpolation_error_rel : ndarray
        Largest relative error of the interpolated film area at the check quantiles.
    max_pressure_no_film_mpa : ndarray
        Peak pressure of the smooth contact without film: above the steel's elastic limit the elastic model is
        outside its validity.
    """

    offsets_mm: np.ndarray
    forces_n: np.ndarray
    area_no_film_mm2: np.ndarray
    area_film_median_mm2: np.ndarray
    delta_area_median_mm2: np.ndarray
    delta_area_ci90_mm2: np.ndarray
    ratio_median: np.ndarray
    ratio_ci90: np.ndarray
    interpolation_error_rel: np.ndarray
    max_pressure_no_film_mpa: np.ndarray


def _thinned(samples, max_samples: int) -> np.ndarray:
    e = np.asarray(samples, dtype=float).ravel()
    if len(e) > max_samples:
        e = e[np.linspace(0, len(e) - 1, max_samples).round().astype(int)]
    if not np.all(np.isfinite(e)) or np.any(e <= 0):
        raise ValueError("modulus_samples_mpa must be finite and > 0")
    return e


def _pooled(components, max_samples: int) -> tuple[list, np.ndarray]:
    """The components with thinned samples, and how many samples of each the weighted pool takes."""
    parts = [(model, _thinned(samples, max_samples), float(w)) for model, samples, w in components]
    weights = np.array([w for _, _, w in parts])
    if not len(parts) or np.any(weights < 0) or not np.all(np.isfinite(weights)) or weights.sum() <= 0:
        raise ValueError("components need non-negative finite weights, not all zero")
    weights = weights / weights.sum()
    n_pool = max(len(e) for _, e, _ in parts)
    counts = np.floor(weights * n_pool).astype(int)
    counts[np.argsort(-(weights * n_pool - counts), kind="stable")[:n_pool - counts.sum()]] += 1
    return parts, counts


def curve_moduli(components, max_samples: int = 4000) -> np.ndarray:
    """The film moduli (MPa) at which `correction_curves` solves for these components (sorted).

    A rough wheel's laws can be computed at them beforehand (in parallel) and
    handed to `correction_curves` as ``roughness={modulus: law}``.
    """
    parts, counts = _pooled(components, max_samples)
    nodes, checks = modulus_grid([e for (_, e, _), n in zip(parts, counts) if n > 0])
    return np.sort(np.concatenate([nodes, checks]))


def correction_curves(components, offsets_mm, forces_n, *, roughness=None, no_film_law=None,
                      max_samples: int = 4000, **wheel_rail) -> CorrectionCurves:
    """Posterior correction curves over offsets and forces, of one film model or a mixture of models.

    Parameters
    ----------
    components : sequence of (FilmModel, modulus samples, weight)
        Calibrated film models (`filmcal.contact.film.FilmModel`: film type,
        imprint model, kinematics), each with its posterior samples of E and
        its weight in the mixture (e.g. stacking weights; normalised here).
        Each model's film area is what that model records; the bands pool
        the models' samples by weight, so they are as wide as the spread
        between models that the data cannot tell apart.
    offsets_mm, forces_n : array_like
        The grid (lateral offsets eta in mm, forces in N).
    roughness : None, Roughness, RoughSurface, InterfaceLaw or mapping
        The bodies: smooth, rough (`filmcal.contact.roughness.Roughness`, or one rough surface; laws computed
        against each film modulus), a measured film-wheel law, or the laws of rough bodies computed
        beforehand at each modulus of `curve_moduli` (``{modulus: law}``). The film's rough reading
        (`FilmModel.recorded_area_mm2` with the law) uses the representative conditioned draw's reading level.
    no_film_law : InterfaceLaw, optional
        The rough bodies' law without film (`filmcal.contact.roughness.steel_contact_law`): the area without
        film is then their nominal area (`filmcal.wheelrail.film_contact.nominal_rough_area_mm2`); without
        it, the smooth bodies' area.
    max_samples : int
        Posterior samples used per model.
    **wheel_rail
        Wheel-rail settings of `filmcal.wheelrail.get_wheel_rail_model` (wheel, rail,
        rail_inclination, nominal_radius_mm, grid_mm); the sweep solves to the
        tolerance `SWEEP_TOL`.
    """
    parts, counts = _pooled(components, max_samples)
    offsets = np.atleast_1d(np.asarray(offsets_mm, dtype=float))
    forces = np.atleast_1d(np.asarray(forces_n, dtype=float))
    shape = (len(forces), len(offsets))
    a0 = np.empty(shape)
    a_med = np.empty(shape)
    d_med, r_med = np.empty(shape), np.empty(shape)
    d_ci, r_ci = np.empty(shape + (2,)), np.empty(shape + (2,))
    err = np.zeros(shape)
    peak = np.empty(shape)

    # Models of one film type and kinematics read the same contact: one solve per modulus serves them all.
    groups: dict = {}
    for k, (model, e, _) in enumerate(parts):
        if counts[k] > 0:
            groups.setdefault((model.film, model.kinematics), []).append(k)
    nodes, checks = modulus_grid([parts[k][1] for members in groups.values() for k in members])
    moduli = np.sort(np.concatenate([nodes, checks]))  # as `curve_moduli` gives them
    wheel_rail_model = get_wheel_rail_model(**wheel_rail, tol=SWEEP_TOL)
    law_at = roughness if isinstance(roughness, Mapping) else {m: roughness for m in moduli}
    interfaces = {(key, m): parts[members[0]][0].interface(float(m), law_at[m])
                  for key, members in groups.items() for m in moduli}

    for i, force in enumerate(forces):
        for j, eta in enumerate(offsets):
            # the transfer spread's draws: seeded by the cell, so a cell's band does not depend on the others
            rng = np.random.default_rng([int(round(force)), int(round(1e3 * eta)) + 10**7])
            bare = wheel_rail_model.solve(eta, force)
            a0[i, j] = bare.area_mm2
            peak[i, j] = bare.max_pressure_mpa
            if no_film_law is not None:
                from filmcal.wheelrail.film_contact import nominal_rough_area_mm2

                a0[i, j] = nominal_rough_area_mm2(wheel_rail_model.solve(eta, force, roughness=no_film_law,
                                                                         initial=bare), bare)
            pooled = []
            for key, members in groups.items():
                recorded, spread, previous = {}, {}, bare
                for m in moduli:  # each solve starts from its neighbour's pressure
                    film, law, rough_law = interfaces[key, m]
                    previous = wheel_rail_model.solve(eta, force, film=film, roughness=law, initial=previous)
                    terms = [parts[k][0].transfer_term(float(m), previous) for k in members]
                    recorded[m] = [parts[k][0].recorded_area_mm2(previous, rough_law) + t.shift_mm2
                                   for k, t in zip(members, terms)]
                    spread[m] = [t.std_mm2 / r for t, r in zip(terms, recorded[m])]
                at_nodes = np.log(np.array([recorded[m] for m in nodes]) / a0[i, j])
                at_checks = np.log(np.array([recorded[m] for m in checks]) / a0[i, j]) if len(checks) else None
                degree = min(2, len(nodes) - 1)
                for col, k in enumerate(members):
                    e = parts[k][1]
                    coef = np.polyfit(np.log(nodes), at_nodes[:, col], degree) if degree else at_nodes[:1, col]
                    area = a0[i, j] * np.exp(np.polyval(coef, np.log(e)))
                    rel_std = np.interp(np.log(e), np.log(moduli), [spread[m][col] for m in moduli])
                    area = area * (1.0 + rel_std * rng.standard_normal(len(area)))
                    if len(nodes) > 1:
                        err[i, j] = max(err[i, j], float(np.max(np.abs(
                            np.exp(np.polyval(coef, np.log(checks)) - at_checks[:, col]) - 1.0))))
                    pooled.append(area[np.linspace(0, len(area) - 1, counts[k]).round().astype(int)])
            area = np.concatenate(pooled)
            delta, ratio = area - a0[i, j], a0[i, j] / area
            a_med[i, j] = np.median(area)
            d_med[i, j], r_med[i, j] = np.median(delta), np.median(ratio)
            d_ci[i, j] = np.quantile(delta, [0.05, 0.95])
            r_ci[i, j] = np.quantile(ratio, [0.05, 0.95])
    return CorrectionCurves(offsets, forces, a0, a_med, d_med, d_ci, r_med, r_ci, err, peak)


CURVE_COLUMNS = ("film", "wheel", "force_kn", "offset_mm", "area_no_film_mm2", "area_film_median_mm2",
                 "delta_area_median_mm2", "delta_area_lo_mm2", "delta_area_hi_mm2", "ratio_median", "ratio_lo",
                 "ratio_hi", "interpolation_error_rel", "max_pressure_no_film_mpa")


def rough_bodies(ra_um: float):
    """A rough wheel of roughness Ra (um) on a smooth rail: `filmcal.contact.roughness.Roughness` of the
    representative conditioned draw of the roughness inputs (spectrum, coating hardness;
    `filmcal.contact.rough_imprint.representative_roughness_inputs`)."""
    from filmcal.contact.rough_imprint import representative_roughness_inputs

    return representative_roughness_inputs().bodies(float(ra_um))


def wheel_label(roughness=None) -> str:
    """The ``wheel`` column of curve rows: ``smooth``, ``rough Ra <x> um``, the rough bodies' Ra, or ``rough,
    measured law``."""
    from filmcal.contact.roughness import Roughness

    if roughness is None:
        return "smooth"
    if isinstance(roughness, (int, float)):
        return f"rough Ra {roughness:g} um"
    if isinstance(roughness, Roughness):
        ra = roughness.describe()
        parts = [f"{body} Ra {ra[f'{body}_ra_um']:.3g} um" for body in ("wheel", "rail") if ra[f"{body}_ra_um"]]
        return "rough " + ", ".join(parts)
    return "rough, measured law"


def curve_rows(film: str, components, offsets_mm, forces_kn, roughness=None, laws=None, **wheel_rail) -> list[list]:
    """Correction curves of one film as CSV rows (`CURVE_COLUMNS`), for one wheel.

    Parameters
    ----------
    film : str
        Film type (the rows' label).
    components : sequence of (FilmModel, modulus samples, weight)
        The film's calibrated models, as `correction_curves` takes them.
    offsets_mm, forces_kn : sequence of float
        The grid: lateral offsets eta (mm) and loads (kN).
    roughness : None, float, Roughness or InterfaceLaw
        The bodies: smooth (None), a rough wheel with this Ra in um (`rough_bodies`: laws computed against each
        film modulus, and against the steel rail for the area without film), rough bodies
        (`filmcal.contact.roughness.Roughness`, e.g. measured surfaces), or a measured
        film-wheel pressure-closure law (e.g. `filmcal.wheelrail.TabularLaw`;
        the area without film is then the smooth one).
    laws : mapping, optional
        With a rough wheel of Ra `roughness`: its laws already computed at each
        modulus of `curve_moduli` (``{modulus: rough_law(modulus)}``).
    **wheel_rail
        Passed on to `correction_curves` (profiles, inclination, ...).
    """
    from filmcal.contact.roughness import Roughness

    law = rough_bodies(float(roughness)) if isinstance(roughness, (int, float)) else roughness
    no_film_law = None
    if isinstance(law, Roughness):  # the same surfaces against each other: the area without film is rough too
        no_film_law = law.steel_law()
    if laws is not None:
        law = laws
    c = correction_curves(components, offsets_mm, np.asarray(forces_kn, dtype=float) * 1e3, roughness=law,
                          no_film_law=no_film_law, **wheel_rail)
    wheel = wheel_label(roughness)
    return [[film, wheel, force / 1e3, eta, c.area_no_film_mm2[i, j], c.area_film_median_mm2[i, j],
             c.delta_area_median_mm2[i, j], *c.delta_area_ci90_mm2[i, j], c.ratio_median[i, j], *c.ratio_ci90[i, j],
             c.interpolation_error_rel[i, j], c.max_pressure_no_film_mpa[i, j]]
            for i, force in enumerate(c.forces_n) for j, eta in enumerate(c.offsets_mm)]


def rough_law_tasks(bodies, film, components) -> dict:
    """The tasks of rough bodies' laws against a film at the moduli its curves solve at (`curve_moduli`):
    ``{modulus: (function, args)}`` for `filmcal._parallel.run_tasks`, each a boundary-element law."""
    return {float(m): (bodies.film_law, (float(m), film.poisson, film.thickness_mm)) for m in curve_moduli(components)}


def curve_table(film: str, components, offsets_mm, forces_kn, wheels=(None,), workers=None) -> list[list]:
    """Correction curves of one film for several wheels as CSV rows (`CURVE_COLUMNS`), solved in parallel.

    The rows are those of `curve_rows` for each wheel in turn (loads, then offsets within a load), wherever
    the work runs: one task per wheel, load and offset (each cell's band has its own seed), the rough wheels
    first, after one task per law of a rough wheel at each modulus solved at (`rough_law_tasks`).

    Parameters
    ----------
    film, components, offsets_mm, forces_kn
        As `curve_rows` takes them: the film type, its calibrated models and the grid (mm, kN).
    wheels : sequence
        Each a `roughness` of `curve_rows`: None (smooth), a rough wheel's Ra in um, rough bodies
        (`filmcal.contact.roughness.Roughness`) or a measured film-wheel law.
    workers : int or filmcal._parallel.Executor, optional
        Local worker processes (default: all cores; 1: everything in this process), or the executor to run
        on (a `filmcal._parallel.DaskExecutor`: a Dask cluster).
    """
    from filmcal._parallel import run_tasks
    from filmcal.contact.roughness import Roughness

    wheels = list(wheels)
    law_tasks = {}
    for w, wheel in enumerate(wheels):
        bodies = rough_bodies(wheel) if isinstance(wheel, (int, float)) else wheel
        if isinstance(bodies, Roughness):
            law_tasks.update({(w, m): task for m, task in rough_law_tasks(bodies, components[0][0].film,
                                                                           components).items()})
    laws: dict = {}
    run_tasks(law_tasks, workers, lambda key, law, k: laws.setdefault(key[0], {}).update({key[1]: law}))
    cells = [(w, force, eta) for force in forces_kn for eta in offsets_mm for w in range(len(wheels))]
    cells.sort(key=lambda cell: wheels[cell[0]] is None)  # the rough wheels first: they are the longest
    rows: dict = {}
    run_tasks({(w, force, eta): (curve_rows, (film, components, (eta,), (force,), wheels[w], laws.get(w)))
               for w, force, eta in cells}, workers, lambda key, value, k: rows.update({key: value}))
    return [row for w in range(len(wheels)) for force in forces_kn for eta in offsets_mm
            for row in rows[w, force, eta]]


def write_curves_csv(path: str | Path, rows: list[list]) -> Path:
    """Write curve rows with the `CURVE_COLUMNS` header, whole or not at all."""
    path = Path(path)
    with atomic_open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CURVE_COLUMNS)
        w.writerows(rows)
    return path


def read_curves_csv(path: str | Path) -> list[dict]:
    """Rows of a ``curves-<film>.csv`` with numbers as floats."""
    with open(path, newline="") as fh:
        return [{k: (v if k in ("film", "wheel") else float(v)) for k, v in row.items()} for row in csv.DictReader(fh)]
