"""Wheel-rail normal contact with and without film: placement, contact plane, gap, solution.

The wheel (S1002) stands on the inclined rail (60E2 or 60E1) at the lateral
offset eta (:func:`filmcal.wheelrail.placement.place_wheel_on_rail`) and is
pressed down by the vertical wheel load ``F``; it may only move vertically,
as in the finite-element model of the film-calibration paper (section 2.2).
The contact is solved as the normal contact of two elastic half-spaces
(:class:`filmcal.wheelrail.halfspace.HalfSpaceContactSolver`), with the film
as springs in series and optionally a rough film-wheel interface.

Contact plane
-------------
A half-space problem lives in one plane. The contact is solved in the plane
tangent to the rail at the first contact point, inclined by the contact
angle ``theta`` (the mean angle when several contact points load together:
two-point contact at the gauge corner); its coordinates are ``x`` along the
rail and ``s`` along the inclined tangent, and the gap is measured along
the plane normal ``n``:

* each profile, placed in the track frame, is sampled every 5 um and
  rotated into ``(s, n)``; ``n_rail(s)`` and ``n_wheel(s)`` are interpolated
  along the part where ``s`` increases monotonically;
* the wheel is a body of revolution: its profile point of rolling radius
  ``r`` rises by ``dz = r - sqrt(r**2 - x**2)`` at ``x`` along the rail,
  which moves it by ``dz sin(theta)`` in ``s`` and ``dz cos(theta)`` in ``n``
  (solved by fixed-point iteration), so
  ``g(x, s) = n_wheel(x, s) - n_rail(s)``; for ``theta = 0`` this is the
  placement's vertical gap ``separation(y) + r - sqrt(r**2 - x**2)``;
* the normal force is ``F / cos(theta)`` (frictionless contact, the lateral
  component taken by the wheel's guidance);
* the wheel is lowered vertically, so its approach ``delta`` along the
  plane normal comes with a slide ``delta tan(theta)`` along the plane: the
  gap is that of the slid wheel, ``n_wheel(x, s + delta tan(theta)) -
  n_rail(s)``, first with the slide of the estimated approach, then again
  with the slide of its own approach until the slide moves by less than
  2 % of a cell (one solve on a tread, two or three on a flange). Where the patch straddles a curvature jump
  of a profile (S1002's straight flange face and its R20 arc, 60E1 at
  eta +5 mm) the slide moves it onto the other section: CONTACT, which
  lowers the wheelset vertically too, agrees within 1 % in area and peak
  pressure over eta +3..+8 mm (``tests/test_wheelrail_contact_reference.py``),
  where pressing the wheel in along the normal was 2.8 % and 6.1 % off.

A patch narrower than twice the solver's ``min_cells_across`` cells in a
direction (through a film: `FILM_MIN_CELLS_ACROSS`, 80) is solved again on a
grid refined in that direction (down to an eighth of ``grid_mm``): a flange
patch is read on 20 cells or more across, 80 through a film.

Region
------
Inside the contact ``g + u + c = delta`` with a non-negative elastic closure
``u`` and interface closure ``c``, so the contact lies within ``g <= delta``.
The grid covers that set for an estimate of the approach ``delta`` (local
Hertz at the first contact point, plus the film and roughness closures at
the Hertz peak pressure); when the solved approach exceeds the estimate, or
the contact reaches the grid edge, the region is enlarged and the case
solved again. So every contact point that the load brings into contact --
a second patch at the gauge corner, a patch spread over a profile joint --
is covered, whatever its shape. Grid sizes are rounded up (x: to an odd
count in steps of 8, s: in steps of 8) so that neighbouring cases share the
cached influence-coefficient spectra of the solver. A larger region starts
from the previous attempt's pressure (interpolated onto its grid) instead of
from scratch.


Sweeps
------
``WheelRailModel.solve(..., initial=neighbour)`` starts from a neighbouring
solution (another offset, load, film modulus or roughness), its pressure
mapped by plane coordinates; ``solve_many`` does so along its list by
default. The answers equal cold starts to the solver tolerance; a modulus
sweep saves about a fifth of the iterations.

Area
----
``area_mm2`` is the area where the pressure is positive: the solver's sub-
cell outline (`filmcal.wheelrail.halfspace`, "Contact area"), with or without
a film. With a film this is the zero-pressure edge of the film springs, which
lies 0.01-0.04 mm outside the continuum film's edge that the calibration ran
(the springs have no lateral coupling); that difference is not hidden in the
reading but carried as the transfer term of `filmcal.contact.transfer`
(`FilmModel.transfer_term`), with its spread, in every correction.
"""
from __future__ import annotations

import math
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Iterable, Mapping

import numpy as np
from scipy import ndimage

from filmcal.wheelrail.settings import (FILM_MIN_CELLS_ACROSS, GRID_MM, GRID_MM_RANGE, NOMINAL_RADIUS_MM, RAIL,
                                        RAIL_INCLINATION, WHEEL)
from filmcal._validation import as_finite, check_positive, check_range
from filmcal.wheelrail.patches import patch_ring_areas_mm2
from filmcal.wheelrail.halfspace import ContactResult, HalfSpaceContactSolver, SurfaceGrid
from filmcal.wheelrail.hertz import HertzContact, hertz_elliptic
from filmcal.contact.laws import FilmLayer, InterfaceLaw, through_film
from filmcal.wheelrail.placement import ContactPoint, WheelRailPlacement, place_wheel_on_rail
from filmcal.wheelrail.profiles import Profile, get_profile

__all__ = [
    "ContactPlane", "ContactRegion", "ContactPatch", "WheelRailCase", "WheelRailResult",
    "WheelRailGeometry", "WheelRailModel", "get_wheel_rail_model", "local_hertz",
    "solve_wheel_rail", "solve_wheel_rail_many",
]

