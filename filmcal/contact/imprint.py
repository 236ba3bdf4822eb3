"""What the film records: imprint models, one definition for every model.

An imprint model says which part of a contact a pressure film colours. The
same model object reads an axisymmetric nodal pressure profile (the FE
sphere-on-flat model, :meth:`ImprintModel.radius_mm`) and a cell-centred 2D
field (the wheel-rail half-space model, :meth:`ImprintModel.area_mm2`), so
that calibration and correction use one definition.

``edge``
    The film records the whole contact: the region of positive pressure,
    read at the zero-pressure edge (:mod:`filmcal.contact.reading`).
``activation``
    The film colours where the pressure exceeds its activation pressure
    (``FilmType.activation_pressure_mpa``: MS 10, HS 50, HHS 130 MPa): the
    contour ``p = p_act``.
``capsule``
    The dye capsules of a film break at different pressures. Their burst
    strengths are taken as log-normally distributed over the film's
    measurement range ``FilmType.range_mpa = (lo, hi)``: the range's ends are
    the 2 % and 98 % quantiles (:data:`CAPSULE_RANGE_QUANTILE`), i.e. the
    colour is just visible at the lower end and saturated at the upper end
    of the range, as the manufacturer's range states. A point at pressure
    ``p`` is coloured with probability ``P(p)``, the fraction of capsules
    weaker than ``p``; the imprint is the *expected coloured area*
    ``int P(p) dA`` (what a densitometric reading of the imprint measures),
    and its radius is ``sqrt(area / pi)``. A film without a range is refused.

Examples
--------
>>> from filmcal.films import get_film
>>> model = get_imprint_model("activation")
>>> float(model.stain_probability(np.array([40.0, 60.0]), get_film("HS"))[1])
1.0
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Sequence

import numpy as np

from filmcal.contact.names import DEFAULT_IMPRINT_MODEL, IMPRINT_MODELS
from filmcal.contact.reading import FILM_CONTOUR_POWER, GridField, RadialProfile, read_radial_profile

if TYPE_CHECKING:  # pragma: no cover
    from filmcal.films import FilmType

__all__ = ["IMPRINT_MODELS", "DEFAULT_IMPRINT_MODEL", "imprint_models_for", "CAPSULE_RANGE_QUANTILE", "ImprintModel",
           "EdgeImprint", "ActivationImprint", "CapsuleImprint", "get_imprint_model", "imprint_key",
           "read_imprints"]

#: Quantile of the capsule burst strengths at the lower end of the film's range
#: (its complement at the upper end).
CAPSULE_RANGE_QUANTILE = 0.02


def _pressure(p) -> np.ndarray:
    arr = np.asarray(p, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise ValueError("pressure_mpa must be finite")
    return arr


class ImprintModel:
    """Base of the imprint models (see the module notes)."""

    name: str = ""

    def stain_probability(self, pressure_mpa: np.ndarray, film: "FilmType | None" = None) -> np.ndarray:
        """Probability in [0, 1] that the film is coloured at a point at this pressure."""
        raise NotImplementedError

    def check_film(self, film: "FilmType | None") -> None:
        """Raise a ValueError when this model cannot read `film`."""

    def radius_from_profile(self, profile: RadialProfile, film: "FilmType | None" = None) -> float:
        """Imprint radius (mm) of an already read axisymmetric profile."""
        raise NotImplementedError

    def area_from_field(self, field: GridField, film: "FilmType | None" = None) -> float:
        """Imprint area (mm^2) of an already wrapped 2D field."""
        raise NotImplementedError

    def radius_mm(self, r_mm: np.ndarray, pressure_mpa: np.ndarray, film: "FilmType | None" = None,
                  *, tip_mm: float = math.inf, samples: str = "nodal") -> float:
        """Imprint radius of an axisymmetric nodal pressure profile (mm).

        Parameters
        ----------
        r_mm : ndarray
            Node radii, ascending from the axis.
        pressure_mpa : ndarray
            Nodal pressures (nodal force over tributary area).
        film : FilmType, optional
            The film type (needed by ``activation`` and ``capsule``).
        tip_mm : float
            Tip length of the contact edge
            (:func:`filmcal.contact.reading.film_tip_length_mm`); inf for no film.
        samples : {'nodal', 'point'}
            Nodal pressures of linear elements (FE), or point values (grid cells).
        """
        self.check_film(film)
        profile = read_radial_profile(r_mm, _pressure(pressure_mpa), tip_mm, samples=samples)
        return self.radius_from_profile(profile, film)

    def area_mm2(self, x_mm: np.ndarray, y_mm: np.ndarray, pressure_mpa_2d: np.ndarray,
                 film: "FilmType | None" = None, through_film: bool = True) -> float:
        """Imprint area of a cell-centred 2D pressure field on a regular grid (mm^2).

        Parameters
        ----------
        x_mm, y_mm : ndarray
            Cell centres along the grid axes (``ContactResult.grid.x_mm``, ``.y_mm``).
        pressure_mpa_2d : ndarray, shape (len(x_mm), len(y_mm))
            Cell pressures (``ContactResult.pressure_mpa``).
        film : FilmType, optional
        through_film : bool
            Whether the contact was solved with a film between the bodies (its
            pressure rises linearly from the edge, `GridField`); False for a
            contact without film.
        """
        self.check_film(film)
        power = FILM_CONTOUR_POWER if through_film else 2
        return self.area_from_field(GridField(x_mm, y_mm, _pressure(pressure_mpa_2d), power), film)


@dataclass(frozen=True)
class EdgeImprint(ImprintModel):
    """The whole contact: positive pressure, read at the zero-pressure edge."""

    name: str = "edge"

    def stain_probability(self, pressure_mpa, film=None) -> np.ndarray:
        return (_pressure(pressure_mpa) > 0).astype(float)

    def radius_from_profile(self, profile, film=None) -> float:
        return float(profile.edge_mm)

    def area_from_field(self, field, film=None) -> float:
        return field.level_area_mm2(0.0)[0]


def _activation(film: "FilmType | None", model: str) -> float:
    if film is None:
        raise ValueError(f"the {model} imprint model needs a film type (--film)")
    if film.activation_pressure_mpa is None:
        raise ValueError(f"film {film.name} has no activation_pressure_mpa (nor range_mpa): "
                         f"the {model} imprint model cannot read it; use the edge model or give "
                         "the film an activation pressure")
    return float(film.activation_pressure_mpa)


@dataclass(frozen=True)
class ActivationImprint(ImprintModel):
    """The contour where the pressure equals the film's activation pressure."""

    name: str = "activation"

    def check_film(self, film) -> None:
        _activation(film, self.name)

    def stain_probability(self, pressure_mpa, film=None) -> np.ndarray:
        return (_pressure(pressure_mpa) >= _activation(film, self.name)).astype(float)

    def radius_from_profile(self, profile, film=None) -> float:
        return float(profile.level_radius_mm(_activation(film, self.name)))

    def area_from_field(self, field, film=None) -> float:
        return field.level_area_mm2(_activation(film, self.name))[0]


