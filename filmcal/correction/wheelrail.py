"""Correction of wheel-rail film imprints: the contact area without film, with its uncertainty.

For the measured configuration (offset eta, force F, profiles) the wheel-rail
model gives the area without film A_0 and with the calibrated film A_f(E). The
film's effect depends smoothly on E over a posterior, so A_f is solved at a
few posterior quantiles of E and log(A_0 / A_f) is interpolated (quadratic in
log E) for every posterior sample. The corrected area of a sample is

    A = (A_m + u eps_1) * (A_0 / A_f(E)) * (1 + 2 s / r_m * eps_2),

A_m the measured area, u the user's area uncertainty, r_m = sqrt(A_m / pi)
its equivalent radius and s = sqrt(sigma^2 + m^2): the scatter of one imprint's
radius about the model (sigma, inferred on the sphere-on-flat tests) and the
film representation's radius error m (0.01 mm typical against the FE, see
`bench/wheelrail_speed.py --fe-table`), carried over as a relative area
scatter; eps_1, eps_2 standard normal.
"""
from __future__ import annotations

import numpy as np

from filmcal.contact.film import FilmModel
from filmcal.correction.sphere import CorrectedArea, _summarise
from filmcal.wheelrail import solve_wheel_rail

__all__ = ["WheelRailCorrector", "nominal_modulus_mpa"]

QUANTILES = (0.001, 0.25, 0.5, 0.75, 0.999)


def nominal_modulus_mpa(posterior: dict, nominal_poisson: float) -> np.ndarray:
    """Posterior samples of E at the film's nominal nu, with the same oedometric modulus M.

    A thin film held laterally responds to M = E(1-nu)/((1+nu)(1-2nu)) alone,
    so a posterior sampled with nu free is carried over to the film model
    (which uses the nominal nu) sample by sample at equal M; with nu fixed at
    the nominal value the samples are unchanged.
    """
    from filmcal.elastic import oedometric_ratio

    e = np.asarray(posterior["modulus_mpa"], dtype=float).ravel()
    nu = np.asarray(posterior.get("poisson", nominal_poisson), dtype=float)
    nu = np.broadcast_to(nu.ravel() if nu.ndim else nu, e.shape)
    return e * oedometric_ratio(nu) / oedometric_ratio(nominal_poisson)


class WheelRailCorrector:
    """Correct wheel-rail imprints measured with one film type.

    Parameters
    ----------
    posterior : dict of ndarray
        Posterior samples ``modulus_mpa``, ``sigma_mm`` (and ``poisson``).
    film : FilmModel
        The film model the posterior was calibrated under
        (`filmcal.contact.film.FilmModel`: film type, imprint model,
        kinematics): the film's area is what that model records.
    wheel, rail : str
        Profile names (or CSV paths) as `filmcal.wheelrail.solve_wheel_rail` takes them.
    rail_inclination, nominal_radius_mm, grid_mm : float
        Wheel-rail model settings.
    model_radius_std_mm : float
        Radius error of the film representation (see the module docstring).
    max_samples : int
    random_state : int or numpy.random.Generator
    """

    def __init__(self, posterior: dict, film: FilmModel, wheel: str = "S1002", rail: str = "60E2",
                 rail_inclination: float = 1 / 40, nominal_radius_mm: float = 460.0, grid_mm: float = 0.1,
                 model_radius_std_mm: float = 0.01, max_samples: int = 2000, random_state=0) -> None:
        modulus = nominal_modulus_mpa(posterior, film.film.poisson)
        take = np.unique(np.linspace(0, len(modulus) - 1, min(len(modulus), max_samples)).round().astype(int))
        self.modulus_mpa_ = modulus[take]
        self.sigma_mm_ = np.asarray(posterior["sigma_mm"], dtype=float).ravel()[take]
        self.film = film
        self.settings = dict(wheel=wheel, rail=rail, rail_inclination=rail_inclination,
                             nominal_radius_mm=nominal_radius_mm, grid_mm=grid_mm)
        self.model_radius_std_mm = model_radius_std_mm
        self.random_state = random_state

    def film_area_mm2(self, modulus_mpa: float, offset_mm: float, force_n: float) -> float:
        """The area the film records at modulus E (the film model's kinematics and imprint reading)."""
        film, law, _ = self.film.interface(float(modulus_mpa))
        result = solve_wheel_rail(offset_mm, force_n, film=film, roughness=law, **self.settings)
        return self.film.recorded_area_mm2(result)

    def area_ratio(self, offset_mm: float, force_n: float) -> tuple[np.ndarray, dict]:
        """A_0 / A_f(E) for every posterior sample, and the solved support points."""
        a0 = solve_wheel_rail(offset_mm, force_n, film=None, **self.settings).area_mm2
        e_grid = np.unique(np.quantile(self.modulus_mpa_, QUANTILES))
        a_f = np.array([self.film_area_mm2(e, offset_mm, force_n) for e in e_grid])
        log_ratio = np.log(a0 / a_f)
        degree = min(2, len(e_grid) - 1)
        coef = np.polyfit(np.log(e_grid), log_ratio, degree) if degree > 0 else log_ratio
        ratio = np.exp(np.polyval(coef, np.log(self.modulus_mpa_)) if degree > 0 else np.full_like(
            self.modulus_mpa_, log_ratio[0]))
        return ratio, {"area_no_film_mm2": a0, "modulus_grid_mpa": e_grid, "area_film_mm2": a_f}

    def correct(self, measured_area_mm2, offset_mm, force_n, measurement_std_mm2=0.0) -> CorrectedArea:
        """The contact area without film behind measured imprint areas (vectorised).

        Parameters
        ----------
        measured_area_mm2 : float or array_like
            Imprint area on the film (mm^2), > 0.
        offset_mm : float or array_like
            Lateral offset eta (mm, the paper's convention).
        force_n : float or array_like
            Wheel load (N), > 0.
        measurement_std_mm2 : float or array_like
            The user's standard uncertainty of the measured area (mm^2), >= 0.
        """
        A, eta, F, u = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                            (measured_area_mm2, offset_mm, force_n, measurement_std_mm2)))
        if not np.all(np.isfinite(A)) or np.any(A <= 0):
            raise ValueError("measured_area_mm2 must be finite and > 0")
        if not np.all(np.isfinite(u)) or np.any(u < 0):
            raise ValueError("measurement_std_mm2 must be finite and >= 0")
        rng = np.random.default_rng(self.random_state)
        n = len(self.modulus_mpa_)
        samples = np.empty(A.shape + (n,))
        cache: dict[tuple[float, float], np.ndarray] = {}
        scatter_mm = np.sqrt(self.sigma_mm_**2 + self.model_radius_std_mm**2)
        for idx in np.ndindex(A.shape):
            key = (float(eta[idx]), float(F[idx]))
            if key not in cache:
                cache[key] = self.area_ratio(*key)[0]
            r_m = np.sqrt(A[idx] / np.pi)
            measured = A[idx] + u[idx] * rng.standard_normal(n)
            samples[idx] = measured * cache[key] * (1.0 + 2.0 * scatter_mm / r_m * rng.standard_normal(n))
        samples = np.clip(samples, 0.0, None)
        return _summarise(samples, np.sqrt(samples / np.pi))
