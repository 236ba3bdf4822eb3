"""Deterministic inversion: the film modulus that best reproduces a film's data.

With the noise level common to all cases and a flat prior in log E, the
posterior mode is the least-squares fit; computing it with the FE model in the
loop (few tens of solves) checks that a surrogate-based posterior is not driven
by the surrogate.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from filmcal.calibration.data import RadiusErrorData
from filmcal.calibration.datasets import load_table1
from filmcal.calibration.likelihood import RadiusModel
from filmcal.films import FILM_POISSON

__all__ = ["LeastSquaresFit", "least_squares_modulus"]


@dataclass
class LeastSquaresFit:
    """Least-squares film modulus of one film type."""

    film: str
    loads: str | None
    modulus_mpa: float
    poisson: float
    rms_residual_mm: float
    residuals_mm: np.ndarray
    evaluations: int


def least_squares_modulus(film: str, model: RadiusModel, loads: str | None = None, poisson: float = FILM_POISSON,
                          modulus_range_mpa: tuple[float, float] = (400.0, 20000.0),
                          xtol: float = 1e-4, data: RadiusErrorData | None = None) -> LeastSquaresFit:
    """E minimising the sum of squared radius residuals over the film's cases.

    Parameters
    ----------
    film : str
        Film name: a Table 1 film (MS, HS, HHS) unless `data` is given.
    model : RadiusModel
        FE in the loop (`filmcal.surrogate.radius.FERadiusModel`) or a surrogate adapter.
    loads : str, optional
        Load range in kN, e.g. ``"50-100"``.
    poisson : float
        Fixed Poisson's ratio.
    modulus_range_mpa : (float, float)
        Search bracket (bounded scalar minimisation in log E).
    xtol : float
        Tolerance in log E (1e-4: 0.01 % in E).
    data : RadiusErrorData, optional
        The film's measured radii (e.g. ``load_dataset(path).select(film)``);
        default Table 1's rows of `film` and `loads`.
    """
    given = data is not None
    data = data if given else load_table1(film, loads)
    calls = 0

    def cost(log_e: float) -> float:
        nonlocal calls
        calls += 1
        mean, _ = model.predict(np.full(len(data.force_n), np.exp(log_e)), poisson, data.sphere_radius_mm,
                                data.force_n)
        if not np.all(np.isfinite(mean)):
            return np.inf
        return float(np.sum((mean - data.target_radius_mm) ** 2))

    lo, hi = np.log(modulus_range_mpa[0]), np.log(modulus_range_mpa[1])
    fit = minimize_scalar(cost, bounds=(lo, hi), method="bounded", options={"xatol": xtol})
    e = float(np.exp(fit.x))
    mean, _ = model.predict(np.full(len(data.force_n), e), poisson, data.sphere_radius_mm, data.force_n)
    res = mean - data.target_radius_mm
    return LeastSquaresFit(film if given else film.upper(), loads, e, poisson, float(np.sqrt(np.mean(res**2))), res, calls)