_SAMPLE_STEP_MM = 0.005
_CANDIDATE_TOLERANCE_MM = 1.0
_MARGIN_CELLS = 3
#: The largest contact grid (cells; 800 x 800): its FFT convolution arrays stay within a few hundred MB. A long,
#: narrow flange patch at a fine grid (1009 x 96 cells at 0.025 mm) is well inside it.
_MAX_CELLS = 640_000
_MAX_ATTEMPTS = 6
_MAX_REFINEMENTS = 3
#: Solves with the wheel's slide along an inclined contact plane updated (vertical approach; module notes).
_MAX_SLIDES = 8
#: The slide is converged when it moves by less than this share of a cell across the rail (0.002 mm at 0.1 mm:
#: 0.06 % in area at the S1002 flange joint, where the whole slide of 0.14 mm moves the area by 4 %; over 40 tread
#: and flange cases at most 0.03 %; `WheelRailModel`'s ``slide_tol_cells``).
SLIDE_TOL_CELLS = 0.02
_MAX_REFINEMENT_FACTOR = 8
_HERTZ_CURVATURE_FACTOR = 2.0


@dataclass(frozen=True)
class ContactPlane:
    """The plane tangent to the contact: origin on the rail surface, inclination theta.

    ``s`` runs along the plane in the track's y-z section (towards the field
    side), ``n`` along its normal (upwards, from the rail into the wheel).
    """

    origin_y_mm: float
    origin_z_mm: float
    angle_rad: float

    def to_plane(self, y_mm, z_mm) -> tuple[np.ndarray, np.ndarray]:
        """Track coordinates (y, z) to plane coordinates (s, n)."""
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        dy = np.asarray(y_mm, dtype=float) - self.origin_y_mm
        dz = np.asarray(z_mm, dtype=float) - self.origin_z_mm
        return dy * c + dz * s, -dy * s + dz * c


@dataclass(frozen=True)
class ContactRegion:
    """Rectangle of the contact plane covered by the grid (mm).

    ``|x| <= half_length_x_mm`` along the rail and ``s_min_mm <= s <= s_max_mm``
    across it, ``s`` measured from the first contact point. ``x_offset_mm``
    shifts the grid along the rail: its cells are centred at ``x_offset_mm + k
    h`` (default 0, a cell centred on the contact; a fraction of a cell moves
    the grid's phase against the patch, as shifting ``s_min_mm`` and
    ``s_max_mm`` does across the rail).
    """

    half_length_x_mm: float
    s_min_mm: float
    s_max_mm: float
    x_offset_mm: float = 0.0

    def __post_init__(self) -> None:
        check_positive("half_length_x_mm", self.half_length_x_mm)
        as_finite("x_offset_mm", self.x_offset_mm)
        as_finite("s_min_mm", self.s_min_mm)
        if not as_finite("s_max_mm", self.s_max_mm) > self.s_min_mm:
            raise ValueError(f"s_max_mm must exceed s_min_mm, got [{self.s_min_mm:g}, "
                             f"{self.s_max_mm:g}]")


@dataclass(frozen=True)
class ContactPatch:
    """One connected contact patch.

    Attributes
    ----------
    area_mm2 : float
        Area where the pressure is positive.
    force_fraction : float
        Share of the normal force carried by the patch.
    max_pressure_mpa : float
    centroid_x_mm, centroid_y_mm : float
        Area centroid of the patch along the rail and laterally in the track
        frame (y of the rail surface point).
    rail_y_mm, wheel_y_mm : float
        The centroid in the rail's and the wheel's own profile coordinates.
    """

    area_mm2: float
    force_fraction: float
    max_pressure_mpa: float
    centroid_x_mm: float
    centroid_y_mm: float
    rail_y_mm: float
    wheel_y_mm: float


@dataclass(frozen=True)
class WheelRailCase:
    """One load case: offset eta (mm), vertical force (N), optional film and roughness."""

    offset_mm: float
    force_n: float
    film: FilmLayer | None = None
    roughness: InterfaceLaw | None = None

    def __post_init__(self) -> None:
        as_finite("offset_mm", self.offset_mm)
        check_positive("force_n", self.force_n)
        _check_interfaces(self.film, self.roughness)


_INTERFACE_METHODS = ("closure_mm", "tangent_compliance_mm_per_mpa", "closure_integral",
                      "initial_compliance_mm_per_mpa")


def _check_interfaces(film, roughness) -> None:
    if film is not None and not (isinstance(film, FilmLayer) or all(
            hasattr(film, name) for name in _INTERFACE_METHODS)):
        raise ValueError("film must be a FilmLayer, a film with the interface methods "
                         f"({', '.join(_INTERFACE_METHODS)}) or None, got {film!r}")
    if roughness is not None and not isinstance(roughness, InterfaceLaw):
        raise ValueError(f"roughness must be an InterfaceLaw or None, got {roughness!r}")


