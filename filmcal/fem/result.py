"""The result of one FE evaluation and its readings: the contact edge and the imprint."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from filmcal.contact import RadialProfile, get_imprint_model, read_radial_profile

__all__ = ["FEResult", "SMALL_STRAIN_LIMIT"]

#: The film's through-thickness compression beyond which the small-strain (linear) film is no model of it: half
#: its thickness. Below it the linear film is an effective model whose modulus the calibration fits (at HS's 20 %
#: the two kinematics differ by 0.09 mm in radius, absorbed in E); beyond it solve with ``kinematics="large"``.
SMALL_STRAIN_LIMIT = 0.5


@dataclass
class FEResult:
    """The outcome of one evaluation of the sphere-on-flat FE model.

    Lengths in mm, forces in N, pressures in MPa. ``converged = False`` comes
    with a ``reason``; its numbers are then not to be used.

    ``contact_radius_mm`` is the contact edge read from the loads at which
    the last closed node opens and the first open node closes
    (:mod:`filmcal.fem.model`, "Reading the edge"); the pressure profile
    between the nodes (:meth:`profile`, tip length ``edge_tip_mm``) ends
    there. ``imprint_radius_mm`` and ``imprint_area_mm2``
    are the imprint of film type ``film`` under ``imprint_model``
    (None when no film type was asked for); :meth:`read_imprint` reads any
    other (model, film type) pair from the same solution.

    ``pressure_mpa`` holds the nodal pressures, each node's contact force over
    its consistent area, and ``max_pressure_mpa`` their largest. With a film,
    the node on the axis reads too high at any mesh: the film's volumetric term
    is integrated at one point per element (:mod:`filmcal.fem.forms`), which in
    the element on the axis gives its two face nodes equal shares of that
    term's force where the consistent shares are 1/3 and 2/3, so that the axis
    node carries ``nu / (2 (1 - nu))`` more than its pressure (24 % at nu 0.33,
    41 % at 0.45) and its neighbour a little less. The contact's total force,
    its edge and the imprints are read away from the axis and are not affected.
    :attr:`pressure_profile_mpa` and :attr:`peak_pressure_mpa` read those two
    nodes from the profile beyond them, as a second formulation without the
    one-point rule gives them (`tests/test_fem_film.py`).
    """

    sphere_radius_mm: float
    force_n: float
    film_modulus_mpa: float | None
    film_poisson: float | None
    sphere_contact: str
    flat_contact: str
    friction_coefficient: float
    kinematics: str
    contact_radius_mm: float
    contact_area_mm2: float
    max_pressure_mpa: float
    hertz_radius_mm: float
    approach_mm: float
    film_strain_max: float
    r_mm: np.ndarray
    pressure_mpa: np.ndarray
    gap_mm: np.ndarray
    film_strain: np.ndarray
    n_active: int
    imprint_radius_mm: float | None
    imprint_area_mm2: float | None
    activation_pressure_mpa: float | None
    imprint_model: str | None
    film: str | None
    edge_tip_mm: float
    converged: bool
    reason: str
    iterations: int
    elapsed_s: float
    n_dofs: int
    element_size_mm: float

    @property
    def radius_error_mm(self) -> float:
        """Contact radius minus the Hertz radius (the film's enlargement)."""
        return self.contact_radius_mm - self.hertz_radius_mm

    @property
    def hertz_area_mm2(self) -> float:
        return float(np.pi * self.hertz_radius_mm**2)

    @property
    def pressure_profile_mpa(self) -> np.ndarray:
        """The nodal pressures (MPa), with a film's two nodes nearest the axis read from the third and fourth.

        Near the axis the pressure is even in r, ``p = a + b r^2``; through the third and fourth nodes (outside the
        element on the axis, whose one-point volumetric rule loads its nodes unevenly: see the class notes) that
        gives the first two. Without a film, or with fewer than four loaded nodes, the nodal pressures as solved.
        """
        p = np.array(self.pressure_mpa, dtype=float)
        r = np.asarray(self.r_mm, dtype=float)
        if self.film_modulus_mpa is None or p.size < 4 or not np.all(p[:4] > 0.0) or r[0] != 0.0:
            return p
        r2, r3 = r[2] ** 2, r[3] ** 2
        b = (p[3] - p[2]) / (r3 - r2)
        p[:2] = p[2] + b * (r[:2] ** 2 - r2)
        return p

    @property
    def peak_pressure_mpa(self) -> float:
        """The largest pressure of :attr:`pressure_profile_mpa` (MPa): the contact's peak, read free of the axis
        node's share (class notes); ``max_pressure_mpa`` without a film."""
        return float(np.max(self.pressure_profile_mpa))

    def profile(self) -> RadialProfile:
        """The continuous reading of the nodal pressure profile (edge, levels, integrals).

        Read once and kept (an attribute, not a field: it is not part of the summary).
        """
        cached = self.__dict__.get("_profile")
        if cached is None or cached.r_mm is not self.r_mm or cached.pressure_mpa is not self.pressure_mpa:
            edge = self.contact_radius_mm if self.contact_radius_mm > 0 else None
            cached = read_radial_profile(self.r_mm, self.pressure_mpa, self.edge_tip_mm, edge_mm=edge)
            self.__dict__["_profile"] = cached
        return cached

    def validity_warnings(self) -> list[str]:
        """Why this solution lies outside its model's validity, one sentence each (empty when it does not):
        a small-strain film compressed beyond `SMALL_STRAIN_LIMIT`, a peak pressure beyond the steel's
        elastic limit (`filmcal.hertz.ELASTIC_LIMIT_MPA`)."""
        from filmcal.hertz import ELASTIC_LIMIT_MPA

        out = []
        if self.kinematics == "small" and self.film_strain_max >= 1.0:  # more than its thickness: no film left
            out.append(f"the small-strain film collapses (compressed by more than its thickness), far beyond the "
                       f"{100 * SMALL_STRAIN_LIMIT:g} % it models: solve it with --kinematics large")
        elif self.kinematics == "small" and self.film_strain_max > SMALL_STRAIN_LIMIT:
            out.append(f"the film is compressed by {100 * self.film_strain_max:.1f} %, beyond the small-strain film's "
                       f"{100 * SMALL_STRAIN_LIMIT:g} %: solve it with --kinematics large")
        if self.peak_pressure_mpa > ELASTIC_LIMIT_MPA:
            out.append(f"the peak pressure {self.peak_pressure_mpa:.0f} MPa exceeds the steel's elastic limit "
                       f"({ELASTIC_LIMIT_MPA:.0f} MPa): the bodies would yield, and the elastic model does not hold")
        return out

    def read_imprint(self, model: str, film_type) -> float:
        """Imprint radius (mm) of `film_type` (a :class:`filmcal.films.FilmType`) under imprint `model`."""
        return get_imprint_model(model).radius_from_profile(self.profile(), film_type)

    def summary(self) -> dict:
        """The scalar fields as a JSON-ready dict (no arrays)."""
        d = {k: v for k, v in asdict(self).items() if not isinstance(v, np.ndarray)}
        if math.isinf(d["edge_tip_mm"]):
            d["edge_tip_mm"] = None  # no film: a Hertzian edge (JSON has no infinity)
        d["radius_error_mm"] = self.radius_error_mm
        d["hertz_area_mm2"] = self.hertz_area_mm2
        d["peak_pressure_mpa"] = self.peak_pressure_mpa
        return d
