"""A wheel profile placed over an inclined rail: undeformed gap and contact points.

Track frame (all lengths in mm)
-------------------------------
* origin at the top of the rail crown (the origin of the rail profile, about
  which the rail is inclined);
* ``y`` lateral, positive towards the field side (away from the track
  centre), so the gauge side, where the wheel flange runs, is y < 0;
* ``z`` vertical, upwards;
* ``x`` along the rail (rolling direction).

The rail is inclined by ``rail_inclination`` (1:40) towards the track centre:
its profile is rotated about its origin so that its symmetry axis leans to
the gauge side, ``(y, z)_track = R(theta) (y, z)_rail`` with
``theta = atan(rail_inclination)``.

The wheel is not rotated (horizontal axle). Its profile is shifted laterally
by the offset ``eta = offset_mm`` (the convention of the film-calibration
paper, Fig. 5): eta = 0 when the tape circle lies in the rail's inclined
symmetry plane at the crown; eta > 0 moves the wheel towards the field side,
so its flange approaches the rail's gauge corner. A track point y lies at
``y - eta`` in wheel coordinates, and the wheel surface is
``z = h - z_wheel(y - eta)`` where ``h`` (``tape_circle_height_mm``) is the
height of the tape-circle datum, chosen so that the two profiles touch
without overlapping.

Undeformed gap
--------------
``separation(y)`` is the vertical distance from the rail surface up to the
wheel surface across the lateral overlap of the two profiles (>= 0, zero at
the contact point). The wheel is a body of revolution of rolling radius
``r(y) = nominal_radius_mm + z_wheel(y - eta)`` and the rail is straight in x,
so the 3D gap of the contact plane is

    g(x, y) = separation(y) + r(y) - sqrt(r(y)^2 - x^2)
            = separation(y) + x^2 / (2 r(y)) + O(x^4 / r^3).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import minimize_scalar

from filmcal.wheelrail.settings import NOMINAL_RADIUS_MM, RAIL, RAIL_INCLINATION, WHEEL
from filmcal._validation import as_finite, check_positive, check_range
from filmcal.wheelrail.profiles import Profile, get_profile

__all__ = ["ContactPoint", "WheelRailPlacement", "place_wheel_on_rail", "offset_range_mm"]

_NEWTON_TOL_MM = 1e-12


@dataclass(frozen=True)
class ContactPoint:
    """A point where the undeformed wheel and rail profiles touch or nearly touch.

    Attributes
    ----------
    y_mm, z_mm : float
        Position on the rail surface in the track frame.
    y_wheel_mm, y_rail_mm : float
        The same point in the wheel's and the rail's own profile coordinates.
    separation_mm : float
        Undeformed vertical gap there (0 for the first contact).
    rolling_radius_mm : float
        Wheel rolling radius at this point.
    contact_angle_rad : float
        Inclination of the common tangent in the track frame, positive when
        the surfaces rise towards the field side (as at the gauge corner and on
        the flange).
    wheel_curvature_per_mm, rail_curvature_per_mm : float
        Lateral curvatures (1/radius), convex positive, so their sum is the
        relative lateral curvature of the contact.
    """

    y_mm: float
    z_mm: float
    y_wheel_mm: float
    y_rail_mm: float
    separation_mm: float
    rolling_radius_mm: float
    contact_angle_rad: float
    wheel_curvature_per_mm: float
    rail_curvature_per_mm: float


def offset_range_mm(wheel: Profile, rail: Profile, rail_inclination: float = RAIL_INCLINATION) -> tuple[float, float]:
    """Offsets eta for which the wheel profile spans the whole (inclined) rail profile laterally.

    Returns
    -------
    (low, high) : tuple of float
        Allowed range of `offset_mm` (mm) for `place_wheel_on_rail`.
    """
    incl = check_range("rail_inclination", rail_inclination, 0.0, 0.2, low_open=False, high_open=False)
    c, s = _cos_sin(incl)
    rail = _single_valued(rail, incl)
    ylo, yhi = rail.y_range_mm
    rail_lo = ylo * c - rail.z(ylo) * s
    rail_hi = yhi * c - rail.z(yhi) * s
    wlo, whi = wheel.y_range_mm
    return rail_hi - whi, rail_lo - wlo


def _cos_sin(inclination: float) -> tuple[float, float]:
    theta = math.atan(inclination)
    return math.cos(theta), math.sin(theta)


@dataclass(frozen=True)
class WheelRailPlacement:
    """Wheel and rail profiles in one track frame at a lateral offset (see module docstring).

    Build it with `place_wheel_on_rail`. The fields describe the configuration
    and the first contact; the methods evaluate the gap anywhere in the
    lateral overlap ``y_range_mm``.
    """

    wheel: Profile
    rail: Profile
    offset_mm: float
    rail_inclination: float
    nominal_radius_mm: float
    tape_circle_height_mm: float
    y_range_mm: tuple[float, float]
    contact_points: tuple[ContactPoint, ...]
    tolerance_mm: float

    @property
    def contact(self) -> ContactPoint:
        """The first contact point (global minimum of the separation)."""
        return self.contact_points[0]

    # -- coordinate maps -------------------------------------------------
    def _check_y(self, y) -> np.ndarray:
        arr = np.asarray(y, dtype=float)
        lo, hi = self.y_range_mm
        if not np.all(np.isfinite(arr)) or np.any(arr < lo - 1e-9) or np.any(arr > hi + 1e-9):
            raise ValueError(f"y_mm must lie in the profile overlap [{lo:.4f}, {hi:.4f}] mm")
        return np.clip(arr, lo, hi)

    def wheel_y(self, y):
        """Wheel profile coordinate of track position(s) y."""
        return _scalar(self._check_y(y) - self.offset_mm)

    def rail_y(self, y):
        """Rail profile coordinate of track position(s) y (inverts the inclination)."""
        return _scalar(_rail_own_y(self.rail, self.rail_inclination, self._check_y(y)))

    def wheel_curvature(self, y):
        """Lateral curvature of the wheel at track position(s) y (1/mm, convex positive)."""
        return self.wheel.curvature(self.wheel_y(y))

    def rail_curvature(self, y):
        """Lateral curvature of the rail at track position(s) y (1/mm, convex positive)."""
        return self.rail.curvature(self.rail_y(y))

    # -- surfaces in the track frame ------------------------------------
    def rail_height(self, y):
        """Height z of the rail surface at track position(s) y (mm)."""
        c, s = _cos_sin(self.rail_inclination)
        u = np.asarray(self.rail_y(y))
        return _scalar(u * s + np.asarray(self.rail.z(u)) * c)

    def wheel_height(self, y):
        """Height z of the undeformed wheel surface at track position(s) y (mm)."""
        return _scalar(self.tape_circle_height_mm - np.asarray(self.wheel.z(self.wheel_y(y))))

    def separation(self, y):
        """Undeformed vertical gap between wheel and rail at track position(s) y (mm, >= 0)."""
        return _scalar(np.asarray(self.wheel_height(y)) - np.asarray(self.rail_height(y)))

    def rolling_radius(self, y):
        """Wheel rolling radius r(y) = nominal radius + wheel profile height (mm)."""
        return _scalar(self.nominal_radius_mm + np.asarray(self.wheel.z(self.wheel_y(y))))

    def gap(self, x, y):
        """3D undeformed gap g(x, y) = separation(y) + r(y) - sqrt(r(y)^2 - x^2) (mm).

        Parameters
        ----------
        x : float or array
            Longitudinal position from the contact plane (mm), |x| < r(y).
        y : float or array
            Track lateral position (mm) inside ``y_range_mm``; broadcast with x.
        """
        xa, ya = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
        r = np.asarray(self.rolling_radius(ya))
        if not np.all(np.isfinite(xa)) or np.any(np.abs(xa) >= r):
            raise ValueError("x_mm must be finite and smaller in magnitude than the rolling radius")
        return _scalar(np.asarray(self.separation(ya)) + r - np.sqrt(r**2 - xa**2))

    def rail_points(self, step_mm: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
        """The inclined rail profile sampled in the track frame (y, z)."""
        c, s = _cos_sin(self.rail_inclination)
        u, v = self.rail.points(step_mm)
        return u * c - v * s, u * s + v * c

    def wheel_points(self, step_mm: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
        """The wheel profile sampled in the track frame (y, z)."""
        u, v = self.wheel.points(step_mm)
        return u + self.offset_mm, self.tape_circle_height_mm - v


def _scalar(a):
    a = np.asarray(a)
    return float(a) if a.ndim == 0 else a


def _rail_own_y(rail: Profile, inclination: float, y: np.ndarray) -> np.ndarray:
    """Solve u cos(theta) - z_rail(u) sin(theta) = y for the rail coordinate u (Newton)."""
    c, s = _cos_sin(inclination)
    lo, hi = rail.y_range_mm
    u = np.clip(np.asarray(y, dtype=float) / c, lo, hi)
    for _ in range(60):
        f = u * c - np.asarray(rail.z(u)) * s - y
        df = c - np.asarray(rail.slope(u)) * s
        step = f / df
        u = np.clip(u - step, lo, hi)
        if np.all(np.abs(step) < _NEWTON_TOL_MM):
            break
    residual = u * c - np.asarray(rail.z(u)) * s - y
    if np.any(np.abs(residual) > 1e-8):
        raise ValueError("y_mm lies outside the inclined rail profile")
    return u


#: Steepest tangent of the inclined rail kept (deg): a wheel touches the rail up to the flange's contact angle
#: (about 70 deg on S1002), never a flank below the head. Applied only to a rail that would overhang (60E1 and
#: 60E2 from a cant of 1/20); at the default 1/40 their flanks stand at 88.6 deg and are kept whole.
MAX_RAIL_ANGLE_DEG = 89.0


def _single_valued(rail: Profile, inclination: float) -> Profile:
    """The inclined rail as a function z(y): where a flank would overhang, cut where it turns steeper than
    `MAX_RAIL_ANGLE_DEG`.

    A rail head's flanks lean about 1:20 from the vertical (60E1, 60E2), so that a cant of 1/20 turns the field
    flank vertical; that part lies below the head, where no wheel reaches. The cut keeps the stretch around the
    crown's top; a profile that stays single-valued is returned whole.
    """
    c, s = _cos_sin(inclination)
    u, _ = rail.points(0.1)
    slope = np.asarray(rail.slope(u), dtype=float)
    # the inclined tangent's angle to the track plane: atan(slope) + theta (the rail leans towards the centre)
    angle = np.degrees(np.abs(np.arctan(slope) + math.atan(inclination)))
    overhang = c - slope * s <= 0
    if not overhang.any():  # single-valued as it is: kept whole (at the default cant, and wherever it was solved)
        return rail
    steep = (angle > MAX_RAIL_ANGLE_DEG) | overhang
    top = int(np.argmax(np.asarray(rail.z(u)) * c + u * s))
    if steep[top]:
        raise ValueError(f"rail_inclination {inclination:g} tilts the crown of rail {rail.name} past "
                         f"{MAX_RAIL_ANGLE_DEG:g} deg; the inclined profile is not single-valued")
    left = np.flatnonzero(steep[:top])
    right = np.flatnonzero(steep[top:]) + top
    lo = u[left[-1] + 1] if left.size else u[0]
    hi = u[right[0] - 1] if right.size else u[-1]
    return rail.cropped(lo, hi)


def _resolve(profile: Profile | str, kind: str) -> Profile:
    p = get_profile(profile) if isinstance(profile, str) else profile
    if not isinstance(p, Profile) or p.kind != kind:
        raise ValueError(f"{kind} must be a {kind} profile or the name of one")
    return p


def place_wheel_on_rail(wheel: Profile | str = WHEEL, rail: Profile | str = RAIL,
                        offset_mm: float = 0.0, rail_inclination: float = RAIL_INCLINATION,
                        nominal_radius_mm: float = NOMINAL_RADIUS_MM, tolerance_mm: float = 0.1,
                        resolution_mm: float = 0.01) -> WheelRailPlacement:
    """Place the wheel over the inclined rail at lateral offset eta and find the contact points.

    Parameters
    ----------
    wheel, rail : Profile or str
        Profiles or standard names ("S1002"; "60E1", "60E2").
    offset_mm : float
        Lateral offset eta (paper convention, see module docstring).
    rail_inclination : float
        Rail cant as a slope (1/40); the rail leans towards the track centre.
    nominal_radius_mm : float
        Wheel rolling radius at the tape circle (460 mm).
    tolerance_mm : float
        Local minima of the separation up to this gap are reported as further
        contact points (e.g. the flange near flange contact).
    resolution_mm : float
        Lateral grid spacing of the search; each minimum is then refined.

    Returns
    -------
    WheelRailPlacement

    Raises
    ------
    ValueError
        If the offset leaves part of the rail uncovered by the wheel profile
        or puts the first contact at the edge of a profile (the message names
        offset_mm and the allowed range), or for an invalid parameter.
    """
    w = _resolve(wheel, "wheel")
    r = _resolve(rail, "rail")
    eta = as_finite("offset_mm", offset_mm)
    incl = check_range("rail_inclination", rail_inclination, 0.0, 0.2, low_open=False, high_open=False)
    r0 = check_positive("nominal_radius_mm", nominal_radius_mm)
    tol = check_range("tolerance_mm", tolerance_mm, 0.0, math.inf, low_open=False)
    res = check_range("resolution_mm", resolution_mm, 1e-4, 1.0, low_open=False, high_open=False)
    r = _single_valued(r, incl)
    if r0 + min(np.asarray(w.z(w.points(0.5)[0]))) <= 0:
        raise ValueError(f"nominal_radius_mm {r0:g} is too small for the depth of wheel profile {w.name}")
    lo_eta, hi_eta = offset_range_mm(w, r, incl)
    if lo_eta > hi_eta:
        (wlo, whi), (rlo, rhi) = w.y_range_mm, r.y_range_mm
        raise ValueError(f"the wheel profile {w.name} ({whi - wlo:.1f} mm wide) cannot cover the rail profile "
                         f"{r.name} ({rhi - rlo:.1f} mm wide) at any offset: give a wheel profile that spans the "
                         "rail head, or a rail profile cut to its head")
    allowed = f"offset_mm must lie in [{lo_eta:.2f}, {hi_eta:.2f}] mm for {w.name} on {r.name}"
    if not lo_eta <= eta <= hi_eta:
        raise ValueError(f"{allowed}, got {eta:g}")
    c, s = _cos_sin(incl)
    ylo, yhi = r.y_range_mm
    overlap = (max(ylo * c - r.z(ylo) * s, w.y_range_mm[0] + eta),
               min(yhi * c - r.z(yhi) * s, w.y_range_mm[1] + eta))

    def lift(y):
        """Height the tape-circle datum needs so the wheel clears the rail at y."""
        u = _rail_own_y(r, incl, np.asarray(y, dtype=float))
        return np.asarray(w.z(np.asarray(y) - eta)) + u * s + np.asarray(r.z(u)) * c

    n = max(3, math.ceil((overlap[1] - overlap[0]) / res) + 1)
    grid = np.linspace(overlap[0], overlap[1], n)
    d = lift(grid)
    if int(np.argmax(d)) in (0, n - 1):
        raise ValueError(f"offset_mm {eta:g}: {w.name} and {r.name} first touch at the end of their overlap "
                         f"(y = {grid[int(np.argmax(d))]:.1f} mm), not inside both profiles: the rail's crown must "
                         f"meet the wheel inside the rail profile (is it flat, or cut too narrow?); the wheel covers "
                         f"the rail for offset_mm in [{lo_eta:.2f}, {hi_eta:.2f}] mm")
    peaks = np.flatnonzero((d[1:-1] >= d[:-2]) & (d[1:-1] > d[2:])) + 1
    found = []
    for i in peaks:
        opt = minimize_scalar(lambda t: -float(lift(t)), bounds=(grid[i - 1], grid[i + 1]),
                              method="bounded", options={"xatol": 1e-10})
        found.append((float(opt.x), float(-opt.fun)))
    h = max(v for _, v in found)
    placement = WheelRailPlacement(wheel=w, rail=r, offset_mm=eta, rail_inclination=incl,
                                   nominal_radius_mm=r0, tape_circle_height_mm=h,
                                   y_range_mm=(float(overlap[0]), float(overlap[1])),
                                   contact_points=(), tolerance_mm=tol)
    points = sorted((_contact_point(placement, y, h - v) for y, v in found if h - v <= tol),
                    key=lambda p: p.separation_mm)
    return replace(placement, contact_points=tuple(points))


def _contact_point(placement: WheelRailPlacement, y: float, separation: float) -> ContactPoint:
    """Describe the (near) contact at track position y."""
    u = placement.rail_y(y)
    return ContactPoint(
        y_mm=y, z_mm=placement.rail_height(y), y_wheel_mm=placement.wheel_y(y), y_rail_mm=u,
        separation_mm=separation, rolling_radius_mm=placement.rolling_radius(y),
        contact_angle_rad=math.atan(placement.rail.slope(u)) + math.atan(placement.rail_inclination),
        wheel_curvature_per_mm=placement.wheel_curvature(y),
        rail_curvature_per_mm=placement.rail_curvature(y))