@dataclass
class WheelRailResult:
    """Solution of one wheel-rail normal contact.

    Attributes
    ----------
    offset_mm, force_n : float
        Lateral offset eta and vertical wheel load.
    normal_force_n : float
        Force normal to the contact plane, ``F / cos(theta)``.
    film, roughness : FilmLayer or None, InterfaceLaw or None
    area_mm2 : float
        Contact area: where the pressure is positive (module notes).
    max_pressure_mpa : float
    approach_mm : float
        Vertical approach of wheel and rail from first touch.
    normal_approach_mm : float
        Approach along the plane normal.
    contact_angle_rad : float
        Inclination theta of the contact plane.
    centroid_x_mm, centroid_y_mm, centroid_rail_y_mm, centroid_wheel_y_mm : float
        Area centroid of the whole contact (track frame; rail and wheel
        profile coordinates).
    patches : tuple of ContactPatch
        Connected patches, largest force first.
    outline_mm : list of ndarray
        Outline rings of ``area_mm2``, ``(n, 2)``
        arrays of (x along the rail, y lateral in the track frame).
    hertz : HertzContact or None
        Local Hertz solution at the first contact point (relative curvatures:
        rail and wheel lateral curvatures, and ``cos(theta)/r`` along the
        rail; normal force ``F / cos(theta)``), None where the relative
        lateral curvature is not positive.
    hertz_like : bool
        One patch, one loaded contact point, and a relative lateral curvature
        that stays within a factor 2 of its value at the contact point across
        the Hertz ellipse (no profile joint, not near-conformal): the cases
        where the Hertz area is a meaningful reference.
    plane : ContactPlane
    grid_track_y_mm : ndarray
        Track lateral position of every grid row ``s`` (cell centres).
    contact : ContactResult
        The half-space solution in plane coordinates (grid, pressure map).
    placement : WheelRailPlacement
    converged : bool
    elapsed_s : float
    """

    offset_mm: float
    force_n: float
    normal_force_n: float
    film: FilmLayer | None
    roughness: InterfaceLaw | None
    area_mm2: float
    max_pressure_mpa: float
    approach_mm: float
    normal_approach_mm: float
    contact_angle_rad: float
    centroid_x_mm: float
    centroid_y_mm: float
    centroid_rail_y_mm: float
    centroid_wheel_y_mm: float
    patches: tuple[ContactPatch, ...]
    outline_mm: list[np.ndarray] = field(repr=False)
    hertz: HertzContact | None
    hertz_like: bool
    plane: ContactPlane = field(repr=False)
    grid_track_y_mm: np.ndarray = field(repr=False)
    contact: ContactResult = field(repr=False)
    placement: WheelRailPlacement = field(repr=False)
    converged: bool
    elapsed_s: float

    @property
    def n_patches(self) -> int:
        """Number of connected contact patches."""
        return len(self.patches)

    @property
    def pressure_mpa(self) -> np.ndarray:
        """Pressure map on the grid of the contact plane, indexed ``[ix, is]``."""
        return self.contact.pressure_mpa

    @property
    def grid(self) -> SurfaceGrid:
        """Grid of the contact plane (x along the rail, s along the inclined tangent)."""
        return self.contact.grid

    def summary(self) -> dict:
        """Scalar results as a JSON-ready dict."""
        hz = self.hertz
        return {
            "offset_mm": self.offset_mm,
            "force_kn": self.force_n / 1e3,
            "wheel": self.placement.wheel.name,
            "rail": self.placement.rail.name,
            "rail_inclination": self.placement.rail_inclination,
            "nominal_radius_mm": self.placement.nominal_radius_mm,
            "film": None if self.film is None else {
                key: getattr(self.film, key, None)
                for key in ("modulus_mpa", "poisson", "thickness_mm", "oedometric_modulus_mpa")}
                | {"kinematics": getattr(self.film, "kinematics", "small")},
            "roughness": None if self.roughness is None else repr(self.roughness),
            "contact_area_mm2": self.area_mm2,
            "max_pressure_mpa": self.max_pressure_mpa,
            "approach_mm": self.approach_mm,
            "normal_approach_mm": self.normal_approach_mm,
            "normal_force_kn": self.normal_force_n / 1e3,
            "contact_angle_deg": math.degrees(self.contact_angle_rad),
            "centroid_x_mm": self.centroid_x_mm,
            "centroid_y_mm": self.centroid_y_mm,
            "centroid_rail_y_mm": self.centroid_rail_y_mm,
            "centroid_wheel_y_mm": self.centroid_wheel_y_mm,
            "n_patches": self.n_patches,
            "patches": [vars(p).copy() for p in self.patches],
            "contact_points": [{"y_mm": c.y_mm, "rail_y_mm": c.y_rail_mm,
                                "wheel_y_mm": c.y_wheel_mm, "separation_mm": c.separation_mm,
                                "contact_angle_deg": math.degrees(c.contact_angle_rad)}
                               for c in self.placement.contact_points],
            "hertz_area_mm2": None if hz is None else hz.area_mm2,
            "hertz_max_pressure_mpa": None if hz is None else hz.max_pressure_mpa,
            "hertz_semi_axes_mm": None if hz is None else [hz.semi_axis_x_mm, hz.semi_axis_y_mm],
            "hertz_like": self.hertz_like,
            "grid_mm": self.grid.dx_mm,
            "grid_s_mm": self.grid.dy_mm,
            "grid_cells": [self.grid.nx, self.grid.ny],
            "converged": self.converged,
            "elapsed_s": self.elapsed_s,
        }


# ---------------------------------------------------------------------------
# Geometry in a contact plane
# ---------------------------------------------------------------------------

class _PlaneCurves:
    """Rail and wheel profiles of one placement rotated into one contact plane."""

    def __init__(self, geometry: "WheelRailGeometry", plane: ContactPlane) -> None:
        self.plane = plane
        self.cos, self.sin = math.cos(plane.angle_rad), math.sin(plane.angle_rad)
        y = geometry.y_mm
        s_r, n_r = plane.to_plane(y, geometry.rail_z_mm)
        s_w, n_w = plane.to_plane(y, geometry.wheel_z_mm)
        start = int(np.argmin(np.abs(y - plane.origin_y_mm)))
        rail = _monotone_run(s_r, start)
        wheel = _monotone_run(s_w, start)
        self.s_rail, self.n_rail, self.y_rail = s_r[rail], n_r[rail], y[rail]
        self.s_wheel, self.n_wheel = s_w[wheel], n_w[wheel]
        self.radius_wheel = geometry.radius_mm[wheel]
        self.s_range = (max(self.s_rail[0], self.s_wheel[0]), min(self.s_rail[-1], self.s_wheel[-1]))

    def separation(self, s: np.ndarray, slide_mm: float = 0.0) -> np.ndarray:
        """Normal gap in the y-z section through the contact (x = 0), the wheel slid by `slide_mm` along -s."""
        return np.interp(np.asarray(s) + slide_mm, self.s_wheel, self.n_wheel) - np.interp(s, self.s_rail, self.n_rail)

    def track_y(self, s) -> np.ndarray:
        """Track lateral position of the rail surface point at plane coordinate(s) s."""
        return np.interp(s, self.s_rail, self.y_rail)

    def wheel_radius(self, s: np.ndarray) -> np.ndarray:
        """Rolling radius of the wheel point at s (x = 0)."""
        return np.interp(s, self.s_wheel, self.radius_wheel)

    def gap(self, x: np.ndarray, s: np.ndarray, slide_mm: float = 0.0) -> np.ndarray:
        """3D gap along the plane normal, ``n_wheel(x, s) - n_rail(s)`` (the wheel slid by `slide_mm` along -s)."""
        x = np.asarray(x, dtype=float)
        s = np.asarray(s, dtype=float)
        source = s + slide_mm
        for _ in range(4):
            r = np.interp(source, self.s_wheel, self.radius_wheel)
            rise = x * x / (r + np.sqrt(np.clip(r * r - x * x, 0.0, None)))
            source = s + slide_mm - rise * self.sin
        wheel = np.interp(source, self.s_wheel, self.n_wheel) + rise * self.cos
        return wheel - np.interp(s, self.s_rail, self.n_rail)


    def grid_gap(self, x_mm: np.ndarray, s_mm: np.ndarray, slide_mm: float = 0.0) -> np.ndarray:
        """:meth:`gap` on the tensor grid ``x_mm (nx,) x s_mm (ns,)``, shape ``(nx, ns)``.

        The same fixed-point iteration, with everything that depends on ``s``
        alone evaluated once per grid line and the iteration stopped when the
        source points move by less than 1e-9 mm (at once for an untilted
        plane).
        """
        x2 = np.square(np.asarray(x_mm, dtype=float))[:, None]
        rail = np.interp(np.asarray(s_mm, dtype=float)[None, :], self.s_rail, self.n_rail)
        s = np.asarray(s_mm, dtype=float)[None, :] + slide_mm  # the wheel's points, where it slid from
        r = np.interp(s, self.s_wheel, self.radius_wheel)
        rise = x2 / (r + np.sqrt(np.clip(r * r - x2, 0.0, None)))
        source = s - rise * self.sin
        if self.sin != 0.0:
            for _ in range(4):
                r = np.interp(source, self.s_wheel, self.radius_wheel)
                rise = x2 / (r + np.sqrt(np.clip(r * r - x2, 0.0, None)))
                moved = s - rise * self.sin
                done = float(np.abs(moved - source).max()) < 1e-9
                source = moved
                if done:
                    break
        wheel = np.interp(source, self.s_wheel, self.n_wheel)
        return np.broadcast_to(wheel, rise.shape) + rise * self.cos - rail


