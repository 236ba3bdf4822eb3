"""Wheel and rail profiles from their standard definitions.

A profile is a plane curve z(y) across the running surface, made of sections
(circular arcs, polynomials, straight lines, or a smoothing spline for a
profile read from a CSV file). Every profile is kept in its own standard
coordinate system:

* ``y`` (mm) is lateral. For the wheel it is measured from the tape circle
  (the measuring plane 70 mm from the inner face of the wheel) and is
  positive towards the outer (field) face, so the flange lies at y < 0. For
  the rail it is measured from the rail's symmetry axis, with the same
  orientation: y < 0 is the gauge side, which faces the wheel flange.
* ``z`` (mm) points out of the body's material towards the mating body. For
  the rail it is vertical, upwards, from the top of the crown (z = 0 at
  y = 0, the head lies at z < 0). For the wheel it is radial, outwards, from
  the tread datum at the tape circle: it is the UIC 510-2 profile function
  F(y), so the flange tip lies at z = +28 mm and the rolling radius at y is
  ``nominal radius + z(y)``.

With this convention the lateral curvature ``-z''/(1 + z'^2)^(3/2)`` is
positive where the surface is convex (bulges towards the mating body) for
both bodies, so the relative lateral curvature of a wheel-rail contact is the
sum of the two.

Sources
-------
S1002 (UIC 510-2, 4th ed. 2004, Appendix B; EN 13715:2006+A1:2010): eight
sections A-H, each a polynomial, a straight line or a circular arc, with the
section bounds and coefficients of the published definition (the coefficient
table of H. Netter, DLR, that reproduces the UIC drawing). Flange height
28 mm, flange thickness 32.5 mm.

60E1 and 60E2 (EN 13674-1:2011+A1:2017, Annex A): the head is a chain of
tangent circular arcs from the crown to the gauge corner, followed by a flank
inclined 1:20 that widens downwards. The drawings give the radii and the
horizontal distances between symmetric tangent points: 60E1 R300 | 20.456 |
R80 | 52.053 | R13; 60E2 R200 | 23.778 | R70 | 48.913 | R16 | 70.774 | R8.
The arc centres follow from tangency (each centre lies on the common normal
at its tangent point) and the last arc ends where its tangent has the flank
inclination. The head width of 72 mm is the width between the points where
the flanks begin (14.30 mm below the crown top for both rails).
"""
from __future__ import annotations

import csv
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.polynomial import polynomial as npoly

from filmcal._validation import as_finite, check_choice, check_positive, check_range, plain_float

__all__ = [
    "ProfileSection", "ArcSection", "PolynomialSection", "SplineSection", "Joint", "Profile",
    "PROFILE_NAMES", "PROFILE_KINDS", "INNER_FACE_Y_MM", "FLANGE_THICKNESS_HEIGHT_MM",
    "GAUGE_DEPTH_MM", "RAIL_FLANK_END_DEPTH_MM",
    "s1002_wheel", "rail_60e1", "rail_60e2", "rail_head", "sphere_wheel", "flat_rail", "get_profile", "load_profile_csv",
    "flange_height_mm", "flange_thickness_mm", "head_width_mm", "profile_dimensions",
]

PROFILE_KINDS = ("wheel", "rail")

# EN 13715: the tape circle (measuring circle) lies 70 mm from the inner face
# of the wheel; the flange thickness is measured from that face to the flange
# face at 10 mm from the tread datum towards the flange tip.
INNER_FACE_Y_MM = -70.0
FLANGE_THICKNESS_HEIGHT_MM = 10.0

# Track gauge is measured 14 mm below the running surface (EN 13848-1); the
# default depth for the head width of a rail read from a file.
GAUGE_DEPTH_MM = 14.0

# The rail flanks are modelled down to this depth below the crown top. In
# EN 13674-1 they continue to the fillet of the head underside (about 37 mm
# deep); 30 mm covers the whole region a wheel tread or flange face reaches
# for lateral offsets up to flange contact.
RAIL_FLANK_END_DEPTH_MM = 30.0

_JOINT_TOL_MM = 1e-9


def _as_array(y) -> np.ndarray:
    return np.asarray(y, dtype=float)


def _arc_length_samples(section, step_mm: float, n_dense: int = 2001) -> np.ndarray:
    """Lateral positions spaced about `step_mm` apart along the curve of `section`."""
    yd = np.linspace(section.y_start_mm, section.y_end_mm, n_dense)
    zd = section.evaluate(yd, 0)
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(yd), np.diff(zd)))])
    n = max(1, math.ceil(s[-1] / step_mm))
    y = np.interp(np.linspace(0.0, s[-1], n + 1), s, yd)
    y[0], y[-1] = section.y_start_mm, section.y_end_mm
    return y