@dataclass(frozen=True)
class CapsuleImprint(ImprintModel):
    """Expected coloured area with log-normal capsule burst strengths over the film's range.

    Parameters
    ----------
    range_quantile : float
        Fraction of capsules weaker than the lower end of the range (and
        stronger than the upper end), in (0, 0.5).
    """

    name: str = "capsule"
    range_quantile: float = CAPSULE_RANGE_QUANTILE

    def __post_init__(self) -> None:
        q = float(self.range_quantile)
        if not (0.0 < q < 0.5):
            raise ValueError(f"range_quantile must lie in (0, 0.5), got {q:g}")

    def check_film(self, film) -> None:
        self._lognormal(film)

    def _lognormal(self, film) -> tuple[float, float]:
        if film is None:
            raise ValueError("the capsule imprint model needs a film type (--film)")
        if film.range_mpa is None:
            raise ValueError(f"film {film.name} has no range_mpa: the capsule imprint model spreads "
                             "capsule strengths over the measurement range; give the film a range")
        from scipy.special import ndtri  # the standard normal quantile (scipy.stats would take 0.5 s to import)

        lo, hi = film.range_mpa
        z = float(ndtri(1.0 - self.range_quantile))
        return 0.5 * math.log(lo * hi), math.log(hi / lo) / (2.0 * z)

    def stain_probability(self, pressure_mpa, film=None) -> np.ndarray:
        from scipy.special import ndtr  # the standard normal distribution function

        mu, sigma = self._lognormal(film)
        p = _pressure(pressure_mpa)
        with np.errstate(divide="ignore"):
            z = (np.log(np.where(p > 0, p, 1.0)) - mu) / sigma
        return np.where(p > 0, ndtr(z), 0.0)

    def radius_from_profile(self, profile, film=None) -> float:
        area = profile.integral_mm2(lambda p: self.stain_probability(p, film))
        return math.sqrt(max(area, 0.0) / math.pi)

    def area_from_field(self, field, film=None) -> float:
        return field.integral_mm2(lambda p: self.stain_probability(p, film))


_MODELS = {"edge": EdgeImprint, "activation": ActivationImprint, "capsule": CapsuleImprint}


def get_imprint_model(name: str) -> ImprintModel:
    """The imprint model called `name` (one of :data:`IMPRINT_MODELS`)."""
    if name not in _MODELS:
        raise ValueError(f"imprint model must be one of {', '.join(IMPRINT_MODELS)}, got {name!r}")
    return _MODELS[name]()


def imprint_key(model: str, film: "FilmType | str") -> str:
    """Output name of an imprint radius: ``radius_<model>_<film>_mm`` (``contact_radius_mm`` for edge)."""
    if model not in _MODELS:
        raise ValueError(f"imprint model must be one of {', '.join(IMPRINT_MODELS)}, got {model!r}")
    if model == "edge":
        return "contact_radius_mm"
    name = film if isinstance(film, str) else film.name
    return f"radius_{model}_{name}_mm"


def read_imprints(r_mm: np.ndarray, pressure_mpa: np.ndarray, pairs: Sequence[tuple[str, "FilmType"]],
                  *, tip_mm: float = math.inf) -> dict[str, float]:
    """Imprint radii of several (model, film) pairs from one reading of a profile."""
    profile = read_radial_profile(r_mm, _pressure(pressure_mpa), tip_mm)
    out = {}
    for model, film in pairs:
        m = get_imprint_model(model)
        m.check_film(film)
        out[imprint_key(model, film)] = m.radius_from_profile(profile, film)
    return out


def imprint_models_for(film: "FilmType | None") -> tuple[str, ...]:
    """The imprint models that can read `film`, in the comparison's order.

    ``edge`` reads any film; ``activation`` needs its activation pressure, ``capsule`` its range.
    """
    out = []
    for name in IMPRINT_MODELS:
        try:
            get_imprint_model(name).check_film(film)
        except ValueError:
            continue
        out.append(name)
    return tuple(out)