def _monotone_run(s: np.ndarray, start: int) -> slice:
    """Largest index range around `start` over which s increases."""
    inc = np.diff(s) > 0
    lo = start
    while lo > 0 and inc[lo - 1]:
        lo -= 1
    hi = start
    while hi < len(inc) and inc[hi]:
        hi += 1
    return slice(lo, hi + 1)


class WheelRailGeometry:
    """Rail and wheel surfaces of one placement, sampled in the track frame.

    Parameters
    ----------
    placement : WheelRailPlacement
    """

    def __init__(self, placement: WheelRailPlacement) -> None:
        self.placement = placement
        lo, hi = placement.y_range_mm
        n = int(math.ceil((hi - lo) / _SAMPLE_STEP_MM)) + 1
        self.y_mm = np.linspace(lo, hi, n)
        self.rail_z_mm = np.asarray(placement.rail_height(self.y_mm))
        self.wheel_z_mm = np.asarray(placement.wheel_height(self.y_mm))
        self.radius_mm = np.asarray(placement.rolling_radius(self.y_mm))
        self._curves: dict[tuple[float, float, float], _PlaneCurves] = {}

    def curves(self, plane: ContactPlane) -> _PlaneCurves:
        """The profiles rotated into `plane` (cached per plane)."""
        key = (plane.origin_y_mm, plane.origin_z_mm, plane.angle_rad)
        if key not in self._curves:
            if len(self._curves) >= 4:
                self._curves.pop(next(iter(self._curves)))
            self._curves[key] = _PlaneCurves(self, plane)
        return self._curves[key]

    def plane(self, points: tuple[ContactPoint, ...]) -> ContactPlane:
        """Plane through the first point, inclined at the mean contact angle of `points`."""
        first = points[0]
        angle = float(np.mean([p.contact_angle_rad for p in points]))
        return ContactPlane(first.y_mm, first.z_mm, angle)


# ---------------------------------------------------------------------------
# Local Hertz reference and region estimate
# ---------------------------------------------------------------------------

def local_hertz(point: ContactPoint, force_n: float, contact_modulus_mpa: float) -> HertzContact | None:
    """Hertz contact at a contact point, or None if its relative lateral curvature is not positive.

    Relative curvatures: along the rail ``cos(theta) / r`` (the wheel's normal
    curvature in the rolling direction, Meusnier; the rail is straight),
    across it the sum of the two lateral profile curvatures. The normal force
    is ``F / cos(theta)``.
    """
    c = math.cos(point.contact_angle_rad)
    a_coef = 0.5 * c / point.rolling_radius_mm
    b_coef = 0.5 * (point.wheel_curvature_per_mm + point.rail_curvature_per_mm)
    if not b_coef > 0.0:
        return None
    return hertz_elliptic(a_coef, b_coef, force_n / c, contact_modulus_mpa)


def _approach_estimate(point: ContactPoint, force_n: float, contact_modulus_mpa: float,
                       film: FilmLayer | None, roughness: InterfaceLaw | None) -> float:
    """Approach of a Hertz contact at `point`, plus film and roughness closures at its peak pressure.

    Near-conformal points (relative lateral curvature below 1/20 of the
    rolling-direction one) are estimated with that floor; the solution
    corrects the estimate.
    """
    c = math.cos(point.contact_angle_rad)
    a_coef = 0.5 * c / point.rolling_radius_mm
    b_coef = max(0.5 * (point.wheel_curvature_per_mm + point.rail_curvature_per_mm),
                 a_coef / 20.0)
    hz = hertz_elliptic(a_coef, b_coef, force_n / c, contact_modulus_mpa)
    delta = hz.approach_mm
    if film is not None:
        delta += _closure_mm(film, hz.max_pressure_mpa)
    if roughness is not None:
        delta += float(roughness.closure_mm(np.array([hz.max_pressure_mpa]))[0])
    return delta


def _closure_mm(film, pressure_mpa: float) -> float:
    """Closure of a film at one pressure, through its generic method when it has one."""
    if hasattr(film, "closure_mm"):
        return float(np.asarray(film.closure_mm(np.array([pressure_mpa])), dtype=float)[0])
    return film.compliance_mm_per_mpa * pressure_mpa


def _round_up(n: int, step: int) -> int:
    return step * int(math.ceil(n / step))