class ProfileSection(ABC):
    """A piece of a profile over [y_start_mm, y_end_mm]: an arc, a polynomial or a spline."""

    label: str
    y_start_mm: float
    y_end_mm: float

    def _check_bounds(self) -> None:
        if not (math.isfinite(self.y_start_mm) and math.isfinite(self.y_end_mm)
                and self.y_start_mm < self.y_end_mm):
            raise ValueError(f"section {self.label!r}: need finite y_start_mm < y_end_mm, "
                             f"got [{self.y_start_mm}, {self.y_end_mm}]")

    @abstractmethod
    def evaluate(self, y: np.ndarray, order: int = 0) -> np.ndarray:
        """z (order 0), dz/dy (order 1) or d2z/dy2 (order 2) at y."""

    def curvature(self, y: np.ndarray) -> np.ndarray:
        """Signed curvature -z''/(1+z'^2)^(3/2), convex (towards +z) positive (1/mm)."""
        d1 = self.evaluate(y, 1)
        d2 = self.evaluate(y, 2)
        return -d2 / (1.0 + d1**2) ** 1.5

    def sample(self, step_mm: float) -> np.ndarray:
        """Lateral positions of points about `step_mm` apart along the curve (ends included)."""
        return _arc_length_samples(self, step_mm)


@dataclass(frozen=True)
class ArcSection(ProfileSection):
    """Circular arc z = zc + s sqrt(R^2 - (y - yc)^2), s = +1 if convex, -1 if concave.

    Convex means that the arc bulges towards +z, i.e. out of the body.
    """

    label: str
    y_start_mm: float
    y_end_mm: float
    centre_y_mm: float
    centre_z_mm: float
    radius_mm: float
    convex: bool = True

    def __post_init__(self) -> None:
        self._check_bounds()
        if not self.radius_mm > 0:
            raise ValueError(f"section {self.label!r}: radius_mm must be > 0, got {self.radius_mm}")
        reach = max(abs(self.y_start_mm - self.centre_y_mm), abs(self.y_end_mm - self.centre_y_mm))
        if reach > self.radius_mm * (1.0 + 1e-9):
            raise ValueError(f"section {self.label!r}: bounds reach beyond the arc of radius {self.radius_mm}")

    @property
    def _sign(self) -> float:
        return 1.0 if self.convex else -1.0

    def evaluate(self, y: np.ndarray, order: int = 0) -> np.ndarray:
        """z (order 0), dz/dy (1) or d2z/dy2 (2); the slope is infinite where the arc is vertical."""
        d = _as_array(y) - self.centre_y_mm
        q = np.sqrt(np.clip(self.radius_mm**2 - d**2, 0.0, None))
        s = self._sign
        if order == 0:
            return self.centre_z_mm + s * q
        with np.errstate(divide="ignore", invalid="ignore"):
            if order == 1:
                return np.where(q > 0, -s * d / q, -s * np.sign(d) * np.inf)
            if order == 2:
                return np.where(q > 0, -s * self.radius_mm**2 / q**3, -s * np.inf)
        raise ValueError(f"order must be 0, 1 or 2, got {order}")

    def curvature(self, y: np.ndarray) -> np.ndarray:
        """Exactly +1/R (convex) or -1/R (concave), also where the arc is vertical."""
        return np.full(np.shape(y), self._sign / self.radius_mm)

    def sample(self, step_mm: float) -> np.ndarray:
        """Points equally spaced in angle (hence in arc length) along the arc."""
        r = self.radius_mm
        a0 = math.asin(np.clip((self.y_start_mm - self.centre_y_mm) / r, -1.0, 1.0))
        a1 = math.asin(np.clip((self.y_end_mm - self.centre_y_mm) / r, -1.0, 1.0))
        n = max(1, math.ceil(r * abs(a1 - a0) / step_mm))
        y = self.centre_y_mm + r * np.sin(np.linspace(a0, a1, n + 1))
        y[0], y[-1] = self.y_start_mm, self.y_end_mm
        return y


@dataclass(frozen=True)
class PolynomialSection(ProfileSection):
    """Polynomial z = sum_k c_k y^k (coefficients in increasing powers); a line if degree 1."""

    label: str
    y_start_mm: float
    y_end_mm: float
    coefficients: tuple[float, ...]

    def __post_init__(self) -> None:
        self._check_bounds()
        if len(self.coefficients) == 0:
            raise ValueError(f"section {self.label!r}: no coefficients")

    def evaluate(self, y: np.ndarray, order: int = 0) -> np.ndarray:
        """z (order 0), dz/dy (1) or d2z/dy2 (2)."""
        if order not in (0, 1, 2):
            raise ValueError(f"order must be 0, 1 or 2, got {order}")
        c = np.asarray(self.coefficients, dtype=float)
        return npoly.polyval(_as_array(y), npoly.polyder(c, order) if order else c)


