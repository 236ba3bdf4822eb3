"""Correction curves: the film's effect on the wheel-rail contact area, with credible bands.

For each (offset eta, force F) the wheel-rail model is solved without film and
with the film at five posterior quantiles of its modulus; log(A_film / A_0) is
interpolated quadratically in log E for every posterior sample, giving the
posterior of Delta A = A_film - A_0 and of the ratio A_0 / A_film. The
interpolation error is measured at two further quantiles (10 % and 90 %) and
reported beside the bands.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from filmcal.wheelrail import FilmLayer, solve_wheel_rail

__all__ = ["CorrectionCurves", "correction_curves", "CURVE_COLUMNS", "curve_rows", "write_curves_csv",
           "read_curves_csv", "rough_law", "wheel_label"]

SUPPORT_QUANTILES = (0.001, 0.25, 0.5, 0.75, 0.999)
CHECK_QUANTILES = (0.1, 0.9)


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


def correction_curves(modulus_samples_mpa, offsets_mm, forces_n, *, poisson: float = 0.33,
                      film_thickness_mm: float = 0.09, roughness=None, max_samples: int = 4000,
                      **wheel_rail) -> CorrectionCurves:
    """Posterior correction curves over offsets and forces.

    Parameters
    ----------
    modulus_samples_mpa : array_like
        Posterior samples of the film's Young's modulus.
    offsets_mm, forces_n : array_like
        The grid (lateral offsets eta in mm, forces in N).
    poisson, film_thickness_mm : float
        The film's Poisson's ratio (fixed, as calibrated) and thickness.
    roughness : InterfaceLaw or callable, optional
        Film-wheel interface law (rough wheel), applied with the film; a
        callable ``roughness(modulus_mpa) -> InterfaceLaw`` builds it for each
        film modulus (a Greenwood-Williamson law depends on the film's
        stiffness, as the asperities press into the film).
    **wheel_rail
        Passed to `filmcal.wheelrail.solve_wheel_rail` (wheel, rail, rail_inclination, ...).
    """
    e = np.asarray(modulus_samples_mpa, dtype=float).ravel()
    if len(e) > max_samples:
        e = e[np.linspace(0, len(e) - 1, max_samples).round().astype(int)]
    if not np.all(np.isfinite(e)) or np.any(e <= 0):
        raise ValueError("modulus_samples_mpa must be finite and > 0")
    offsets = np.atleast_1d(np.asarray(offsets_mm, dtype=float))
    forces = np.atleast_1d(np.asarray(forces_n, dtype=float))
    support = np.quantile(e, SUPPORT_QUANTILES)
    check = np.quantile(e, CHECK_QUANTILES)
    shape = (len(forces), len(offsets))
    a0 = np.empty(shape)
    a_med = np.empty(shape)
    d_med, r_med = np.empty(shape), np.empty(shape)
    d_ci, r_ci = np.empty(shape + (2,)), np.empty(shape + (2,))
    err = np.empty(shape)

    def film_area(modulus, eta, force):
        layer = FilmLayer(float(modulus), poisson, film_thickness_mm)
        law = roughness(float(modulus)) if callable(roughness) else roughness
        return solve_wheel_rail(eta, force, film=layer, roughness=law, **wheel_rail).area_mm2

    for i, force in enumerate(forces):
        for j, eta in enumerate(offsets):
            a0[i, j] = solve_wheel_rail(eta, force, **wheel_rail).area_mm2
            log_ratio = np.log([film_area(m, eta, force) / a0[i, j] for m in support])
            coef = np.polyfit(np.log(support), log_ratio, 2)
            area = a0[i, j] * np.exp(np.polyval(coef, np.log(e)))
            exact = np.array([film_area(m, eta, force) for m in check])
            err[i, j] = np.max(np.abs(a0[i, j] * np.exp(np.polyval(coef, np.log(check))) / exact - 1.0))
            delta, ratio = area - a0[i, j], a0[i, j] / area
            a_med[i, j] = np.median(area)
            d_med[i, j], r_med[i, j] = np.median(delta), np.median(ratio)
            d_ci[i, j] = np.quantile(delta, [0.05, 0.95])
            r_ci[i, j] = np.quantile(ratio, [0.05, 0.95])
    return CorrectionCurves(offsets, forces, a0, a_med, d_med, d_ci, r_med, r_ci, err)


CURVE_COLUMNS = ("film", "wheel", "force_kn", "offset_mm", "area_no_film_mm2", "area_film_median_mm2",
                 "delta_area_median_mm2", "delta_area_lo_mm2", "delta_area_hi_mm2", "ratio_median", "ratio_lo",
                 "ratio_hi", "interpolation_error_rel")


def rough_law(ra_um: float, film_poisson: float = 0.33):
    """Film-wheel interface of a rough wheel: a Greenwood-Williamson law per film modulus.

    The wheel's asperities press into the film, so the law's contact modulus
    is that of film against steel.
    """
    from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, contact_modulus_mpa
    from filmcal.wheelrail import GreenwoodWilliamsonLaw

    def law(modulus_mpa: float):
        return GreenwoodWilliamsonLaw(ra_um, contact_modulus_mpa(modulus_mpa, film_poisson, STEEL_MODULUS_MPA,
                                                                 STEEL_POISSON))
    return law


def wheel_label(roughness=None) -> str:
    """The ``wheel`` column of curve rows: ``smooth``, ``rough Ra <x> um`` or ``rough, measured law``."""
    if roughness is None:
        return "smooth"
    if isinstance(roughness, (int, float)):
        return f"rough Ra {roughness:g} um"
    return "rough, measured law"


def curve_rows(film: str, modulus_samples_mpa, offsets_mm, forces_kn, roughness=None, poisson: float = 0.33,
               film_thickness_mm: float = 0.09, **wheel_rail) -> list[list]:
    """Correction curves of one film's posterior as CSV rows (`CURVE_COLUMNS`), for one wheel.

    Parameters
    ----------
    film : str
        Film type (the rows' label).
    modulus_samples_mpa : array_like
        Posterior samples of the film modulus E.
    offsets_mm, forces_kn : sequence of float
        The grid: lateral offsets eta (mm) and loads (kN).
    roughness : None, float or InterfaceLaw
        The wheel: smooth (None), rough with this Ra in um (Greenwood-Williamson
        law per film modulus, `rough_law`), or a measured film-wheel
        pressure-overclosure law (e.g. `filmcal.wheelrail.TabularLaw`).
    poisson, film_thickness_mm : float
        The film's Poisson's ratio (as calibrated) and thickness.
    **wheel_rail
        Passed on to `correction_curves` (profiles, inclination, ...).
    """
    law = rough_law(float(roughness), poisson) if isinstance(roughness, (int, float)) else roughness
    c = correction_curves(modulus_samples_mpa, offsets_mm, np.asarray(forces_kn, dtype=float) * 1e3,
                          poisson=poisson, film_thickness_mm=film_thickness_mm, roughness=law, **wheel_rail)
    wheel = wheel_label(roughness)
    return [[film, wheel, force / 1e3, eta, c.area_no_film_mm2[i, j], c.area_film_median_mm2[i, j],
             c.delta_area_median_mm2[i, j], *c.delta_area_ci90_mm2[i, j], c.ratio_median[i, j], *c.ratio_ci90[i, j],
             c.interpolation_error_rel[i, j]]
            for i, force in enumerate(c.forces_n) for j, eta in enumerate(c.offsets_mm)]


def write_curves_csv(path: str | Path, rows: list[list]) -> Path:
    """Write curve rows with the `CURVE_COLUMNS` header, whole or not at all."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CURVE_COLUMNS)
        w.writerows(rows)
    tmp.replace(path)
    return path


def read_curves_csv(path: str | Path) -> list[dict]:
    """Rows of a ``curves-<film>.csv`` with numbers as floats."""
    with open(path, newline="") as fh:
        return [{k: (v if k in ("film", "wheel") else float(v)) for k, v in row.items()} for row in csv.DictReader(fh)]