def _region(curves: _PlaneCurves, delta_mm: float, spacing_mm: float, slide_mm: float = 0.0) -> ContactRegion:
    """Rectangle around the set ``g(x, s) <= delta`` (see module notes), the wheel slid by `slide_mm`."""
    lo, hi = curves.s_range
    s = curves.s_rail[(curves.s_rail >= lo + max(-slide_mm, 0.0)) & (curves.s_rail <= hi - max(slide_mm, 0.0))]
    d = curves.separation(s, slide_mm)
    inside = np.flatnonzero(d <= delta_mm)
    if inside.size == 0:
        raise ValueError("no contact found in the contact plane (internal geometry error)")
    if inside[0] == 0 or inside[-1] == s.size - 1:
        raise ValueError(f"the contact reaches the end of the wheel or rail profile (its approach {delta_mm:.3g} mm): "
                         "choose an offset further inside the profiles, a smaller force, or a stiffer or thinner "
                         "film (a soft or thick film spreads the contact)")
    r = curves.wheel_radius(s[inside] + slide_mm)
    rise = (delta_mm - d[inside]) / curves.cos
    half_x = float(np.sqrt(np.clip(r * r - (r - rise) ** 2, 0.0, None)).max())
    margin = _MARGIN_CELLS * spacing_mm
    return ContactRegion(max(half_x, spacing_mm) + margin, float(s[inside[0]]) - margin,
                         float(s[inside[-1]]) + margin)


def _grid(region: ContactRegion, spacing_mm: float, curves: _PlaneCurves,
          spacing_s_mm: float | None = None) -> SurfaceGrid:
    """Grid over the region, with cell counts rounded up for spectrum reuse.

    ``spacing_s_mm`` (default ``spacing_mm``) is the cell size across the
    rail, refined for narrow patches.
    """
    hx = spacing_mm
    hs = spacing_mm if spacing_s_mm is None else spacing_s_mm
    half = _round_up(int(math.ceil(region.half_length_x_mm / hx)), 4)
    nx = 2 * half + 1
    ns = _round_up(int(math.ceil((region.s_max_mm - region.s_min_mm) / hs)) + 1, 8)
    if nx * ns > _MAX_CELLS:
        raise ValueError(f"the contact region needs a {nx} x {ns} grid at grid_mm={hx:g} "
                         f"(across the rail {hs:g} mm); at most {_MAX_CELLS} cells (800 x 800) are "
                         "allowed: use a larger grid_mm")
    centre = 0.5 * (region.s_min_mm + region.s_max_mm)
    lo, hi = curves.s_range
    half_s = 0.5 * (ns - 1) * hs
    # keep the grid inside the part of the plane where both profiles are graphs
    centre = min(max(centre, lo + half_s), hi - half_s) if hi - lo > 2 * half_s else 0.5 * (lo + hi)
    return SurfaceGrid(nx, ns, hx, hs, -half * hx + region.x_offset_mm, centre - half_s)


def _transfer(previous: ContactResult, grid: SurfaceGrid) -> np.ndarray | None:
    """A neighbouring solution's pressure on `grid` (same plane coordinates), or None.

    Copied cell by cell when the grids share their cells (spacing and offsets), else
    bilinearly interpolated (zero outside the neighbour's grid).
    """
    source = previous.grid
    p = previous.pressure_mpa
    fx = (grid.x_mm - source.x0_mm) / source.dx_mm
    fy = (grid.y_mm - source.y0_mm) / source.dy_mm
    same = (math.isclose(grid.dx_mm, source.dx_mm) and math.isclose(grid.dy_mm, source.dy_mm)
            and np.allclose(fx, np.rint(fx), atol=1e-6) and np.allclose(fy, np.rint(fy), atol=1e-6))
    if same:
        ix, iy = np.rint(fx).astype(int), np.rint(fy).astype(int)
        okx = (ix >= 0) & (ix < source.nx)
        oky = (iy >= 0) & (iy < source.ny)
        out = np.zeros(grid.shape)
        out[np.ix_(okx, oky)] = p[np.ix_(ix[okx], iy[oky])]
    else:
        fxx, fyy = np.meshgrid(fx, fy, indexing="ij")
        out = ndimage.map_coordinates(p, [fxx, fyy], order=1, mode="constant", cval=0.0,
                                      prefilter=False)
    out = np.clip(out, 0.0, None)
    return out if out.sum() > 0.0 else None


def _refinement(loaded: np.ndarray, min_cells: int) -> tuple[int, int]:
    """Factors refining x and s so that the contact spans at least `min_cells` cells.

    The span in a direction is the largest number of loaded cells on one
    grid line in that direction (the solver's resolution check).
    """
    across_x = int(loaded.sum(axis=0).max())
    across_s = int(loaded.sum(axis=1).max())
    factor_x = 1 if across_x >= min_cells else int(math.ceil(min_cells / max(across_x, 1)))
    factor_s = 1 if across_s >= min_cells else int(math.ceil(min_cells / max(across_s, 1)))
    return factor_x, factor_s


# ---------------------------------------------------------------------------
# The model
# ---------------------------------------------------------------------------

