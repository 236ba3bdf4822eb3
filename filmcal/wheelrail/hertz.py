"""Hertz theory of elliptic point contact between two elastic bodies.

Two bodies touching at a point, with the undeformed separation near it written
as ``g(x, y) = A x**2 + B y**2`` in the principal axes of relative curvature
(``A = (1/R1x + 1/R2x)/2``, ``B = (1/R1y + 1/R2y)/2``), pressed together by a
normal force ``F``, touch over an ellipse with semi-axes ``a_x`` along x and
``a_y`` along y and carry the semi-ellipsoidal pressure
``p = p0 * sqrt(1 - x**2/a_x**2 - y**2/a_y**2)``.

The circular case (``A = B = 1/(2R)``) is :mod:`filmcal.hertz`. With ``a``
the larger and ``b`` the smaller semi-axis, ``e**2 = 1 - b**2/a**2``
and the complete elliptic integrals ``K(e)``, ``E(e)``, Hertz's solution reads
(Johnson, *Contact Mechanics*, 1985, chapters 3 and 4)::

    A_small = (p0 / E*) (b / (e**2 a**2)) [K(e) - E(e)]
    A_large = (p0 / E*) (b / (e**2 a**2)) [(a**2 / b**2) E(e) - K(e)]
    delta   = (p0 / E*) b K(e)
    F       = (2/3) pi a b p0

where ``A_small <= A_large`` are the two gap coefficients (the larger semi-axis
lies along the direction of smaller curvature) and ``1/E* = (1 - nu1**2)/E1 +
(1 - nu2**2)/E2``. The ratio ``A_large/A_small`` depends on ``e`` alone and is
solved for ``e`` with a bracketing root finder; ``F`` then fixes the size.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.special import ellipe, ellipk

from filmcal._validation import check_positive
from filmcal.hertz import contact_modulus_mpa

__all__ = ["HertzContact", "hertz_elliptic"]

# Below this parameter m = e**2 the ellipse is treated with the series of K - E
# to avoid cancellation (relative error of the series < 1e-12 there).
_SMALL_M = 1e-6


@dataclass(frozen=True)
class HertzContact:
    """Hertz solution of an elliptic (or circular) point contact.

    Attributes
    ----------
    semi_axis_x_mm, semi_axis_y_mm : float
        Semi-axes of the contact ellipse along x and y.
    max_pressure_mpa : float
        Peak pressure ``p0 = 3F / (2 pi a_x a_y)``.
    approach_mm : float
        Rigid approach of distant points of the two bodies.
    area_mm2 : float
        ``pi a_x a_y``.
    eccentricity : float
        ``e = sqrt(1 - b**2/a**2)`` with ``b <= a`` the two semi-axes.
    """

    semi_axis_x_mm: float
    semi_axis_y_mm: float
    max_pressure_mpa: float
    approach_mm: float
    area_mm2: float
    eccentricity: float

    @property
    def equivalent_radius_mm(self) -> float:
        """Radius of the circle with the same area, ``sqrt(a_x a_y)``."""
        return math.sqrt(self.semi_axis_x_mm * self.semi_axis_y_mm)

    def pressure_mpa(self, x_mm: np.ndarray, y_mm: np.ndarray) -> np.ndarray:
        """Hertz pressure at points ``(x, y)`` (zero outside the ellipse)."""
        s = 1.0 - (np.asarray(x_mm) / self.semi_axis_x_mm) ** 2 \
            - (np.asarray(y_mm) / self.semi_axis_y_mm) ** 2
        return self.max_pressure_mpa * np.sqrt(np.clip(s, 0.0, None))


def _k_minus_e_over_m(m: float) -> float:
    """``(K(m) - E(m)) / m`` for the parameter ``m = e**2``, stable at small m."""
    if m < _SMALL_M:
        # K - E = (pi/4) m (1 + 3m/8 + ...)
        return 0.25 * math.pi * (1.0 + 0.375 * m)
    return (ellipk(m) - ellipe(m)) / m


def _curvature_ratio(m: float) -> float:
    """``A_large / A_small`` of the ellipse with parameter ``m = e**2``."""
    if m < _SMALL_M:
        # both numerator and denominator ~ (pi/4) m: ratio = 1 + 3m/4 + O(m^2)
        return 1.0 + 0.75 * m
    k, e = ellipk(m), ellipe(m)
    return (e / (1.0 - m) - k) / (k - e)


def _solve_parameter(ratio: float) -> float:
    """Elliptic parameter ``m = e**2`` that gives ``A_large / A_small = ratio``.

    The root is bracketed in ``q = -log(1 - m)`` (so that very elongated
    ellipses, m close to 1, stay resolved in double precision).
    """
    if ratio - 1.0 < 1e-12:
        return 0.0

    def residual(q: float) -> float:
        return math.log(_curvature_ratio(-math.expm1(-q))) - math.log(ratio)

    q_hi = 1.0
    while residual(q_hi) < 0.0:
        q_hi *= 2.0
        if q_hi > 700.0:
            raise ValueError(f"curvature ratio {ratio:g} is too large for an elliptic contact")
    q = brentq(residual, 0.0, q_hi, xtol=1e-300, rtol=1e-15, maxiter=200)
    return -math.expm1(-q)


def hertz_elliptic(gap_coefficient_x_per_mm: float, gap_coefficient_y_per_mm: float,
                   force_n: float, contact_modulus: float | None = None) -> HertzContact:
    """Hertz solution for the gap ``A x**2 + B y**2`` pressed by a force ``F``.

    Parameters
    ----------
    gap_coefficient_x_per_mm, gap_coefficient_y_per_mm : float
        ``A`` and ``B`` (1/mm), both > 0; ``A = 1/(2 R'_x)`` with ``R'_x`` the
        relative radius of curvature in the x-z plane.
    force_n : float
        Normal force (N), > 0.
    contact_modulus : float, optional
        Contact modulus ``E*`` (MPa, see :func:`filmcal.hertz.contact_modulus_mpa`);
        default: two steel bodies (115385 MPa).

    Returns
    -------
    HertzContact
    """
    a_coef = check_positive("gap_coefficient_x_per_mm", gap_coefficient_x_per_mm)
    b_coef = check_positive("gap_coefficient_y_per_mm", gap_coefficient_y_per_mm)
    force = check_positive("force_n", force_n)
    e_star = contact_modulus_mpa() if contact_modulus is None else \
        check_positive("contact_modulus", contact_modulus)
    small, large = min(a_coef, b_coef), max(a_coef, b_coef)
    m = _solve_parameter(large / small)
    km_e = _k_minus_e_over_m(m)
    # From A_small and F = (2/3) pi a b p0: a**3 = 3 F (K - E) / (2 pi A_small E* e**2)
    a = (3.0 * force * km_e / (2.0 * math.pi * small * e_star)) ** (1.0 / 3.0)
    b = a * math.sqrt(1.0 - m)
    p0 = 3.0 * force / (2.0 * math.pi * a * b)
    approach = p0 * b * float(ellipk(m)) / e_star
    ax, ay = (a, b) if a_coef <= b_coef else (b, a)
    return HertzContact(semi_axis_x_mm=ax, semi_axis_y_mm=ay, max_pressure_mpa=p0,
                        approach_mm=approach, area_mm2=math.pi * a * b,
                        eccentricity=math.sqrt(m))