@dataclass(frozen=True, eq=False)
class SplineSection(ProfileSection):
    """A cubic (smoothing) spline z(y), for profiles read from measured points."""

    label: str
    y_start_mm: float
    y_end_mm: float
    spline: Any = field(repr=False)  # a scipy.interpolate.BSpline

    def __post_init__(self) -> None:
        self._check_bounds()

    def evaluate(self, y: np.ndarray, order: int = 0) -> np.ndarray:
        """z (order 0), dz/dy (1) or d2z/dy2 (2)."""
        if order not in (0, 1, 2):
            raise ValueError(f"order must be 0, 1 or 2, got {order}")
        return self.spline(_as_array(y), nu=order)


@dataclass(frozen=True)
class Joint:
    """Mismatch between two neighbouring sections at their common bound."""

    y_mm: float
    left: str
    right: str
    z_mismatch_mm: float
    slope_mismatch: float
    angle_mismatch_rad: float


@dataclass(frozen=True)
class Profile:
    """A wheel or rail profile z(y) in its own standard coordinates (see module docstring).

    Parameters
    ----------
    name : str
        Profile name ("S1002", "60E2", or a file stem).
    kind : {"wheel", "rail"}
        Which body the profile belongs to.
    sections : tuple of sections
        Contiguous pieces ordered by increasing y.
    source : str
        Where the definition comes from.
    flank_depth_mm : float, optional
        Rails only: depth below the crown top where the straight flanks begin
        (the depth of the standard head width).
    """

    name: str
    kind: str
    sections: tuple[ProfileSection, ...]
    source: str = ""
    flank_depth_mm: float | None = None

    def __post_init__(self) -> None:
        check_choice("kind", self.kind, PROFILE_KINDS)
        if len(self.sections) == 0:
            raise ValueError(f"profile {self.name!r} has no sections")
        for a, b in zip(self.sections[:-1], self.sections[1:]):
            if abs(a.y_end_mm - b.y_start_mm) > _JOINT_TOL_MM:
                raise ValueError(f"profile {self.name!r}: sections {a.label!r} and {b.label!r} "
                                 f"do not join ({a.y_end_mm} != {b.y_start_mm})")

    @property
    def y_range_mm(self) -> tuple[float, float]:
        """Lateral range (y_min, y_max) over which the profile is defined."""
        return self.sections[0].y_start_mm, self.sections[-1].y_end_mm

    def _apply(self, y, method: str, *args):
        arr = _as_array(y)
        lo, hi = self.y_range_mm
        if not np.all(np.isfinite(arr)):
            raise ValueError("y_mm must be finite")
        if np.any(arr < lo - _JOINT_TOL_MM) or np.any(arr > hi + _JOINT_TOL_MM):
            raise ValueError(f"y_mm must lie in [{lo:g}, {hi:g}] for profile {self.name}, "
                             f"got values in [{arr.min():g}, {arr.max():g}]")
        arr = np.clip(arr, lo, hi)
        starts = np.array([s.y_start_mm for s in self.sections[1:]])
        index = np.searchsorted(starts, arr, side="right")
        out = np.empty(arr.shape, dtype=float)
        for i in np.unique(index):
            mask = index == i
            out[mask] = getattr(self.sections[i], method)(arr[mask], *args)
        return float(out) if out.ndim == 0 else out

    def z(self, y):
        """Profile coordinate z (mm) at lateral position(s) y (mm)."""
        return self._apply(y, "evaluate", 0)

    def slope(self, y):
        """dz/dy at y (infinite where the profile is vertical, e.g. the S1002 flange back)."""
        return self._apply(y, "evaluate", 1)

    def second_derivative(self, y):
        """d2z/dy2 at y (1/mm)."""
        return self._apply(y, "evaluate", 2)

    def curvature(self, y):
        """Lateral curvature (1/mm) at y: 1/radius, positive where the surface is convex.

        Convex means bulging towards the mating body (out of the material), so
        the rail crown has curvature +1/300 (60E1) and the S1002 flange root
        (an R13 fillet) -1/13.
        """
        return self._apply(y, "curvature")

    def cropped(self, y_start_mm: float, y_end_mm: float) -> "Profile":
        """The same profile over [y_start_mm, y_end_mm] only (inside its range): its sections cut there."""
        from dataclasses import replace

        lo, hi = self.y_range_mm
        a, b = max(float(y_start_mm), lo), min(float(y_end_mm), hi)
        if not a < b:
            raise ValueError(f"cannot crop profile {self.name} to [{y_start_mm:g}, {y_end_mm:g}] mm: it spans "
                             f"[{lo:g}, {hi:g}] mm")
        sections = tuple(replace(s, y_start_mm=max(s.y_start_mm, a), y_end_mm=min(s.y_end_mm, b))
                         for s in self.sections if s.y_end_mm > a and s.y_start_mm < b)
        return replace(self, sections=sections)

    def points(self, step_mm: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
        """Points along the profile spaced about `step_mm` apart in arc length.

        Section ends are always included, so the sampled curve passes through
        every joint.

        Returns
        -------
        y_mm, z_mm : ndarray
            Coordinates in the profile's own standard system, y increasing.
        """
        step = check_range("step_mm", step_mm, 1e-3, 50.0, low_open=False, high_open=False)
        ys = [self.sections[0].sample(step)[:1]]
        for sec in self.sections:
            ys.append(sec.sample(step)[1:])
        y = np.concatenate(ys)
        return y, self.z(y)

    def joints(self) -> list[Joint]:
        """Value, slope and tangent-angle mismatches at every joint between sections."""
        out = []
        for a, b in zip(self.sections[:-1], self.sections[1:]):
            y = b.y_start_mm
            za, zb = float(a.evaluate(y, 0)), float(b.evaluate(y, 0))
            sa, sb = float(a.evaluate(y, 1)), float(b.evaluate(y, 1))
            out.append(Joint(y_mm=y, left=a.label, right=b.label, z_mismatch_mm=zb - za,
                             slope_mismatch=sb - sa, angle_mismatch_rad=math.atan(sb) - math.atan(sa)))
        return out


# --------------------------------------------------------------------------
# S1002 wheel (UIC 510-2 Appendix B, EN 13715)
# --------------------------------------------------------------------------

# Bounds of the sections, from the flange back (y = -70, the inner face) to
# the outer face (y = +60).
_S1002_BOUNDS = (-70.0, -62.764705882, -49.662510381, -39.764473993,
                 -38.426669071, -35.0, -26.0, 32.15796, 60.0)

# Section B (tread): F = -BB y + CB y^2 - DB y^3 + EB y^4 - FB y^5 + GB y^6 - HB y^7 + IB y^8.
_S1002_B = (0.0, -3.358537058e-02, 1.565681624e-03, -2.810427944e-05, 5.844240864e-08,
            -1.562379023e-08, 5.309217349e-15, -5.957839843e-12, 2.646656573e-13)
# Section C (flange root transition): F = -(AC + BC y + ... + HC y^7).
_S1002_C = (-4.320221063e+03, -1.038384026e+03, -1.065501873e+02, -6.051367875,
            -2.054332446e-01, -4.169739389e-03, -4.687195829e-05, -2.252755540e-07)


def s1002_wheel() -> Profile:
    """The S1002 wheel profile (UIC 510-2 / EN 13715), y in [-70, 60] mm.

    Sections (y increasing): H flange back (arc R20.5), G flange tip (arc R12,
    top at y = -55, z = 28), F flange face (arc R20), E flange face (straight,
    about 70 deg), D flange root (concave arc R13), C transition polynomial,
    B tread polynomial (through the tape circle y = 0, z = 0), A outer cone 1:15.
    """
    b = _S1002_BOUNDS
    sections = (
        ArcSection("H flange back R20.5", b[0], b[1], -49.5, 9.519259302, 20.5, convex=True),
        ArcSection("G flange tip R12", b[1], b[2], -55.0, 16.0, 12.0, convex=True),
        ArcSection("F flange face R20", b[2], b[3], -58.558326413, 8.834924130, 20.0, convex=True),
        PolynomialSection("E flange face line", b[3], b[4], (-93.576667419, -2.747477419)),
        ArcSection("D flange root R13", b[4], b[5], -26.210665, 16.446, 13.0, convex=False),
        PolynomialSection("C flange root polynomial", b[5], b[6], _S1002_C),
        PolynomialSection("B tread polynomial", b[6], b[7], _S1002_B),
        PolynomialSection("A outer cone 1:15", b[7], b[8], (1.364323640, -0.066666667)),
    )
    return Profile("S1002", "wheel", sections,
                   source="UIC 510-2 (2004) Appendix B / EN 13715 profile S1002, sections A-H")


def sphere_wheel(radius_mm: float, half_width_mm: float | None = None) -> Profile:
    """A sphere of radius `radius_mm` as a wheel profile: an arc of that radius about the axle, over
    ``|y| <= half_width_mm`` (default: 50 mm, or half the radius if that is less).

    With ``nominal_radius_mm = radius_mm`` the wheel's rolling radius at ``y`` is ``sqrt(R^2 - y^2)``, so
    the wheel is the sphere itself; on `flat_rail` without cant the wheel-rail model solves
    sphere-on-flat (`bench/verification.py` compares it with
    `filmcal.wheelrail.halfspace.sphere_on_flat_contact`).
    """
    radius = check_positive("radius_mm", radius_mm)
    half = check_range("half_width_mm", min(50.0, 0.5 * radius) if half_width_mm is None else half_width_mm,
                       0.0, radius)
    return Profile(f"sphere R{radius:g}", "wheel", (ArcSection("sphere", -half, half, 0.0, -radius, radius),),
                   source=f"a sphere of radius {radius:g} mm")


def flat_rail(half_width_mm: float = 30.0) -> Profile:
    """A flat rail head, z = 0 over ``|y| <= half_width_mm`` (narrower than the wheel profile it carries)."""
    half = check_positive("half_width_mm", half_width_mm)
    return Profile("flat", "rail", (PolynomialSection("flat", -half, half, (0.0,)),), source="a flat plane")


# --------------------------------------------------------------------------
# Rails (EN 13674-1)
# --------------------------------------------------------------------------

def _normal(angle: float) -> np.ndarray:
    """Outward unit normal of a rail head arc at `angle` from the vertical (towards +y)."""
    return np.array([math.sin(angle), math.cos(angle)])


def rail_head(name: str, radii_mm: tuple[float, ...], tangent_widths_mm: tuple[float, ...],
              flank_inclination: float = 1.0 / 20.0,
              flank_end_depth_mm: float = RAIL_FLANK_END_DEPTH_MM, source: str = "") -> Profile:
    """A symmetric rail head made of tangent circular arcs and straight flanks.

    Parameters
    ----------
    name : str
        Profile name.
    radii_mm : tuple of float
        Arc radii from the crown (first) to the gauge corner (last).
    tangent_widths_mm : tuple of float
        Horizontal distance between the two symmetric tangent points where arc
        i meets arc i+1 (one value fewer than `radii_mm`), as dimensioned in
        EN 13674-1.
    flank_inclination : float
        The flank widens downwards by this much per unit depth (1:20).
    flank_end_depth_mm : float
        Depth below the crown top where the modelled flanks end.
    source : str
        Reference of the definition.

    Returns
    -------
    Profile
        Rail profile, y from gauge flank (< 0) to field flank (> 0), z = 0 at
        the crown top. Each arc centre lies on the common normal at its tangent
        point, so value and slope are continuous by construction; the last arc
        ends where its tangent has the flank inclination.
    """
    if len(radii_mm) < 1 or len(tangent_widths_mm) != len(radii_mm) - 1:
        raise ValueError("tangent_widths_mm needs one value fewer than radii_mm (at least one radius)")
    radii_mm = tuple(check_positive("radii_mm", r) for r in radii_mm)
    tangent_widths_mm = tuple(check_positive("tangent_widths_mm", w) for w in tangent_widths_mm)
    flank_inclination = check_positive("flank_inclination", flank_inclination)
    # Field side (y > 0): arcs as (radius, centre, start angle, end angle), the
    # angles of the outward normal measured from the vertical.
    arcs: list[tuple[float, np.ndarray, float, float]] = []
    centre = np.array([0.0, -radii_mm[0]])
    start_angle = 0.0
    for i, radius in enumerate(radii_mm):
        if i < len(tangent_widths_mm):
            reach = (tangent_widths_mm[i] / 2.0 - centre[0]) / radius
            if not -1.0 < reach < 1.0:
                raise ValueError(f"rail {name}: tangent width {tangent_widths_mm[i]:g} mm lies beyond "
                                 f"the arc of radius {radius:g} mm")
            end_angle = math.asin(reach)
        else:
            end_angle = math.atan2(1.0, flank_inclination)  # tangent along (inclination, -1)
        if not end_angle > start_angle:
            raise ValueError(f"rail {name}: tangent widths are not increasing along the head")
        arcs.append((radius, centre, start_angle, end_angle))
        if i + 1 < len(radii_mm):
            centre = centre + (radius - radii_mm[i + 1]) * _normal(end_angle)
        start_angle = end_angle
    radius, centre, _, end_angle = arcs[-1]
    flank_y, flank_z = centre + radius * _normal(end_angle)
    flank_depth = -float(flank_z)
    if not flank_end_depth_mm > flank_depth:
        raise ValueError(f"flank_end_depth_mm must exceed the flank top depth {flank_depth:.3f} mm")
    field: list[ProfileSection] = []
    for radius, c, a0, a1 in arcs[1:]:
        field.append(ArcSection(f"field R{radius:g}", float(c[0] + radius * math.sin(a0)),
                                float(c[0] + radius * math.sin(a1)), float(c[0]), float(c[1]), radius))
    slope = -1.0 / flank_inclination
    flank_end_y = float(flank_y) + flank_inclination * (flank_end_depth_mm - flank_depth)
    field.append(PolynomialSection(f"field flank 1:{1.0 / flank_inclination:g}", float(flank_y), flank_end_y,
                                   (float(flank_z) - slope * float(flank_y), slope)))
    crown_half = radii_mm[0] * math.sin(arcs[0][3])
    crown = ArcSection(f"crown R{radii_mm[0]:g}", -crown_half, crown_half, 0.0, -radii_mm[0], radii_mm[0])
    gauge = [_mirror(sec) for sec in reversed(field)]
    return Profile(name, "rail", tuple(gauge) + (crown,) + tuple(field), source=source,
                   flank_depth_mm=flank_depth)


def _mirror(sec: ProfileSection) -> ProfileSection:
    """A field-side section reflected about y = 0 onto the gauge side."""
    label = sec.label.replace("field", "gauge", 1)
    if isinstance(sec, ArcSection):
        return ArcSection(label, -sec.y_end_mm, -sec.y_start_mm, -sec.centre_y_mm, sec.centre_z_mm,
                          sec.radius_mm, sec.convex)
    c = np.asarray(sec.coefficients, dtype=float) * (-1.0) ** np.arange(len(sec.coefficients))
    return PolynomialSection(label, -sec.y_end_mm, -sec.y_start_mm, tuple(float(v) for v in c))


def rail_60e1() -> Profile:
    """60E1 rail head (EN 13674-1; formerly UIC 60): R300, R80, R13, flanks 1:20."""
    return rail_head("60E1", (300.0, 80.0, 13.0), (20.456, 52.053),
                     source="EN 13674-1 Annex A, 60E1: R300 | 20.456 | R80 | 52.053 | R13, flanks 1:20")


def rail_60e2() -> Profile:
    """60E2 rail head (EN 13674-1): R200, R70, R16, R8, flanks 1:20."""
    return rail_head("60E2", (200.0, 70.0, 16.0, 8.0), (23.778, 48.913, 70.774),
                     source="EN 13674-1 Annex A, 60E2: R200 | 23.778 | R70 | 48.913 | R16 | 70.774 | R8, "
                            "flanks 1:20")


_BUILDERS = {"S1002": s1002_wheel, "60E1": rail_60e1, "60E2": rail_60e2}
PROFILE_NAMES = tuple(_BUILDERS)


def get_profile(name: str) -> Profile:
    """The standard profile called `name` (one of PROFILE_NAMES; case-insensitive)."""
    key = {k.upper(): k for k in _BUILDERS}.get(str(name).strip().upper())
    if key is None:
        raise ValueError(f"unknown profile {name!r}; known profiles: {', '.join(PROFILE_NAMES)}")
    return _BUILDERS[key]()


# --------------------------------------------------------------------------
# Custom profiles from CSV
# --------------------------------------------------------------------------

_MIN_CSV_POINTS = 6
_COLUMN_NAMES = (("y_mm", "z_mm"), ("y", "z"))


def _read_csv_points(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Read columns y_mm,z_mm (or y,z) from `path`, checking every value."""
    with open(path, newline="", encoding="utf-8-sig") as fh:
        rows = [(n, row) for n, row in enumerate(csv.reader(fh), start=1)
                if row and any(c.strip() for c in row) and not row[0].lstrip().startswith("#")]
    if not rows:
        raise ValueError(f"{path}: empty file, expected a header y_mm,z_mm and points")
    header_line, header = rows[0]
    names = [c.strip().lower() for c in header]
    cols = None
    for yname, zname in _COLUMN_NAMES:
        if yname in names and zname in names:
            cols = names.index(yname), names.index(zname)
            break
    if cols is None:
        raise ValueError(f"{path}: line {header_line}: header must name the columns y_mm,z_mm "
                         f"(or y,z), got {','.join(header)!r}")
    y, z = [], []
    for n, row in rows[1:]:
        if len(row) <= max(cols):
            raise ValueError(f"{path}: line {n}: expected {len(names)} columns, got {len(row)}")
        for col, target in zip(cols, (y, z)):
            text = row[col].strip()
            try:
                value = plain_float(text)
            except ValueError:
                raise ValueError(f"{path}: line {n}: {names[col]} value {text!r} is not a number") from None
            if not math.isfinite(value):
                raise ValueError(f"{path}: line {n}: {names[col]} value {text!r} is not finite")
            target.append(value)
    if len(y) < _MIN_CSV_POINTS:
        raise ValueError(f"{path}: needs at least {_MIN_CSV_POINTS} points, got {len(y)}")
    return np.array(y), np.array(z)


#: How far from its origin a profile's points may lie (mm): the widest wheel profile spans about 140 mm and the
#: deepest rail about 180 mm, so a larger value is a unit or column error.
PROFILE_EXTENT_MM = 1000.0
#: The narrowest a profile may be across (mm): a contact patch is 10-20 mm wide and the solver needs the
#: profile around it, so a narrower file is a partial scan or a profile in metres.
PROFILE_MIN_SPAN_MM = 10.0


def load_profile_csv(path: str | Path, kind: str = "rail", name: str | None = None,
                     smoothing: float | None = None) -> Profile:
    """A profile from a CSV file with columns y_mm,z_mm (or y,z), smoothed by a cubic spline.

    The points must be in the standard coordinates of the module docstring and
    y must be strictly monotone (the profile is a single-valued z(y); points
    given with y decreasing are reversed). The curve is a cubic smoothing
    spline (`scipy.interpolate.make_smoothing_spline`) so that slope and
    curvature are smooth enough for local Hertz checks.

    Parameters
    ----------
    path : str or Path
        CSV file; a header row naming the columns, then one point per row.
        Blank lines and lines starting with "#" are skipped.
    kind : {"wheel", "rail"}
        Which body the profile belongs to.
    name : str, optional
        Profile name; the file stem by default.
    smoothing : float, optional
        Smoothing parameter lambda >= 0 (mm^3 scale of the roughness penalty);
        chosen by generalised cross-validation when None.

    Returns
    -------
    Profile

    Raises
    ------
    FileNotFoundError
        If `path` does not exist.
    ValueError
        If the file is malformed (naming the file, the line and the problem).
    """
    check_choice("kind", kind, PROFILE_KINDS)
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"profile file not found: {path}")
    y, z = _read_csv_points(path)
    for label, values in (("y_mm", y), ("z_mm", z)):
        worst = float(np.max(np.abs(values)))
        if worst > PROFILE_EXTENT_MM:
            raise ValueError(f"{path}: {label} reaches {worst:g} mm; a wheel or rail profile lies within "
                             f"{PROFILE_EXTENT_MM:g} mm of its origin (check the units and the column order)")
    dy = np.diff(y)
    if np.all(dy < 0):
        y, z = y[::-1], z[::-1]
    elif not np.all(dy > 0):
        bad = int(np.argmax(dy <= 0) if dy[0] > 0 else np.argmax(dy >= 0))
        raise ValueError(f"{path}: y must be strictly monotone; it stops being so at point {bad + 2} "
                         f"(y = {y[bad + 1]:g} after {y[bad]:g})")
    span = float(np.ptp(y))
    if span < PROFILE_MIN_SPAN_MM:
        raise ValueError(f"{path}: the points span {span:.3g} mm across; a wheel or rail profile spans at least "
                         f"{PROFILE_MIN_SPAN_MM:g} mm in millimetres (give y_mm and z_mm in mm, not m)")
    lam = None if smoothing is None else check_range("smoothing", smoothing, 0.0, math.inf, low_open=False)
    from scipy.interpolate import make_smoothing_spline  # imported here: the CLI starts faster

    given = len(y)
    y, z = _binned(y, z, MAX_PROFILE_POINTS)
    spline = make_smoothing_spline(y, z, lam=lam)
    label = name or path.stem
    through = (f"{given} points" if given == len(y)
               else f"{len(y)} bin means of {given} points (bins {(y[-1] - y[0]) / len(y) * 1e3:.2g} um wide)")
    return Profile(label, kind, (SplineSection("spline", float(y[0]), float(y[-1]), spline),),
                   source=f"smoothing spline through {through} of {path.name}")


#: The most points a measured profile's spline is fitted through: a denser profile (an optical scanner's
#: 10^6 points) is averaged in bins of equal width in y first. 20 000 points over a 140 mm wheel are 7 um
#: apart, finer than the contact's sub-millimetre features need, and keep the spline's cross-validation to
#: about a second (10^6 points took 20 s and ended ill-posed).
MAX_PROFILE_POINTS = 20_000


def _binned(y: np.ndarray, z: np.ndarray, n_max: int) -> tuple[np.ndarray, np.ndarray]:
    """(y, z) unchanged if at most `n_max` points, else the means of y and z in `n_max` equal-width y bins
    (empty bins dropped); y stays strictly increasing."""
    if len(y) <= n_max:
        return y, z
    edges = np.linspace(y[0], y[-1], n_max + 1)
    index = np.clip(np.searchsorted(edges, y, side="right") - 1, 0, n_max - 1)
    counts = np.bincount(index, minlength=n_max)
    keep = counts > 0
    y_mean = np.bincount(index, weights=y, minlength=n_max)[keep] / counts[keep]
    z_mean = np.bincount(index, weights=z, minlength=n_max)[keep] / counts[keep]
    return y_mean, z_mean


# --------------------------------------------------------------------------
# Checked dimensions
# --------------------------------------------------------------------------

def _require_kind(profile: Profile, kind: str) -> None:
    if profile.kind != kind:
        raise ValueError(f"profile {profile.name} is a {profile.kind} profile, expected a {kind} profile")


def _flange_tip(wheel: Profile) -> tuple[float, float]:
    """(y, z) of the flange tip: the highest z on the flange side (y < 0)."""
    lo, _ = wheel.y_range_mm
    if lo >= 0:
        raise ValueError(f"wheel profile {wheel.name} has no flange side (y < 0)")
    y = np.linspace(lo, 0.0, 4001)
    i = int(np.argmax(wheel.z(y)))
    a, b = y[max(i - 1, 0)], y[min(i + 1, len(y) - 1)]
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(lambda t: -wheel.z(t), bounds=(a, b), method="bounded",
                          options={"xatol": 1e-10})
    return float(res.x), float(-res.fun)


def flange_height_mm(wheel: Profile) -> float:
    """Flange height: from the tread datum (z at the tape circle, y = 0) to the flange tip (mm)."""
    _require_kind(wheel, "wheel")
    return _flange_tip(wheel)[1] - wheel.z(0.0)


def flange_thickness_mm(wheel: Profile, height_mm: float = FLANGE_THICKNESS_HEIGHT_MM) -> float:
    """Flange thickness (EN 13715): inner face to flange face, `height_mm` from the tread datum.

    The flange face point is where the profile, between the flange tip and the
    tape circle, lies `height_mm` from the tread datum towards the flange tip;
    the inner face is the plane y = INNER_FACE_Y_MM (70 mm from the tape circle).
    """
    _require_kind(wheel, "wheel")
    y_tip, z_tip = _flange_tip(wheel)
    target = wheel.z(0.0) + as_finite("height_mm", height_mm)
    if not wheel.z(0.0) < target < z_tip:
        raise ValueError(f"height_mm must lie between the tread datum and the flange tip, got {height_mm:g}")
    from scipy.optimize import brentq

    y_face = brentq(lambda t: wheel.z(t) - target, y_tip, 0.0, xtol=1e-12)
    return y_face - INNER_FACE_Y_MM


def head_width_mm(rail: Profile, depth_mm: float | None = None) -> float:
    """Rail head width: horizontal distance between the two flanks `depth_mm` below the crown top.

    By default the depth is where the straight flanks begin for a standard rail
    (the head width dimensioned in EN 13674-1), or GAUGE_DEPTH_MM for a rail
    read from a file.
    """
    _require_kind(rail, "rail")
    if depth_mm is None:
        depth_mm = rail.flank_depth_mm if rail.flank_depth_mm is not None else GAUGE_DEPTH_MM
    lo, hi = rail.y_range_mm
    top = rail.z(0.0)
    depth = check_range("depth_mm", depth_mm, 0.0, top - max(rail.z(lo), rail.z(hi)))
    target = top - depth
    from scipy.optimize import brentq

    left = brentq(lambda t: rail.z(t) - target, lo, 0.0, xtol=1e-12)
    right = brentq(lambda t: rail.z(t) - target, 0.0, hi, xtol=1e-12)
    return right - left


def profile_dimensions(profile: Profile) -> dict[str, Any]:
    """The checked dimensions of a profile, as a dict of plain floats.

    Wheels: flange_height_mm, flange_thickness_mm (at 10 mm). Rails:
    head_width_mm and the depth where it is measured, head width at the
    14 mm gauge depth, crown_radius_mm (1 / curvature at y = 0). A dimension
    that a measured profile does not reach (a partial rail head shallower
    than the gauge depth, a wheel without its flange) is None, and
    ``"not_reached"`` says why.
    """
    not_reached: list[str] = []
    if profile.kind == "wheel":
        lo, _ = profile.y_range_mm
        if lo >= 0:
            not_reached.append(f"the flange: the profile starts at y = {lo:g} mm, on the tread")
            return {"flange_height_mm": None, "flange_thickness_mm": None,
                    "flange_thickness_height_mm": FLANGE_THICKNESS_HEIGHT_MM, "not_reached": not_reached}
        height = flange_height_mm(profile)
        thickness = None
        if height > FLANGE_THICKNESS_HEIGHT_MM:
            thickness = flange_thickness_mm(profile)
        else:
            not_reached.append(f"the flange thickness {FLANGE_THICKNESS_HEIGHT_MM:g} mm above the tread "
                               f"datum: the flange is {height:.3g} mm high")
        return {"flange_height_mm": height, "flange_thickness_mm": thickness,
                "flange_thickness_height_mm": FLANGE_THICKNESS_HEIGHT_MM, "not_reached": not_reached}
    lo, hi = profile.y_range_mm
    reach = profile.z(0.0) - max(profile.z(lo), profile.z(hi)) if lo < 0 < hi else 0.0
    depth = profile.flank_depth_mm if profile.flank_depth_mm is not None else GAUGE_DEPTH_MM

    def width_at(d: float) -> float | None:
        if d < reach:
            return head_width_mm(profile, d)
        not_reached.append(f"the head width {d:g} mm below the crown top: both sides of the profile "
                           f"reach only {max(reach, 0.0):.3g} mm below it")
        return None

    width = width_at(depth)
    crown_radius = None
    curvature = profile.curvature(0.0) if lo < 0 < hi else 0.0
    if abs(curvature) > 1e-9:
        crown_radius = 1.0 / curvature
    else:
        not_reached.append("the crown radius: the profile is straight at y = 0" if lo < 0 < hi
                           else "the crown radius: the profile does not reach y = 0")
    return {"head_width_mm": width,
            "head_width_depth_mm": depth,
            "head_width_at_gauge_depth_mm": width if depth == GAUGE_DEPTH_MM else width_at(GAUGE_DEPTH_MM),
            "crown_radius_mm": crown_radius,
            "not_reached": not_reached}