class WheelRailModel:
    """Wheel-rail normal contact for one pair of profiles, with cached geometry and solver.

    Parameters
    ----------
    wheel, rail : str or Profile
        Profiles ("S1002"; "60E2", "60E1") or profile objects (e.g. from
        :func:`filmcal.wheelrail.profiles.load_profile_csv`).
    rail_inclination : float
        Rail cant (1/40).
    nominal_radius_mm : float
        Wheel rolling radius at the tape circle (460 mm).
    grid_mm : float
        Cell size of the contact grid (0.1 mm, the film's resolution).
    solver : HalfSpaceContactSolver, optional
        Steel on steel by default; it caches the influence-coefficient
        spectra of up to eight grid shapes.
    film_min_cells_across : int
        Cells a patch through a film spans at least in each direction
        (`FILM_MIN_CELLS_ACROSS`); 0 leaves a film's patch to the rule
        without film (twice the solver's ``min_cells_across``), which keeps
        wheel-rail tread patches on the grid as given (a study of the
        readings' convergence on fixed grids).
    slide_tol_cells : float
        The wheel's slide along an inclined contact plane is solved again
        until it moves by less than this share of a cell across the rail
        (`SLIDE_TOL_CELLS`, 0.02: 0.002 mm at 0.1 mm). That leaves up to
        0.03 % in area (40 S1002/60E2 cases at 50/100 kN, eta -7..+6 mm,
        with and without HS film, against 1e-5), an error of first order in
        the cell size; a study of the readings' convergence on fixed grids
        sets it far smaller (``bench/verification.py --grid``: 1e-4).

    Notes
    -----
    Placements and rotated profiles are cached per offset (32 offsets), so
    a sweep over film moduli at fixed offsets and loads (a posterior sample)
    costs the contact solutions only.
    """

    def __init__(self, wheel: str | Profile = WHEEL, rail: str | Profile = RAIL,
                 rail_inclination: float = RAIL_INCLINATION, nominal_radius_mm: float = NOMINAL_RADIUS_MM, *,
                 grid_mm: float = GRID_MM, solver: HalfSpaceContactSolver | None = None,
                 film_min_cells_across: int = FILM_MIN_CELLS_ACROSS,
                 slide_tol_cells: float = SLIDE_TOL_CELLS) -> None:
        self.grid_mm = check_range("grid_mm", grid_mm, *GRID_MM_RANGE, low_open=False,
                                   high_open=False)
        self.film_min_cells_across = int(check_range("film_min_cells_across", film_min_cells_across, 0, 1000,
                                                     low_open=False, high_open=False))
        self.slide_tol_cells = check_positive("slide_tol_cells", slide_tol_cells)
        self.rail_inclination = check_range("rail_inclination", rail_inclination, 0.0, 0.2,
                                            low_open=False, high_open=False)
        self.nominal_radius_mm = check_positive("nominal_radius_mm", nominal_radius_mm)
        self.wheel = _resolve(wheel, "wheel")
        self.rail = _resolve(rail, "rail")
        self.solver = HalfSpaceContactSolver() if solver is None else solver
        self._geometries: "OrderedDict[float, WheelRailGeometry]" = OrderedDict()

    def geometry(self, offset_mm: float) -> WheelRailGeometry:
        """Placement and sampled surfaces at offset eta (cached)."""
        eta = as_finite("offset_mm", offset_mm)
        geo = self._geometries.get(eta)
        if geo is None:
            placement = place_wheel_on_rail(self.wheel, self.rail, offset_mm=eta,
                                            rail_inclination=self.rail_inclination,
                                            nominal_radius_mm=self.nominal_radius_mm,
                                            tolerance_mm=_CANDIDATE_TOLERANCE_MM)
            geo = WheelRailGeometry(placement)
            self._geometries[eta] = geo
            while len(self._geometries) > 32:
                self._geometries.popitem(last=False)
        else:
            self._geometries.move_to_end(eta)
        return geo

    def solve(self, offset_mm: float, force_n: float, film: FilmLayer | None = None,
              roughness: InterfaceLaw | None = None,
              region: ContactRegion | None = None, *,
              initial: "WheelRailResult | None" = None, waviness=None) -> WheelRailResult:
        """Solve one case.

        Parameters
        ----------
        offset_mm : float
            Lateral offset eta (mm), inside the range the profiles allow.
        force_n : float
            Vertical wheel load (N), > 0.
        film : FilmLayer, optional
            Film between wheel and rail (springs in series; a linear
            :class:`FilmLayer` or any film with the interface methods, such
            as a nonlinear film law).
        roughness : InterfaceLaw, optional
            Pressure-overclosure law of a rough interface in series (the
            film-wheel interface with a film, the wheel-rail one without).
        region : ContactRegion, optional
            Grid region in the contact plane; chosen automatically by default.
        initial : WheelRailResult, optional
            Warm start from a neighbouring solution (another offset, load,
            film modulus or roughness): its pressure, in its contact-plane
            coordinates ``(x, s)`` measured from its first contact point, is
            interpolated onto this case's grid (copied cell by cell when the
            grids share their cells) and scaled to this force as the
            solver's starting pressure. The answer is the
            same as from a cold start to the solver tolerance; only the
            iteration count falls. :meth:`solve_many` does this along a
            list of cases.
        waviness : filmcal.contact.waviness.Waviness, optional
            The bodies' long-wave heights, subtracted from the gap at every
            cell (the map repeated from the grid's first cell).

        Returns
        -------
        WheelRailResult

        Raises
        ------
        ValueError
            For an offset outside the profiles, a non-positive force, a
            contact too narrow for ``min_cells_across`` even on a grid
            refined to an eighth of ``grid_mm``, or a contact reaching the
            end of a profile (or the edge of a given region).

        Notes
        -----
        The grid region grows until it encloses the contact (module notes);
        each larger region starts from the previous attempt's pressure. A
        contact narrower than twice the solver's ``min_cells_across`` cells
        (through a film: `FILM_MIN_CELLS_ACROSS`) in a direction (a flange
        contact: 60E1, 10 kN, eta +4 to +8 mm spans 8-11 cells of 0.1 mm
        across) is solved again on a grid refined in
        that direction only, by the factor that brings it to at least that
        many cells, over the same region; ``WheelRailResult.grid`` gives the
        spacings used. On an inclined plane the wheel's slide under its
        vertical approach is followed by solving again (module notes).

        Examples
        --------
        A sweep over film moduli at one offset and load, each solve warm
        started from the previous one:

        >>> model = WheelRailModel()
        >>> previous = None
        >>> for modulus in (2000.0, 2800.0, 4000.0):
        ...     previous = model.solve(-3.0, 50e3, film=FilmLayer(modulus), initial=previous)
        """
        start = time.perf_counter()
        force = check_positive("force_n", force_n)
        _check_interfaces(film, roughness)
        if initial is not None and not isinstance(initial, WheelRailResult):
            raise ValueError(f"initial must be a WheelRailResult or None, got {initial!r}")
        geo = self.geometry(offset_mm)
        placement = geo.placement
        e_star = self.solver.contact_modulus_mpa
        delta_box = 1.1 * _approach_estimate(placement.contact, force, e_star, film, roughness)
        if not (math.isfinite(delta_box) and delta_box > 0):
            raise ValueError("film_modulus_mpa: the film is too soft for this load: its compression has no finite "
                             "estimate (a Prescale film's E is of the order of 10^2-10^4 MPa); check the units")
        previous = None if initial is None else initial.contact
        spacing_x = spacing_s = self.grid_mm
        min_across = max(2 * self.solver.min_cells_across, self.film_min_cells_across) \
            if through_film(film, roughness) else 2 * self.solver.min_cells_across
        # the wheel's slide along an inclined plane under its vertical approach, first from the approach estimate
        first = geo.plane(tuple(p for p in placement.contact_points if p.separation_mm <= delta_box))
        slide = delta_box / 1.1 * math.tan(first.angle_rad)
        for _ in range(_MAX_SLIDES):
            enclosed = resolved = False
            refinements = 0
            for _ in range(_MAX_ATTEMPTS + _MAX_REFINEMENTS):
                points = tuple(p for p in placement.contact_points if p.separation_mm <= delta_box)
                plane = geo.plane(points)
                curves = geo.curves(plane)
                normal_force = force / math.cos(plane.angle_rad)
                box = _region(curves, delta_box, self.grid_mm, slide) if region is None else region
                grid = _grid(box, spacing_x, curves, spacing_s)
                gap = curves.grid_gap(grid.x_mm, grid.y_mm, slide)
                if waviness is not None:
                    gap = gap - waviness.gap_mm(grid.x_mm, grid.y_mm)
                start_pressure = None if previous is None else _transfer(previous, grid)
                result = self.solver.solve(gap, normal_force, grid, film=film, law=roughness,
                                           initial_pressure_mpa=start_pressure, allow_edge=True,
                                           check_resolution=False)
                previous = result
                delta = result.approach_mm + float(gap.min())
                if region is not None:
                    enclosed = not result.reaches_edge
                elif not result.reaches_edge and delta <= delta_box:
                    enclosed = True
                else:
                    delta_box = 1.25 * max(delta, delta_box)
                    continue
                if not enclosed:
                    break
                factor_x, factor_s = _refinement(result.contact_mask, min_across)
                resolved = factor_x == factor_s == 1
                if resolved or refinements == _MAX_REFINEMENTS:
                    break
                finest = self.grid_mm / _MAX_REFINEMENT_FACTOR
                refined = (max(spacing_x / factor_x, finest), max(spacing_s / factor_s, finest))
                if refined == (spacing_x, spacing_s):
                    break
                refinements += 1
                spacing_x, spacing_s = refined
            # the wheel is lowered vertically: its normal approach slides it along the inclined plane by
            # approach * tan(angle); solved again with that slide until it stops moving (module notes)
            moved = delta * math.tan(plane.angle_rad)
            if not enclosed or abs(moved - slide) <= self.slide_tol_cells * spacing_s:
                break
            slide = moved
        if not enclosed:
            raise ValueError("the contact reaches the edge of the given region; enlarge it"
                             if region is not None else
                             "the contact could not be enclosed in the usable part of the profiles "
                             "at this offset and load")
        if not resolved:
            self.solver.check_resolution(result.contact_mask, result.grid)
        return self._result(geo, plane, curves, result, force, normal_force, film, roughness,
                            delta, start)

    def solve_many(self, cases: Iterable[WheelRailCase | Mapping | tuple], *,
                   warm_start: bool = True) -> list[WheelRailResult]:
        """Solve many cases (offset, force, film, roughness) with the shared caches.

        Cases may be :class:`WheelRailCase`, mappings with its field names or
        tuples in its field order. Their values (finite offset, positive
        force, film and roughness types) are checked before the first solve.

        With ``warm_start`` (default) each case starts from the solution of
        the case before it (``solve(..., initial=previous)``): order a sweep
        so that neighbours are alike (moduli, loads or offsets in order).
        The results equal cold starts to the solver tolerance.
        """
        checked = [_as_case(c) for c in cases]
        results: list[WheelRailResult] = []
        for c in checked:
            initial = results[-1] if warm_start and results else None
            results.append(self.solve(c.offset_mm, c.force_n, c.film, c.roughness,
                                      initial=initial))
        return results

    # -- post-processing ---------------------------------------------------
    def _result(self, geo: WheelRailGeometry, plane: ContactPlane, curves: _PlaneCurves,
                result: ContactResult, force: float, normal_force: float,
                film: FilmLayer | None, roughness: InterfaceLaw | None, delta: float,
                start: float) -> WheelRailResult:
        placement = geo.placement
        grid = result.grid
        p = result.pressure_mpa
        labels, n_labels = ndimage.label(p > 0.0, structure=np.ones((3, 3), dtype=int))
        support = patch_ring_areas_mm2(grid.x_mm, grid.y_mm, result.outline_mm, labels, n_labels)
        x, s = grid.mesh()
        patches = []
        for k in range(1, n_labels + 1):
            cells = labels == k
            cx, cs = float(x[cells].mean()), float(s[cells].mean())
            cy = float(curves.track_y(cs))
            patches.append(ContactPatch(
                area_mm2=float(support[k - 1]),
                force_fraction=float(p[cells].sum() / p.sum()),
                max_pressure_mpa=float(p[cells].max()), centroid_x_mm=cx, centroid_y_mm=cy,
                rail_y_mm=float(placement.rail_y(cy)), wheel_y_mm=cy - placement.offset_mm))
        patches.sort(key=lambda q: -q.force_fraction)
        loaded = p > 0.0
        cy = float(curves.track_y(float(s[loaded].mean())))
        hertz = local_hertz(placement.contact, force, self.solver.contact_modulus_mpa)
        cos = math.cos(plane.angle_rad)
        return WheelRailResult(
            offset_mm=placement.offset_mm, force_n=force, normal_force_n=normal_force,
            film=film, roughness=roughness, area_mm2=result.area_mm2,
            max_pressure_mpa=result.max_pressure_mpa,
            approach_mm=delta / cos, normal_approach_mm=delta, contact_angle_rad=plane.angle_rad,
            centroid_x_mm=float(x[loaded].mean()), centroid_y_mm=cy,
            centroid_rail_y_mm=float(placement.rail_y(cy)),
            centroid_wheel_y_mm=cy - placement.offset_mm, patches=tuple(patches),
            outline_mm=[_to_track(curves, r) for r in result.outline_mm],
            hertz=hertz, hertz_like=_hertz_like(placement, curves, result, hertz, n_labels),
            plane=plane, grid_track_y_mm=curves.track_y(grid.y_mm), contact=result,
            placement=placement,
            converged=result.converged, elapsed_s=time.perf_counter() - start)



