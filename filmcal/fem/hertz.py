"""Hertz theory of a sphere pressed on a flat (circular contact).

Reference: K. L. Johnson, Contact Mechanics (1985), section 4.2:
a = (3 F R / (4 E*))^(1/3), p0 = 3 F / (2 pi a^2), delta = a^2 / R,
1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2, p(r) = p0 sqrt(1 - r^2/a^2).
"""
from __future__ import annotations

import numpy as np

from filmcal._validation import check_poisson, check_positive

STEEL_MODULUS_MPA = 210000.0
STEEL_POISSON = 0.3

__all__ = [
    "STEEL_MODULUS_MPA", "STEEL_POISSON", "effective_modulus_mpa", "hertz_radius_mm",
    "hertz_max_pressure_mpa", "hertz_approach_mm", "hertz_pressure_mpa",
]


def effective_modulus_mpa(modulus1_mpa: float = STEEL_MODULUS_MPA, poisson1: float = STEEL_POISSON,
                          modulus2_mpa: float | None = None, poisson2: float | None = None) -> float:
    """Contact modulus E* of two elastic bodies (the second defaults to the first)."""
    e1 = check_positive("modulus1_mpa", modulus1_mpa)
    n1 = check_poisson("poisson1", poisson1)
    e2 = e1 if modulus2_mpa is None else check_positive("modulus2_mpa", modulus2_mpa)
    n2 = n1 if poisson2 is None else check_poisson("poisson2", poisson2)
    return 1.0 / ((1.0 - n1**2) / e1 + (1.0 - n2**2) / e2)


def hertz_radius_mm(radius_mm, force_n, contact_modulus_mpa: float | None = None):
    """Hertz contact radius a = (3 F R / (4 E*))^(1/3) of a sphere on a flat.

    Parameters
    ----------
    radius_mm : float or array
        Sphere radius R (mm).
    force_n : float or array
        Normal force F (N).
    contact_modulus_mpa : float, optional
        E*; two steel bodies (E = 210000 MPa, nu = 0.3) by default.

    Returns
    -------
    float or ndarray
        Contact radius in mm. R450, 75 kN, steel on steel gives 6.031 mm.
    """
    estar = effective_modulus_mpa() if contact_modulus_mpa is None else contact_modulus_mpa
    r = np.asarray(radius_mm, dtype=float)
    f = np.asarray(force_n, dtype=float)
    if np.any(~np.isfinite(r)) or np.any(r <= 0):
        raise ValueError("radius_mm must be finite and > 0")
    if np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise ValueError("force_n must be finite and > 0")
    a = np.cbrt(3.0 * f * r / (4.0 * estar))
    return float(a) if a.ndim == 0 else a


def hertz_max_pressure_mpa(radius_mm, force_n, contact_modulus_mpa: float | None = None):
    """Hertz maximum pressure p0 = 3F / (2 pi a^2) (MPa)."""
    a = np.asarray(hertz_radius_mm(radius_mm, force_n, contact_modulus_mpa))
    p0 = 3.0 * np.asarray(force_n, dtype=float) / (2.0 * np.pi * a**2)
    return float(p0) if p0.ndim == 0 else p0


def hertz_approach_mm(radius_mm, force_n, contact_modulus_mpa: float | None = None):
    """Hertz mutual approach of distant points, delta = a^2 / R (mm)."""
    a = np.asarray(hertz_radius_mm(radius_mm, force_n, contact_modulus_mpa))
    d = a**2 / np.asarray(radius_mm, dtype=float)
    return float(d) if d.ndim == 0 else d


def hertz_pressure_mpa(r_mm, radius_mm: float, force_n: float, contact_modulus_mpa: float | None = None):
    """Hertz pressure distribution p(r) = p0 sqrt(1 - r^2/a^2), zero outside (MPa)."""
    a = hertz_radius_mm(radius_mm, force_n, contact_modulus_mpa)
    p0 = hertz_max_pressure_mpa(radius_mm, force_n, contact_modulus_mpa)
    r = np.asarray(r_mm, dtype=float)
    return p0 * np.sqrt(np.clip(1.0 - (r / a) ** 2, 0.0, None))
