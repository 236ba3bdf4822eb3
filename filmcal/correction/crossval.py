"""Leave-one-case-out cross-validation of the sphere-on-flat correction on Table 1.

For each (R, F) case of a film type: calibrate the film without that case,
correct the case's measured radius, and check whether the Hertz area (the
truth of these Hertzian experiments) lies inside the corrected 90 % interval.
A correction that can be trusted puts it there in about 9 of 10 cases.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from filmcal.correction.sphere import SphereCorrector
from filmcal.hertz import hertz_radius_mm

__all__ = ["CaseCrossValidation", "cross_validate_case", "leave_one_case_out"]


@dataclass
class CaseCrossValidation:
    """Corrections of each Table 1 case by a calibration that did not see it (arrays of shape (n,)).

    Attributes
    ----------
    film : str
    sphere_radius_mm, force_n, measured_radius_mm : ndarray
        The cases.
    hertz_area_mm2 : ndarray
        The truth: pi a_Hertz^2.
    area_mm2, area_std_mm2 : ndarray
        Corrected area (posterior mean and std) of each held-out case.
    area_ci90_mm2 : ndarray, shape (n, 2)
        Its 90 % interval.
    modulus_median_mpa : ndarray
        Posterior median of E of each fold.
    """

    film: str
    sphere_radius_mm: np.ndarray
    force_n: np.ndarray
    measured_radius_mm: np.ndarray
    hertz_area_mm2: np.ndarray
    area_mm2: np.ndarray
    area_std_mm2: np.ndarray
    area_ci90_mm2: np.ndarray
    modulus_median_mpa: np.ndarray

    @property
    def inside(self) -> np.ndarray:
        """Whether each Hertz area lies inside its corrected 90 % interval."""
        return (self.area_ci90_mm2[:, 0] <= self.hertz_area_mm2) & (self.hertz_area_mm2 <= self.area_ci90_mm2[:, 1])

    @property
    def hits(self) -> int:
        return int(self.inside.sum())

    def to_dict(self) -> dict:
        """Plain JSON values."""
        return {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.__dict__.items()}

    @classmethod
    def from_dict(cls, d: dict) -> CaseCrossValidation:
        """Inverse of `to_dict`."""
        return cls(film=str(d["film"]), **{k: np.asarray(v, dtype=float) for k, v in d.items() if k != "film"})

    @classmethod
    def from_folds(cls, film: str, folds: list[dict]) -> CaseCrossValidation:
        """Gather the outputs of `cross_validate_case`, one per case, in case order."""
        keys = ("sphere_radius_mm", "force_n", "measured_radius_mm", "hertz_area_mm2", "area_mm2", "area_std_mm2",
                "area_ci90_mm2", "modulus_median_mpa")
        return cls(film, *(np.asarray([f[k] for f in folds], dtype=float) for k in keys))


def cross_validate_case(model, film: str, case: int, loads: str | None = None, priors=None, seed: int = 0) -> dict:
    """One fold: calibrate `film` without case `case` of Table 1 and correct that case's measured radius.

    Parameters
    ----------
    model : RadiusModel
        ``predict(E, nu, R, F) -> (mean, std)`` of the printed radius (e.g. a
        `filmcal.study.SurrogateRadiusModel`).
    film : str
        MS, HS or HHS.
    case : int
        Index of the held-out case in ``load_table1(film, loads)``.
    loads : str, optional
        Load range of the data (default: all loads).
    priors : filmcal.calibration.Priors, optional
    seed : int
        Seed of the fold's chains and scatter draws (the fold uses ``seed + case``).
    """
    from filmcal.calibration import calibrate, load_table1

    data = load_table1(film, loads)
    if not 0 <= case < len(data):
        raise ValueError(f"case must be in [0, {len(data) - 1}], got {case}")
    keep = np.ones(len(data), bool)
    keep[case] = False
    result = calibrate(data.select(keep), model, film=film, loads=loads, priors=priors, seed=seed + case)
    corrected = SphereCorrector(model, result.samples, random_state=seed + case).correct(
        data.measured_radius_mm[case], data.sphere_radius_mm[case], data.force_n[case])
    r, f = float(data.sphere_radius_mm[case]), float(data.force_n[case])
    return {"sphere_radius_mm": r, "force_n": f, "measured_radius_mm": float(data.measured_radius_mm[case]),
            "hertz_area_mm2": float(np.pi * hertz_radius_mm(r, f) ** 2), "area_mm2": float(corrected.area_mm2),
            "area_std_mm2": float(corrected.area_std_mm2),
            "area_ci90_mm2": [float(x) for x in corrected.area_ci90_mm2],
            "modulus_median_mpa": float(result.modulus_mpa["median"])}


def leave_one_case_out(model, film: str, loads: str | None = None, priors=None, seed: int = 0,
                       log=None) -> CaseCrossValidation:
    """All folds of a film type in turn (see `cross_validate_case`)."""
    from filmcal.calibration import load_table1

    folds = []
    for case in range(len(load_table1(film, loads))):
        folds.append(cross_validate_case(model, film, case, loads, priors, seed))
        if log:
            log(f"{film} fold {case + 1}: R{folds[-1]['sphere_radius_mm']:g} / {folds[-1]['force_n'] / 1e3:g} kN")
    return CaseCrossValidation.from_folds(film, folds)