def _to_track(curves: _PlaneCurves, ring: np.ndarray) -> np.ndarray:
    """Ring in plane coordinates (x, s) to track coordinates (x, y)."""
    return np.column_stack([ring[:, 0], curves.track_y(ring[:, 1])])


def _resolve(profile: str | Profile, kind: str) -> Profile:
    """A profile object from a standard name, checking its kind."""
    p = get_profile(profile) if isinstance(profile, str) else profile
    if not isinstance(p, Profile) or p.kind != kind:
        raise ValueError(f"{kind} must be a {kind} profile or the name of one, got {profile!r}")
    return p


def _hertz_like(placement: WheelRailPlacement, curves: _PlaneCurves, result: ContactResult,
                hertz: HertzContact | None, n_patches: int) -> bool:
    """One patch, one loaded contact point, and a relative lateral curvature within a
    factor 2 of its contact-point value across the Hertz semi-axis.

    A smoothly varying curvature (the S1002 tread) mainly shifts and skews the
    patch; a curvature jump at a profile joint or a near-conformal region
    (curvature falling towards zero) changes its size.
    """
    if hertz is None or n_patches != 1:
        return False
    grid = result.grid
    ix = int(np.argmin(np.abs(grid.x_mm)))
    loaded_points = 0
    for point in placement.contact_points:
        s, _ = curves.plane.to_plane(point.y_mm, point.z_mm)
        i_s = int(np.rint((float(s) - grid.y0_mm) / grid.dy_mm))
        if 0 <= i_s < grid.ny and result.pressure_mpa[ix, i_s] > 0.0:
            loaded_points += 1
    if loaded_points > 1:
        return False
    point = placement.contact
    half = hertz.semi_axis_y_mm * math.cos(point.contact_angle_rad)
    lo, hi = placement.y_range_mm
    y = np.clip(point.y_mm + half * np.linspace(-1.0, 1.0, 41), lo, hi)
    k = np.asarray(placement.wheel_curvature(y)) + np.asarray(placement.rail_curvature(y))
    k0 = point.wheel_curvature_per_mm + point.rail_curvature_per_mm
    return bool(np.all(k >= k0 / _HERTZ_CURVATURE_FACTOR)
                and np.all(k <= k0 * _HERTZ_CURVATURE_FACTOR))


