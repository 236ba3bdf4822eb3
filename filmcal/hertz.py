"""Hertz theory of a sphere pressed on a flat (circular contact): the reference
solution of the package, shared by the FE model, the calibration data and checks.

Johnson, Contact Mechanics (1985), section 4.2: a = (3 F R / (4 E*))^(1/3),
p0 = 3 F / (2 pi a^2), mutual approach delta = a^2 / R,
p(r) = p0 sqrt(1 - r^2/a^2), 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2.
"""
from __future__ import annotations

import numpy as np

__all__ = ["STEEL_MODULUS_MPA", "STEEL_POISSON", "ELASTIC_LIMIT_MPA", "contact_modulus_mpa", "hertz_radius_mm",
           "hertz_max_pressure_mpa", "hertz_approach_mm", "hertz_pressure_mpa"]

#: Young's modulus of the steel sphere and flat in the experiments (MPa).
STEEL_MODULUS_MPA = 210000.0
#: Poisson's ratio of the steel sphere and flat in the experiments.
STEEL_POISSON = 0.3
#: The steel's elastic limit as a peak Hertz pressure (MPa): the paper's specimens stayed elastic at R450 / 100 kN
#: (p0 1083 MPa) and R300 / 50 kN (1127 MPa); it skipped R300 at 75 and 100 kN (1290 and 1420 MPa) "to avoid
#: plastic strain".
ELASTIC_LIMIT_MPA = 1250.0


def _positive(name: str, value: object) -> np.ndarray:
    """`value` as a float array after checking that every entry is finite and > 0."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}") from None
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0.0):
        raise ValueError(f"{name} must be finite and > 0, got {value!r}")
    return arr


def _poisson(name: str, value: object) -> np.ndarray:
    """`value` as a float array after checking -1 < nu < 0.5 entry by entry."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must lie in (-1, 0.5), got {value!r}") from None
    if not np.all(np.isfinite(arr)) or np.any(arr <= -1.0) or np.any(arr >= 0.5):
        raise ValueError(f"{name} must lie in (-1, 0.5), got {value!r}")
    return arr


def _scalar_or_array(x: np.ndarray) -> float | np.ndarray:
    return float(x) if x.ndim == 0 else x


def contact_modulus_mpa(modulus_mpa: float | np.ndarray = STEEL_MODULUS_MPA,
                        poisson: float | np.ndarray = STEEL_POISSON,
                        modulus2_mpa: float | np.ndarray | None = None,
                        poisson2: float | np.ndarray | None = None) -> float | np.ndarray:
    """Hertz contact modulus E* of two elastic bodies.

    ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (Johnson, Contact Mechanics,
    eq. 4.22). The second body defaults to the material of the first, which
    gives ``E* = E / (2 (1 - nu^2))``; ``modulus2_mpa=numpy.inf`` is a rigid
    second body.

    Parameters
    ----------
    modulus_mpa, poisson : float or array_like
        Young's modulus (MPa) and Poisson's ratio of the first body.
    modulus2_mpa, poisson2 : float or array_like, optional
        The same for the second body; default: equal to the first.

    Returns
    -------
    float or ndarray
        E* in MPa.
    """
    e1 = _positive("modulus_mpa", modulus_mpa)
    nu1 = _poisson("poisson", poisson)
    if modulus2_mpa is None:
        e2 = e1
    else:
        e2 = np.asarray(modulus2_mpa, dtype=float)
        if np.any(np.isnan(e2)) or np.any(e2 <= 0.0):
            raise ValueError(f"modulus2_mpa must be > 0 (inf for a rigid body), got {modulus2_mpa!r}")
    nu2 = nu1 if poisson2 is None else _poisson("poisson2", poisson2)
    return _scalar_or_array(1.0 / ((1.0 - nu1**2) / e1 + (1.0 - nu2**2) / e2))


