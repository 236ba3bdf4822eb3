"""Compliant interfaces in series with the elastic bodies: film and roughness.

Both act on the normal contact problem of :mod:`filmcal.wheelrail.halfspace`
through an *interface closure* ``c(p)``: the extra approach of the two bodies
that a cell under pressure ``p`` allows on top of the elastic displacement of
the half-spaces. Contact holds where ``h + u_el(p) + c(p) = delta``.

* :class:`FilmLayer` -- a thin layer of thickness ``t`` held laterally (tied, or
  sticking by friction) is compressed oedometrically: ``c(p) = p t / M`` with
  ``M = E (1 - nu) / ((1 + nu)(1 - 2 nu))`` the oedometric (constrained)
  modulus. In a linear model the contact depends on ``(E, nu)`` only through
  ``M``: ``E`` and ``nu`` cannot be identified separately from contact areas.
* :class:`InterfaceLaw` subclasses -- pressure-overclosure laws of a rough
  interface, ``c(p)`` increasing with ``c(0) = 0``: closures are measured from
  the separation at which the interface starts to carry pressure.

  - :class:`HardLaw`: no closure (smooth, hard contact).
  - :class:`ExponentialLaw`: ``p = p0 (exp(c / c0) - 1)``.
  - :class:`TabularLaw`: measured pressure-closure points, monotone
    (PCHIP) interpolation.
  - :class:`GreenwoodWilliamsonLaw`: elastic spherical asperities with
    Gaussian or exponential summit heights, from ``Ra``.
  - :class:`LargeStrainFilm`: the film itself under large strain (the
    oedometric law of the FE model's compressible neo-Hookean film), passed
    to the solver as a law instead of a linear :class:`FilmLayer`.
  - :class:`SeriesLaw`: laws in series (a large-strain film and a rough
    interface): closures add at a common pressure.

  A rough interface computed from the surface by contact mechanics is
  :func:`filmcal.contact.roughness.rough_contact_law` (a :class:`TabularLaw`).

A note on Abaqus: its "exponential" pressure-overclosure law is
``p = p0 / (e - 1) * (h/c0 + 1) * (exp(h/c0 + 1) - 1)`` for an overclosure
``h > -c0``; :class:`ExponentialLaw` is the simpler ``p0 (exp(c/c0) - 1)``
(the exact Greenwood-Williamson law of exponential summit heights, shifted to
start at zero pressure). A tabulated Abaqus law is used with :class:`TabularLaw`.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.special import gamma, pbdv

from filmcal.elastic import oedometric_modulus_mpa
from filmcal._validation import (FILM_MODULUS_MPA_BOUNDS, FILM_THICKNESS_MM_BOUNDS, check_choice, check_poisson,
                                 check_positive, check_range)

__all__ = [
    "through_film",
    "FilmLayer",
    "InterfaceLaw",
    "HardLaw",
    "ExponentialLaw",
    "TabularLaw",
    "GreenwoodWilliamsonLaw",
    "LargeStrainFilm",
    "SeriesLaw",
    "film_law",
]


@dataclass(frozen=True)
class FilmLayer:
    """Linear-elastic film between the bodies, acting as normal springs.

    Parameters
    ----------
    modulus_mpa : float
        Young's modulus of the film (MPa), > 0.
    poisson : float
        Poisson's ratio, -1 < nu < 0.5 (default 0.33, the paper's value).
    thickness_mm : float
        Film thickness (mm), default 0.09 (Prescale's PET carrier).

    Notes
    -----
    The film adds ``p t / M`` to the elastic closure of every loaded cell: a
    Winkler layer of stiffness ``M / t`` per unit area in series with the
    half-spaces. This neglects the film's shear coupling between neighbouring
    cells (its bending and membrane stiffness), which is small for a film
    much thinner than the contact (90 um against millimetres).
    """

    modulus_mpa: float
    poisson: float = 0.33
    thickness_mm: float = 0.09

    def __post_init__(self) -> None:
        check_range("modulus_mpa", self.modulus_mpa, *FILM_MODULUS_MPA_BOUNDS, low_open=False, high_open=False)
        check_poisson("poisson", self.poisson)
        check_range("thickness_mm", self.thickness_mm, *FILM_THICKNESS_MM_BOUNDS, low_open=False, high_open=False)

    @property
    def oedometric_modulus_mpa(self) -> float:
        """Constrained modulus ``M`` of the film (MPa)."""
        return oedometric_modulus_mpa(self.modulus_mpa, self.poisson)

    @property
    def compliance_mm_per_mpa(self) -> float:
        """Closure per unit pressure, ``t / M`` (mm/MPa)."""
        return self.thickness_mm / self.oedometric_modulus_mpa


class InterfaceLaw(ABC):
    """Pressure-overclosure law of an interface, written as closure(pressure).

    Subclasses give ``closure_mm(p)``, increasing with ``closure_mm(0) = 0``,
    its slope ``tangent_compliance_mm_per_mpa(p)`` and its inverse
    ``pressure_mpa(c)``.
    """

    #: True for the law without any closure (hard contact).
    is_hard: bool = False

    @abstractmethod
    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Interface closure (mm) at pressures ``pressure_mpa`` (>= 0)."""

    @abstractmethod
    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """Pressure (MPa) carried at closures ``closure_mm`` (inverse law)."""

    @abstractmethod
    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Slope ``dc/dp`` (mm/MPa) at pressures ``pressure_mpa`` (>= 0)."""

    @abstractmethod
    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``int_0^p c(q) dq`` (mm MPa): the energy per unit area stored in the
        interface (complementary energy), used by the nonlinear solver."""

    @property
    def initial_compliance_mm_per_mpa(self) -> float:
        """``dc/dp`` at zero pressure (mm/MPa)."""
        return float(self.tangent_compliance_mm_per_mpa(np.zeros(1))[0])


class HardLaw(InterfaceLaw):
    """Hard contact: no closure at any pressure (smooth surfaces)."""

    is_hard = True

    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Zero closure."""
        return np.zeros_like(np.asarray(pressure_mpa, dtype=float))

    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """Zero below contact, unbounded for any positive closure."""
        c = np.asarray(closure_mm, dtype=float)
        return np.where(c > 0.0, np.inf, 0.0)

    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Zero."""
        return np.zeros_like(np.asarray(pressure_mpa, dtype=float))

    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Zero."""
        return np.zeros_like(np.asarray(pressure_mpa, dtype=float))

    def __repr__(self) -> str:
        return "HardLaw()"


class ExponentialLaw(InterfaceLaw):
    """Exponential pressure-overclosure: ``p = p0 (exp(c / c0) - 1)``.

    Equivalently ``c = c0 log(1 + p / p0)``. Its stiffness at zero pressure is
    ``p0 / c0``; for pressures far below ``p0`` it is a linear spring.

    Parameters
    ----------
    pressure_scale_mpa : float
        ``p0`` (MPa), > 0.
    closure_scale_mm : float
        ``c0`` (mm), > 0.
    """

    def __init__(self, pressure_scale_mpa: float, closure_scale_mm: float) -> None:
        self.pressure_scale_mpa = check_positive("pressure_scale_mpa", pressure_scale_mpa)
        self.closure_scale_mm = check_positive("closure_scale_mm", closure_scale_mm)

    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``c0 log(1 + p / p0)``."""
        p = np.asarray(pressure_mpa, dtype=float)
        return self.closure_scale_mm * np.log1p(p / self.pressure_scale_mpa)

    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """``p0 (exp(c / c0) - 1)`` for ``c >= 0``, zero below."""
        c = np.clip(np.asarray(closure_mm, dtype=float), 0.0, None)
        return self.pressure_scale_mpa * np.expm1(c / self.closure_scale_mm)

    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``c0 / (p0 + p)``."""
        p = np.asarray(pressure_mpa, dtype=float)
        return self.closure_scale_mm / (self.pressure_scale_mpa + p)

    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``c0 ((p0 + p) log(1 + p/p0) - p)``."""
        p = np.asarray(pressure_mpa, dtype=float)
        p0 = self.pressure_scale_mpa
        return self.closure_scale_mm * ((p0 + p) * np.log1p(p / p0) - p)

    def __repr__(self) -> str:
        return (f"ExponentialLaw(pressure_scale_mpa={self.pressure_scale_mpa:g}, "
                f"closure_scale_mm={self.closure_scale_mm:g})")


#: The widest span of closures (um) a measured law may have: a rough interface closes by a few asperity heights,
#: tens of um; a span beyond 1 mm is a unit error.
MAX_LAW_CLOSURE_UM = 1000.0


class TabularLaw(InterfaceLaw):
    """Pressure-overclosure law given by measured points.

    Parameters
    ----------
    closure_mm : array_like
        Closures (mm), strictly increasing. Closures are measured from the
        first point (which must carry zero pressure), so any offset in the
        data is removed.
    pressure_mpa : array_like
        Pressures (MPa) at those closures, strictly increasing from 0.

    Notes
    -----
    The closure is interpolated as a function of pressure with the monotone
    piecewise-cubic Hermite interpolant (PCHIP; Fritsch & Carlson 1980), so
    the law stays monotone between the points. Above the last point the law
    continues linearly with the slope of the last interval (as Abaqus does for
    tabulated laws).
    """

    @classmethod
    def from_csv(cls, path) -> "TabularLaw":
        """A measured law from a CSV file with columns ``closure_um,pressure_mpa`` (data only)."""
        import csv

        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
        try:
            closure = [float(r["closure_um"]) * 1e-3 for r in rows]
            pressure = [float(r["pressure_mpa"]) for r in rows]
        except (KeyError, TypeError, ValueError):
            raise ValueError(f"roughness_law {path}: needs numeric columns closure_um,pressure_mpa") from None
        from filmcal._validation import HARDNESS_MPA_BOUNDS

        if not np.all(np.isfinite(closure + pressure)):
            raise ValueError(f"roughness_law {path}: closure_um and pressure_mpa must be finite")
        if closure and max(closure) - min(closure) > 1e-3 * MAX_LAW_CLOSURE_UM:
            raise ValueError(f"roughness_law {path}: its closures span {1e3 * (max(closure) - min(closure)):g} um, "
                             f"more than a rough interface closes (at most {MAX_LAW_CLOSURE_UM:g} um): check the "
                             "units")
        if pressure and max(pressure) > HARDNESS_MPA_BOUNDS[1]:
            raise ValueError(f"roughness_law {path}: its pressures reach {max(pressure):g} MPa, above any steel's "
                             f"hardness (at most {HARDNESS_MPA_BOUNDS[1]:g} MPa): check the units")
        try:
            return cls(closure, pressure)
        except ValueError as exc:  # said in the file's own columns
            text = str(exc).replace("closure_mm", "closure_um")
            raise ValueError(f"roughness_law {path}: {text}") from None

    def __init__(self, closure_mm: np.ndarray, pressure_mpa: np.ndarray) -> None:
        c = np.asarray(closure_mm, dtype=float)
        p = np.asarray(pressure_mpa, dtype=float)
        if c.ndim != 1 or c.shape != p.shape or c.size < 2:
            raise ValueError("closure_mm and pressure_mpa must be 1-D arrays of the same "
                             f"length >= 2, got shapes {c.shape} and {p.shape}")
        if not (np.all(np.isfinite(c)) and np.all(np.isfinite(p))):
            raise ValueError("closure_mm and pressure_mpa must be finite")
        if p[0] != 0.0:
            raise ValueError(f"pressure_mpa must start at 0, got {p[0]:g}")
        if np.any(np.diff(c) <= 0.0) or np.any(np.diff(p) <= 0.0):
            raise ValueError("closure_mm and pressure_mpa must both be strictly increasing")
        self.closures_mm = c - c[0]
        self.pressures_mpa = p
        self._closure_of_pressure = PchipInterpolator(p, self.closures_mm, extrapolate=False)
        self._closure_integral = self._closure_of_pressure.antiderivative()
        self._last_slope = (self.closures_mm[-1] - self.closures_mm[-2]) / (p[-1] - p[-2])

    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Interpolated closure; linear continuation above the last point."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        p_last = self.pressures_mpa[-1]
        inside = self._closure_of_pressure(np.minimum(p, p_last))
        return inside + self._last_slope * np.maximum(p - p_last, 0.0)

    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`closure_mm` (bisection on the monotone interpolant)."""
        c = np.clip(np.asarray(closure_mm, dtype=float), 0.0, None)
        c_last, p_last = self.closures_mm[-1], self.pressures_mpa[-1]
        lo, hi = np.zeros(c.shape), np.full(c.shape, p_last)
        target = np.minimum(c, c_last)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            below = self._closure_of_pressure(mid) < target
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return 0.5 * (lo + hi) + np.maximum(c - c_last, 0.0) / self._last_slope

    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Slope of the interpolant (of the last interval above the last point)."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        p_last = self.pressures_mpa[-1]
        inside = self._closure_of_pressure(np.minimum(p, p_last), 1)
        return np.where(p < p_last, inside, self._last_slope)

    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Integral of the interpolant, continued with the linear extension."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        p_last, c_last = self.pressures_mpa[-1], self.closures_mm[-1]
        extra = np.maximum(p - p_last, 0.0)
        return (self._closure_integral(np.minimum(p, p_last))
                + c_last * extra + 0.5 * self._last_slope * extra ** 2)

    def __repr__(self) -> str:
        return (f"TabularLaw(<{self.pressures_mpa.size} points up to "
                f"{self.pressures_mpa[-1]:g} MPa>)")


def _gaussian_moment(order: float, h: np.ndarray) -> np.ndarray:
    """``F_n(h) = int_h^inf (s - h)**n phi(s) ds`` for the standard normal ``phi``.

    Closed form with the parabolic-cylinder function ``D_v``:
    ``F_n(h) = Gamma(n + 1) exp(-h**2 / 4) D_{-(n+1)}(h) / sqrt(2 pi)``.
    """
    d, _ = pbdv(-(order + 1.0), h)
    return gamma(order + 1.0) * np.exp(-0.25 * h * h) * d / math.sqrt(2.0 * math.pi)


class GreenwoodWilliamsonLaw(InterfaceLaw):
    """Greenwood-Williamson (1966) law of a rough surface against a smooth one.

    Identical spherical elastic asperities (radius ``beta``, density ``eta``
    per unit area) with random summit heights of standard deviation
    ``sigma``; at mean-plane separation ``d`` the nominal pressure is::

        p_GW(d) = (4/3) eta E* sqrt(beta) sigma**1.5 F_{3/2}(d / sigma)

    with ``F_{3/2}(h) = int_h^inf (s - h)**1.5 phi(s) ds`` for the
    standardised summit-height density ``phi``.

    Parameters
    ----------
    ra_um : float
        Arithmetic mean roughness Ra (um), 0.1 <= Ra <= 30 (from polished
        specimens to freshly re-profiled wheels).
    contact_modulus_mpa : float
        Contact modulus ``E*`` of the asperity contacts (MPa): the combined
        modulus of the rough body and the body it touches (for steel against
        a PET film, ``filmcal.hertz.contact_modulus_mpa(E_film, nu_film,
        210000, 0.3)``).
    heights : {"gaussian", "exponential"}
        Summit-height distribution. "exponential" gives the closed form
        ``p = p0 (exp(c / sigma) - 1)`` (Greenwood & Williamson's own
        exponential model).
    eta_sigma_beta : float
        ``eta sigma beta``, default 0.04: Greenwood & Tripp (1970, Proc. IMechE
        185:625) report 0.03-0.05 for engineering surfaces.
    sigma_over_beta : float
        ``sigma / beta``, default 1e-3, the middle (on a log scale) of the range
        1e-4-1e-2 they report.
    onset_sigma : float
        Separation, in units of ``sigma``, at which the interface starts to
        carry pressure (the highest summits), default 4. The law is shifted
        so that ``p = 0`` there: ``p(d) = p_GW(d) - p_GW(d_onset)``.
    saturation_sigma : float
        Separation, in units of ``sigma``, below which the interface is taken
        as hard (closure no longer grows), default 0: GW theory assumes a
        small real contact fraction (``pi eta sigma beta F_1(d/sigma)``, 5 %
        at ``d = 0`` with the defaults); beyond that the valleys are filled.

    Notes
    -----
    The roughness sigma is taken as ``sqrt(pi/2) Ra = 1.2533 Ra`` (exact for
    Gaussian profile heights) and the summit-height deviation as equal to it
    (Greenwood & Williamson 1966 found them close). Only the two groups
    ``eta sigma beta`` and ``sigma / beta`` enter the pressure scale
    ``(4/3) (eta sigma beta) E* sqrt(sigma / beta)``; ``Ra`` sets the closure
    scale. Closures are measured from the onset separation.
    """

    def __init__(self, ra_um: float, contact_modulus_mpa: float, *,
                 heights: str = "gaussian", eta_sigma_beta: float = 0.04,
                 sigma_over_beta: float = 1e-3, onset_sigma: float = 4.0,
                 saturation_sigma: float = 0.0) -> None:
        self.ra_um = check_range("ra_um", ra_um, 0.1, 30.0, low_open=False, high_open=False)
        self.contact_modulus_mpa = check_positive("contact_modulus_mpa", contact_modulus_mpa)
        self.heights = check_choice("heights", heights, ("gaussian", "exponential"))
        self.eta_sigma_beta = check_range("eta_sigma_beta", eta_sigma_beta, 0.0, 1.0)
        self.sigma_over_beta = check_range("sigma_over_beta", sigma_over_beta, 0.0, 1.0)
        self.onset_sigma = check_range("onset_sigma", onset_sigma, 0.0, 10.0, high_open=False)
        low = -10.0 if self.heights == "gaussian" else 0.0
        self.saturation_sigma = check_range("saturation_sigma", saturation_sigma, low,
                                            self.onset_sigma, low_open=False)
        self.sigma_mm = math.sqrt(0.5 * math.pi) * self.ra_um * 1e-3
        self._h = np.linspace(self.saturation_sigma, self.onset_sigma, 801)
        self._p_table = self._nominal_pressure(self._h) - self._nominal_pressure(
            np.array([self.onset_sigma]))[0]
        self._c_table = self.sigma_mm * (self.onset_sigma - self._h)
        # increasing pressure order for the interpolants
        self._closure_of_pressure = PchipInterpolator(self._p_table[::-1], self._c_table[::-1])
        self._closure_integral = self._closure_of_pressure.antiderivative()

    @property
    def pressure_scale_mpa(self) -> float:
        """``(4/3) eta E* sqrt(beta) sigma**1.5`` (MPa)."""
        return (4.0 / 3.0) * self.eta_sigma_beta * self.contact_modulus_mpa \
            * math.sqrt(self.sigma_over_beta)

    @property
    def saturation_pressure_mpa(self) -> float:
        """Pressure above which the interface is hard."""
        return float(self._p_table[0])

    @property
    def saturation_closure_mm(self) -> float:
        """Largest closure, ``sigma (onset - saturation)``."""
        return float(self._c_table[0])

    def _nominal_pressure(self, h: np.ndarray) -> np.ndarray:
        """Greenwood-Williamson nominal pressure at separations ``h sigma``."""
        if self.heights == "gaussian":
            moment = _gaussian_moment(1.5, h)
        else:  # exponential heights on [0, inf): F_{3/2}(h) = Gamma(5/2) exp(-h)
            moment = gamma(2.5) * np.exp(-h)
        return self.pressure_scale_mpa * moment

    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Closure from the onset separation; constant above saturation."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, self.saturation_pressure_mpa)
        return self._closure_of_pressure(p)

    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """Pressure at a closure (exact GW law); unbounded past saturation."""
        c = np.clip(np.asarray(closure_mm, dtype=float), 0.0, None)
        h = self.onset_sigma - np.minimum(c, self.saturation_closure_mm) / self.sigma_mm
        p = self._nominal_pressure(h) - self._nominal_pressure(np.array([self.onset_sigma]))[0]
        return np.where(c > self.saturation_closure_mm, np.inf, p)

    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Slope of the interpolated law; zero above saturation (hard)."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        p_sat = self.saturation_pressure_mpa
        return np.where(p < p_sat, self._closure_of_pressure(np.minimum(p, p_sat), 1), 0.0)

    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Integral of the interpolated law, continued at constant closure."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        p_sat = self.saturation_pressure_mpa
        return (self._closure_integral(np.minimum(p, p_sat))
                + self.saturation_closure_mm * np.maximum(p - p_sat, 0.0))

    @property
    def initial_compliance_mm_per_mpa(self) -> float:
        """``dc/dp = sigma / |dp_GW/dh|`` at the onset (``dF_n/dh = -n F_{n-1}``)."""
        h = np.array([self.onset_sigma])
        if self.heights == "gaussian":
            slope = 1.5 * _gaussian_moment(0.5, h)[0]
        else:
            slope = gamma(2.5) * math.exp(-self.onset_sigma)
        return self.sigma_mm / (self.pressure_scale_mpa * slope)

    def __repr__(self) -> str:
        return (f"GreenwoodWilliamsonLaw(ra_um={self.ra_um:g}, contact_modulus_mpa="
                f"{self.contact_modulus_mpa:g}, heights={self.heights!r})")


class LargeStrainFilm(InterfaceLaw):
    """The film under large strain: the oedometric law of a compressible neo-Hookean film.

    The film of the FE model's ``large_strain`` option
    (:mod:`filmcal.fem.largestrain`) has the strain energy
    ``W = mu/2 (tr C - 3) - mu ln J + lam/2 (ln J)**2``. Compressed by a
    pressure ``p`` while held laterally (lateral stretch 1, the oedometric
    state of a thin film in a contact), its stretch ``lambda = J = exp(-s)``
    obeys (nominal = true stress, the area does not change)::

        p = mu (1/lambda - lambda) - lam ln(lambda) / lambda
          = 2 mu sinh(s) + lam s exp(s)

    and the film closes by ``c = t (1 - lambda)``. At small strain
    ``p = (lam + 2 mu) c / t = M c / t``, the linear :class:`FilmLayer`; at
    large strain the film stiffens (``c < t`` at any pressure), so a soft
    film compressed by 50-70 % is not extrapolated linearly.

    Parameters
    ----------
    modulus_mpa : float
        Young's modulus at small strain (MPa), > 0.
    poisson : float
        Poisson's ratio at small strain, -1 < nu < 0.5.
    thickness_mm : float
        Film thickness (mm), > 0.

    Notes
    -----
    Pass it to the solvers as the interface law (``law=`` of
    :func:`filmcal.wheelrail.halfspace.sphere_on_flat_contact`, ``roughness=``
    of the wheel-rail model) with no linear film, or in a :class:`SeriesLaw`
    with a rough interface. ``int_0^p c dq = p c - t W(lambda)`` exactly.
    """

    kinematics = "large"

    def __init__(self, modulus_mpa: float, poisson: float = 0.33,
                 thickness_mm: float = 0.09) -> None:
        self.modulus_mpa = check_positive("modulus_mpa", modulus_mpa)
        self.poisson = check_poisson("poisson", poisson)
        self.thickness_mm = check_positive("thickness_mm", thickness_mm)
        e, nu = self.modulus_mpa, self.poisson
        self._lam = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
        self._mu = e / (2.0 * (1.0 + nu))
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # the last (pressure, s) of log_compression

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_last": None}  # the cache stays in its process

    @classmethod
    def from_film(cls, film: FilmLayer) -> "LargeStrainFilm":
        """The large-strain counterpart of a linear film."""
        return cls(film.modulus_mpa, film.poisson, film.thickness_mm)

    @property
    def oedometric_modulus_mpa(self) -> float:
        """Small-strain constrained modulus ``M = lam + 2 mu`` (MPa)."""
        return self._lam + 2.0 * self._mu

    @property
    def compliance_mm_per_mpa(self) -> float:
        """Small-strain closure per unit pressure, ``t / M`` (mm/MPa)."""
        return self.thickness_mm / self.oedometric_modulus_mpa

    def _pressure_of_log(self, s: np.ndarray) -> np.ndarray:
        return 2.0 * self._mu * np.sinh(s) + self._lam * s * np.exp(s)

    def _slope_of_log(self, s: np.ndarray) -> np.ndarray:
        return 2.0 * self._mu * np.cosh(s) + self._lam * (1.0 + s) * np.exp(s)

    def log_compression(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``s = -ln(lambda)`` at pressures ``p >= 0`` (Newton from an upper bound).

        Two upper bounds of the root: ``p / M`` (``p(s) >= M s``, convex) and ``ln(1 + p / mu)``
        (``p(s) >= mu (e^s - 1)``); Newton from the smaller falls monotonically onto the root, and the second
        keeps ``sinh`` and ``exp`` finite for pressures far beyond the film's modulus.
        """
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        last = self._last
        if last is not None and last[0].shape == p.shape and np.array_equal(last[0], p):
            return last[1].copy()  # a solver asks for the closure, its slope and its integral at one pressure
        if p.ndim:  # Newton on the loaded cells only (s = 0 where p = 0; a contact grid is mostly unloaded)
            s = np.zeros_like(p)
            loaded = ~(p <= 0.0)  # NaN stays in, and comes back NaN
            s[loaded] = self._newton_log(p[loaded])
            self._last = (p, s.copy())
            return s
        return self._newton_log(p)

    def _newton_log(self, p: np.ndarray) -> np.ndarray:
        s = np.minimum(p / self.oedometric_modulus_mpa, np.log1p(p / self._mu))
        two_mu, lam = 2.0 * self._mu, self._lam
        for _ in range(100):
            # p(s) and p'(s) from one expm1: sinh s = m (2 + m) / (2 (1 + m)) with m = e^s - 1 (no cancellation
            # at small s), cosh s = sinh s + e^-s
            m = np.expm1(s)
            e = 1.0 + m
            sinh = m * (2.0 + m) / (2.0 * e)
            step = (two_mu * sinh + lam * s * e - p) / (two_mu * (sinh + 1.0 / e) + lam * (1.0 + s) * e)
            s = np.maximum(s - step, 0.0)
            if np.all(np.abs(step) <= 1e-14 * (1.0 + s)):
                break
        return s

    def strain(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Compressive engineering strain ``1 - lambda`` of the film."""
        return -np.expm1(-self.log_compression(pressure_mpa))

    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``t (1 - lambda(p))``."""
        return self.thickness_mm * self.strain(pressure_mpa)

    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """Pressure at a closure; unbounded as the closure approaches ``t``."""
        c = np.clip(np.asarray(closure_mm, dtype=float), 0.0, None)
        lam = 1.0 - c / self.thickness_mm
        with np.errstate(divide="ignore", invalid="ignore"):
            s = -np.log(np.where(lam > 0.0, lam, 1.0))
        return np.where(lam > 0.0, self._pressure_of_log(s), np.inf)

    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``dc/dp = t exp(-s) / (dp/ds)``."""
        s = self.log_compression(pressure_mpa)
        return self.thickness_mm * np.exp(-s) / self._slope_of_log(s)

    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """``p c - t W(lambda)``, ``W = mu/2 (lambda**2 - 1) + mu s + lam s**2/2``."""
        p = np.clip(np.asarray(pressure_mpa, dtype=float), 0.0, None)
        s = self.log_compression(p)
        c = -self.thickness_mm * np.expm1(-s)
        w = 0.5 * self._mu * np.expm1(-2.0 * s) + self._mu * s + 0.5 * self._lam * s * s
        return np.clip(p * c - self.thickness_mm * w, 0.0, None)

    def __repr__(self) -> str:
        return (f"LargeStrainFilm(modulus_mpa={self.modulus_mpa:g}, poisson={self.poisson:g}, "
                f"thickness_mm={self.thickness_mm:g})")


class SeriesLaw(InterfaceLaw):
    """Interface laws in series: one pressure, the closures add.

    Parameters
    ----------
    *laws : InterfaceLaw
        At least one law; hard laws add nothing.
    """

    def __init__(self, *laws: InterfaceLaw) -> None:
        if not laws or not all(isinstance(law, InterfaceLaw) for law in laws):
            raise ValueError(f"laws must be one or more InterfaceLaw objects, got {laws!r}")
        self.laws = tuple(law for law in laws if not law.is_hard) or (HardLaw(),)
        self.is_hard = all(law.is_hard for law in self.laws)

    def closure_mm(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Sum of the closures."""
        return sum(law.closure_mm(pressure_mpa) for law in self.laws)

    def tangent_compliance_mm_per_mpa(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Sum of the slopes."""
        return sum(law.tangent_compliance_mm_per_mpa(pressure_mpa) for law in self.laws)

    def closure_integral(self, pressure_mpa: np.ndarray) -> np.ndarray:
        """Sum of the integrals."""
        return sum(law.closure_integral(pressure_mpa) for law in self.laws)

    def pressure_mpa(self, closure_mm: np.ndarray) -> np.ndarray:
        """Inverse of the summed closure (bisection on the pressure)."""
        c = np.clip(np.asarray(closure_mm, dtype=float), 0.0, None)
        if self.is_hard:
            return np.where(c > 0.0, np.inf, 0.0)
        lo, hi = np.zeros(c.shape), np.ones(c.shape)
        for _ in range(200):
            short = self.closure_mm(hi) < c
            if not np.any(short) or np.all(hi[short] > 1e12):
                break
            hi = np.where(short, 2.0 * hi, hi)
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            below = self.closure_mm(mid) < c
            lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
        return 0.5 * (lo + hi)

    def __repr__(self) -> str:
        return "SeriesLaw(" + ", ".join(repr(law) for law in self.laws) + ")"


def through_film(film: FilmLayer | None, law: InterfaceLaw | None) -> bool:
    """Whether a solver's interface ``(film, law)`` holds a film: a linear `FilmLayer`, or a
    `LargeStrainFilm` law alone or in series (what `film_law` hands a large-strain film as)."""
    if film is not None:
        return True
    laws = law.laws if isinstance(law, SeriesLaw) else (law,)
    return any(isinstance(one, LargeStrainFilm) for one in laws)


def film_law(film: FilmLayer | None, roughness: InterfaceLaw | None, *,
             kinematics: str = "small") -> tuple[FilmLayer | None, InterfaceLaw | None]:
    """The ``(film, law)`` pair to hand to the contact solvers.

    A linear film stays a :class:`FilmLayer` (springs ``t/M``); a
    large-strain film becomes a :class:`LargeStrainFilm` law, in series with
    the roughness law when there is one.
    """
    if kinematics not in ("small", "large"):
        raise ValueError(f"kinematics must be small or large, got {kinematics!r}")
    if film is None or kinematics == "small":
        return film, roughness
    large = LargeStrainFilm.from_film(film)
    return None, (large if roughness is None or roughness.is_hard else SeriesLaw(large, roughness))