def _as_case(case) -> WheelRailCase:
    if isinstance(case, WheelRailCase):
        return case
    if isinstance(case, Mapping):
        return WheelRailCase(**case)
    return WheelRailCase(*case)


_MODELS: "OrderedDict[tuple, WheelRailModel]" = OrderedDict()


def get_wheel_rail_model(wheel: str | Profile = WHEEL, rail: str | Profile = RAIL,
                         rail_inclination: float = RAIL_INCLINATION, nominal_radius_mm: float = NOMINAL_RADIUS_MM,
                         grid_mm: float = GRID_MM, tol: float = 1e-9) -> WheelRailModel:
    """A :class:`WheelRailModel` for these settings, built once per process (LRU of 4).

    `tol` is the solver's tolerance (`HalfSpaceContactSolver`); sweeps use 1e-6,
    which changes wheel-rail areas by about 1e-6 relative at most.
    """
    key = (wheel, rail, float(rail_inclination), float(nominal_radius_mm), float(grid_mm), float(tol))
    model = _MODELS.get(key)
    if model is None:
        solver = None if tol == 1e-9 else HalfSpaceContactSolver(tol=tol)
        model = WheelRailModel(wheel, rail, rail_inclination, nominal_radius_mm, grid_mm=grid_mm, solver=solver)
        _MODELS[key] = model
        while len(_MODELS) > 4:
            _MODELS.popitem(last=False)
    else:
        _MODELS.move_to_end(key)
    return model


def solve_wheel_rail(offset_mm: float, force_n: float, *, wheel: str | Profile = WHEEL,
                     rail: str | Profile = RAIL, rail_inclination: float = RAIL_INCLINATION,
                     nominal_radius_mm: float = NOMINAL_RADIUS_MM, film: FilmLayer | None = None,
                     roughness: InterfaceLaw | None = None, grid_mm: float = GRID_MM,
                     region: ContactRegion | None = None,
                     initial: WheelRailResult | None = None, waviness=None) -> WheelRailResult:
    """Wheel-rail normal contact at lateral offset eta under vertical load F.

    Parameters
    ----------
    offset_mm : float
        Lateral offset eta (mm; the paper's convention, see
        :mod:`filmcal.wheelrail.placement`).
    force_n : float
        Vertical wheel load (N), > 0.
    wheel, rail : str or Profile
        "S1002"; "60E2" or "60E1"; or profiles read from CSV files.
    rail_inclination : float
        Rail cant (1/40).
    nominal_radius_mm : float
        Wheel radius at the tape circle (460 mm).
    film : FilmLayer, optional
        Film between wheel and rail (e.g. HS: ``FilmLayer(2800, 0.33, 0.09)``).
    roughness : InterfaceLaw, optional
        Rough interface in series (film-wheel with a film).
    grid_mm : float
        Cell size (mm).
    region : ContactRegion, optional
        Grid region in the contact plane; automatic by default.
    initial : WheelRailResult, optional
        Warm start from a neighbouring solution (see
        :meth:`WheelRailModel.solve`).
    waviness : filmcal.contact.waviness.Waviness, optional
        The bodies' long-wave heights in the gap (see :meth:`WheelRailModel.solve`).

    Returns
    -------
    WheelRailResult

    Notes
    -----
    Uses a per-process cached :class:`WheelRailModel`
    (:func:`get_wheel_rail_model`), so repeated calls reuse placements and
    influence-coefficient spectra.
    """
    model = get_wheel_rail_model(wheel, rail, rail_inclination, nominal_radius_mm, grid_mm)
    return model.solve(offset_mm, force_n, film=film, roughness=roughness, region=region,
                       initial=initial, waviness=waviness)


def solve_wheel_rail_many(cases: Iterable[WheelRailCase | Mapping | tuple], *,
                          wheel: str | Profile = WHEEL, rail: str | Profile = RAIL,
                          rail_inclination: float = RAIL_INCLINATION, nominal_radius_mm: float = NOMINAL_RADIUS_MM,
                          grid_mm: float = GRID_MM, warm_start: bool = True) -> list[WheelRailResult]:
    """Solve many (offset_mm, force_n, film, roughness) cases with one cached model.

    See :meth:`WheelRailModel.solve_many`.
    """
    model = get_wheel_rail_model(wheel, rail, rail_inclination, nominal_radius_mm, grid_mm)
    return model.solve_many(cases, warm_start=warm_start)
