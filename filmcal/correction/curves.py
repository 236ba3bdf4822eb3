"""Correction curves: the film's effect on the wheel-rail contact area, with credible bands.

For each (offset eta, force F) the wheel-rail model is solved without film and
with the film at five posterior quantiles of its modulus; log(A_film / A_0) is
interpolated quadratically in log E for every posterior sample, giving the
posterior of Delta A = A_film - A_0 and of the ratio A_0 / A_film. The
interpolation error is measured at two further quantiles (10 % and 90 %) and
reported beside the bands.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from filmcal.wheelrail import FilmLayer, solve_wheel_rail

__all__ = ["CorrectionCurves", "correction_curves"]

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