def hertz_radius_mm(sphere_radius_mm: float | np.ndarray, force_n: float | np.ndarray,
                    modulus_mpa: float | np.ndarray = STEEL_MODULUS_MPA,
                    poisson: float | np.ndarray = STEEL_POISSON,
                    modulus2_mpa: float | np.ndarray | None = None,
                    poisson2: float | np.ndarray | None = None) -> float | np.ndarray:
    """Hertz contact radius of a sphere pressed on a flat.

    ``a = (3 F R / (4 E*))^(1/3)`` with `contact_modulus_mpa` E* (Johnson,
    Contact Mechanics, eq. 4.22). With the defaults both bodies are the steel of
    the experiments: R = 450 mm, F = 75 kN gives a = 6.031 mm.

    Parameters
    ----------
    sphere_radius_mm : float or array_like
        Sphere radius R (mm), > 0.
    force_n : float or array_like
        Normal force F (N), > 0.
    modulus_mpa, poisson : float or array_like
        Young's modulus (MPa) and Poisson's ratio of the sphere.
    modulus2_mpa, poisson2 : float or array_like, optional
        The same for the flat; default: the sphere's material.

    Returns
    -------
    float or ndarray
        Contact radius a in mm (broadcast over the inputs).
    """
    r = _positive("sphere_radius_mm", sphere_radius_mm)
    f = _positive("force_n", force_n)
    e_star = contact_modulus_mpa(modulus_mpa, poisson, modulus2_mpa, poisson2)
    return _scalar_or_array(np.cbrt(3.0 * f * r / (4.0 * np.asarray(e_star))))


def hertz_max_pressure_mpa(sphere_radius_mm: float | np.ndarray, force_n: float | np.ndarray,
                           modulus_mpa: float | np.ndarray = STEEL_MODULUS_MPA,
                           poisson: float | np.ndarray = STEEL_POISSON,
                           modulus2_mpa: float | np.ndarray | None = None,
                           poisson2: float | np.ndarray | None = None) -> float | np.ndarray:
    """Hertz maximum contact pressure of a sphere pressed on a flat.

    ``p0 = 3 F / (2 pi a^2)`` with the `hertz_radius_mm` a (Johnson, Contact
    Mechanics, eq. 4.21). Steel on steel, R = 450 mm, F = 75 kN: p0 = 984.5 MPa.

    Parameters
    ----------
    sphere_radius_mm, force_n, modulus_mpa, poisson, modulus2_mpa, poisson2
        As in `hertz_radius_mm`.

    Returns
    -------
    float or ndarray
        p0 in MPa.
    """
    a = np.asarray(hertz_radius_mm(sphere_radius_mm, force_n, modulus_mpa, poisson, modulus2_mpa, poisson2))
    f = np.asarray(force_n, dtype=float)
    return _scalar_or_array(3.0 * f / (2.0 * np.pi * a**2))


def hertz_approach_mm(sphere_radius_mm, force_n, modulus_mpa=STEEL_MODULUS_MPA, poisson=STEEL_POISSON,
                      modulus2_mpa=None, poisson2=None) -> float | np.ndarray:
    """Hertz mutual approach of distant points, delta = a^2 / R (mm)."""
    a = np.asarray(hertz_radius_mm(sphere_radius_mm, force_n, modulus_mpa, poisson, modulus2_mpa, poisson2))
    return _scalar_or_array(a**2 / np.asarray(sphere_radius_mm, dtype=float))


def hertz_pressure_mpa(r_mm, sphere_radius_mm: float, force_n: float, modulus_mpa=STEEL_MODULUS_MPA,
                       poisson=STEEL_POISSON, modulus2_mpa=None, poisson2=None) -> np.ndarray:
    """Hertz pressure distribution p(r) = p0 sqrt(1 - r^2/a^2), zero outside (MPa)."""
    a = hertz_radius_mm(sphere_radius_mm, force_n, modulus_mpa, poisson, modulus2_mpa, poisson2)
    p0 = hertz_max_pressure_mpa(sphere_radius_mm, force_n, modulus_mpa, poisson, modulus2_mpa, poisson2)
    r = np.asarray(r_mm, dtype=float)
    return p0 * np.sqrt(np.clip(1.0 - (r / a) ** 2, 0.0, None))


def plausible_imprint_radius_mm(hertz_radius: float | np.ndarray) -> tuple:
    """The range of imprint radii a film can print around a Hertz radius a_H: ``[a_H / 2, 1.5 a_H + 5 mm]``.

    Steel on steel, a film enlarges the Hertz radius by at most a few millimetres (Table 1 of the reference
    paper: up to 2.8 mm for the softest film) and never shrinks it by half; outside this range a radius is a
    unit or typing error. The one rule of datasets and correctors alike.
    """
    a = np.asarray(hertz_radius, dtype=float)
    return 0.5 * a, 1.5 * a + 5.0
