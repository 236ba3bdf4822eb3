"""A radius model tabulated at the data's own cases: any model in the loop at a few moduli per case.

For a calibration of E with nu fixed, the radius model is needed only at the
(R, F) cases of the data. `TabulatedRadiusModel` evaluates any model there
(the FE model, an external solver) at a handful of moduli and interpolates in
ln E by a cubic spline; `max_error_mm` checks the interpolation against
further evaluations the table did not see, and that error is the model's
predictive std. A few evaluations per case replace a surrogate over the
whole (E, nu, R, F) domain when the data are few, e.g. a lab's own film lot.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterable

import numpy as np
from scipy.interpolate import CubicSpline

__all__ = ["TabulatedRadiusModel"]


@dataclass
class TabulatedRadiusModel:
    """Radius per (R, F) case as a cubic spline in ln E, at one fixed nu.

    Parameters
    ----------
    cases : list of (float, float)
        (sphere_radius_mm, force_n) of each case.
    moduli_mpa : ndarray of shape (m,)
        Increasing moduli of the table (m >= 4); the model is defined
        between the first and the last only.
    radius_mm : ndarray of shape (n_cases, m)
        Radius of each case at each modulus.
    poisson : float
        The nu the table was made at; `predict` refuses any other.
    std_mm : float, default 0
        Predictive std (e.g. the interpolation error from `max_error_mm`).
    """

    cases: list
    moduli_mpa: np.ndarray
    radius_mm: np.ndarray
    poisson: float
    std_mm: float = 0.0

    def __post_init__(self) -> None:
        self.moduli_mpa = np.asarray(self.moduli_mpa, dtype=float)
        self.radius_mm = np.asarray(self.radius_mm, dtype=float)
        self.cases = [(float(r), float(f)) for r, f in self.cases]
        m = self.moduli_mpa.size
        if m < 4 or np.any(np.diff(self.moduli_mpa) <= 0) or np.any(self.moduli_mpa <= 0):
            raise ValueError(f"moduli_mpa must be at least 4 increasing values > 0, got {self.moduli_mpa}")
        if self.radius_mm.shape != (len(self.cases), m):
            raise ValueError(f"radius_mm must have shape ({len(self.cases)}, {m}), got {self.radius_mm.shape}")
        if not np.all(np.isfinite(self.radius_mm)):
            raise ValueError("radius_mm holds non-finite values (a failed model evaluation?)")
        if not (np.isfinite(self.std_mm) and self.std_mm >= 0):
            raise ValueError(f"std_mm must be finite and >= 0, got {self.std_mm!r}")
        self._splines = {case: CubicSpline(np.log(self.moduli_mpa), row) for case, row in
                         zip(self.cases, self.radius_mm)}

    @classmethod
    def from_function(cls, radius: Callable[[float, float, float, float], float], cases: Iterable,
                      moduli_mpa: Iterable[float], poisson: float, std_mm: float = 0.0) -> TabulatedRadiusModel:
        """Tabulate ``radius(modulus_mpa, poisson, sphere_radius_mm, force_n) -> mm`` at every case and modulus."""
        cases = [(float(r), float(f)) for r, f in cases]
        moduli = np.asarray(list(moduli_mpa), dtype=float)
        table = np.array([[float(radius(e, poisson, r, f)) for e in moduli] for r, f in cases])
        return cls(cases, moduli, table, float(poisson), std_mm)

    def max_error_mm(self, radius: Callable[[float, float, float, float], float],
                     moduli_mpa: Iterable[float]) -> float:
        """Largest |spline - radius| over every case at moduli the table did not use."""
        moduli = np.asarray(list(moduli_mpa), dtype=float)
        errors = [float(self._splines[(r, f)](np.log(e))) - float(radius(e, self.poisson, r, f))
                  for r, f in self.cases for e in moduli]
        return float(np.max(np.abs(errors)))

    @property
    def modulus_range_mpa(self) -> tuple[float, float]:
        """Where the table is defined (use it as the prior range of E)."""
        return float(self.moduli_mpa[0]), float(self.moduli_mpa[-1])

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n) -> tuple[np.ndarray, np.ndarray]:
        """Radius (mm) and its std at tabulated cases; NaN outside the table's moduli."""
        E, nu, R, F = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in
                                            (modulus_mpa, poisson, sphere_radius_mm, force_n)))
        if not np.allclose(nu, self.poisson, rtol=0, atol=1e-12):
            raise ValueError(f"poisson must be {self.poisson:g}, the table's value")
        mean = np.full(E.shape, np.nan)
        found = np.zeros(E.shape, dtype=bool)
        for (r, f), spline in self._splines.items():
            at = (R == r) & (F == f)
            found |= at
            mean[at] = spline(np.log(E[at]))
        if not np.all(found):
            j = np.flatnonzero(~found.ravel())[0]
            raise ValueError(f"no table for sphere_radius_mm={R.ravel()[j]:g}, force_n={F.ravel()[j]:g}")
        lo, hi = self.modulus_range_mpa
        mean[(E < lo * (1 - 1e-9)) | (E > hi * (1 + 1e-9))] = np.nan  # ends reached through exp(log(.)) count
        return mean, np.full(E.shape, float(self.std_mm))
