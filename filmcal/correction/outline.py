"""Outline of the contact without film, shrunk from a measured imprint outline.

The correctors (`SphereCorrector`, `WheelRailCorrector`) give the area the
contact has without film; this module gives the matching outline: the
measured outline shrunk, consistently with the contact model, until it
encloses the corrected area (at the posterior mean and at both ends of the
90 % interval: a band).

Rule
----
Let ``phi_m`` be the signed distance to the measured outline (negative
inside) and ``s`` the film's outward shift of the outline. The corrected
outline is the zero level set of ``phi_m + lam * s``; ``lam`` is found by
Brent's method so that it encloses the target area. A level set stays a
simple curve where a point-by-point offset would loop over itself (sharp
corners, narrow waists).

* Sphere on flat, and whenever no model outlines are given: ``s = 1``, an
  inward normal offset by ``lam`` mm. The film enlarges the radius of an
  axisymmetric contact by ``a_film - a_0``, the same all round, so for a
  circle this is exact: a radius ``a_m - lam``.
* Wheel-rail: ``s = phi_0 - phi_f``, the difference of the signed distances
  to the model's outlines without and with film (same offset and load, film
  at the posterior median modulus), carried into the image frame by matching
  the area centroids and by the image direction of the rail's field side.
  At ``lam = 1`` the model's film outline goes exactly into its no-film
  outline; on the outline ``s`` is the local enlargement, so a measured
  outline shrinks by the model's enlargement there, scaled to the corrected
  area.

Why not a uniform offset for wheel-rail? The film enlarges a patch by about
``delta_film / |grad g|`` (the film's extra approach over the gap gradient at
the edge), so much more where the surfaces are nearly conformal: on S1002 /
60E2 with the HS film (E = 2800 MPa, nu = 0.33, 90 um) the enlargement
ranges over 0.95-1.2 mm round the patch on the rail crown (eta = -7 mm) and
0.95-1.85 mm at eta = +2 mm (100 kN). Shrinking a film outline (solved at
E = 2000, 2800 or 4000 MPa) to the no-film area and comparing it with the
model's no-film outline (Hausdorff distance; model grid 0.1 mm), for
eta = -7, -5, -3, -1, 0, 1, 2 mm at 50 and 100 kN:

* uniform offset: 0.15-0.27 mm for eta <= -3, 0.26-0.49 mm for
  eta = -1 ... 1, 0.47-0.99 mm at eta = +2;
* this rule (model shift from E = 2800 MPa): 0.01-0.03 mm with the same
  modulus, at most 0.09 mm with the other two, except the near-conformal
  eta = -1 mm (0.17-0.37 mm: corners of the flat-sided patch move with E
  in a way no single scaling of the shift follows) and eta = 0 at 50 kN,
  E = 4000 MPa (0.16 mm).

The registration assumes that the scan is not rotated against the rail
(rolling direction along an image axis); the centroid match takes care of
the position.
"""
from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from filmcal._validation import as_finite, check_choice

__all__ = ["CorrectedOutline", "ModelOutlines", "FIELD_SIDES", "correct_outline", "hausdorff_distance_mm",
           "offset_outline", "outline_area_mm2", "outline_centroid_mm", "outline_perimeter_mm",
           "shrink_outline", "signed_distance_mm", "wheel_rail_outlines"]

# Image frame (x right, y up) -> model frame (x along the rail, y towards the field side),
# for each image direction of the field side.
FIELD_SIDES = {
    "right": np.array([[0.0, 1.0], [1.0, 0.0]]),
    "left": np.array([[0.0, 1.0], [-1.0, 0.0]]),
    "up": np.array([[1.0, 0.0], [0.0, 1.0]]),
    "down": np.array([[1.0, 0.0], [0.0, -1.0]]),
}
GRID_NODES = 256  # level-set grid nodes across the larger extent of the outline


# ---------------------------------------------------------------------------
# Polygons
# ---------------------------------------------------------------------------

def _as_rings(outline, name: str = "outline") -> list[np.ndarray]:
    """Rings as open ``(n, 2)`` float arrays (repeated vertices, the closing one included, removed),
    oriented by nesting (even-odd rule): outer rings counter-clockwise, holes clockwise."""
    items = [outline] if isinstance(outline, np.ndarray) and outline.ndim == 2 else list(outline)
    if not items:
        raise ValueError(f"{name} must hold at least one polygon")
    rings = []
    for ring in items:
        r = np.asarray(ring, dtype=float)
        if r.ndim != 2 or r.shape[1] != 2 or not np.all(np.isfinite(r)):
            raise ValueError(f"{name}: each polygon must be a finite (n, 2) array of (x, y) in mm")
        r = r[np.any(r != np.roll(r, 1, axis=0), axis=1)] if len(r) > 1 else r
        if len(r) < 3 or abs(_signed_area_mm2(r)) <= 0.0:
            raise ValueError(f"{name}: each polygon needs at least 3 vertices and a non-zero area")
        rings.append(r)
    return _oriented(rings)


def _closed(ring: np.ndarray) -> np.ndarray:
    return ring if np.array_equal(ring[0], ring[-1]) else np.vstack([ring, ring[:1]])


def _signed_area_mm2(ring: np.ndarray) -> float:
    """Shoelace area, positive counter-clockwise (closed or open ring)."""
    from filmcal.contact.geometry import ring_signed_area_mm2

    return ring_signed_area_mm2(ring)


def outline_area_mm2(outline) -> float:
    """Area enclosed by polygons (even-odd rule: a ring inside another is a hole), whatever their orientation."""
    return float(sum(_signed_area_mm2(r) for r in _as_rings(outline)))


def outline_perimeter_mm(outline) -> float:
    """Total length of the polygons' edges."""
    return float(sum(np.sum(np.hypot(*np.diff(_closed(r), axis=0).T)) for r in _as_rings(outline)))


def outline_centroid_mm(outline) -> np.ndarray:
    """Area centroid ``(x, y)`` of polygons (even-odd rule)."""
    total, moment = 0.0, np.zeros(2)
    for r in _as_rings(outline):
        x, y = r[:, 0], r[:, 1]
        x1, y1 = np.roll(x, -1), np.roll(y, -1)
        cross = x * y1 - x1 * y
        total += 0.5 * cross.sum()
        moment += np.array([np.sum((x + x1) * cross), np.sum((y + y1) * cross)]) / 6.0
    return moment / total


def _subdivide(ring: np.ndarray, step_mm: float) -> np.ndarray:
    """The ring's vertices plus evenly spaced points on every edge longer than ``step_mm``."""
    nxt = np.roll(ring, -1, axis=0)
    pieces = np.maximum(1, np.ceil(np.hypot(*(nxt - ring).T) / step_mm).astype(int))
    start = np.repeat(ring, pieces, axis=0)
    direction = np.repeat(nxt - ring, pieces, axis=0)
    fraction = np.concatenate([np.arange(k) / k for k in pieces])
    return start + fraction[:, None] * direction


def _oriented(rings: list[np.ndarray]) -> list[np.ndarray]:
    """Rings oriented by nesting: counter-clockwise at even depth (outer), clockwise at odd (holes)."""
    from matplotlib.path import Path as MplPath

    out = []
    for k, ring in enumerate(rings):
        depth = sum(bool(MplPath(other).contains_point(ring[0])) for j, other in enumerate(rings) if j != k)
        ccw = _signed_area_mm2(ring) > 0
        out.append(ring if ccw == (depth % 2 == 0) else ring[::-1])
    return out


def _closest_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from points to segments a-b and the position t in [0, 1] of the closest point."""
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
    return np.hypot(*(p - a - t[:, None] * ab).T), t


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def signed_distance_mm(outline, points, step_mm: float | None = None) -> np.ndarray:
    """Signed distance from points to polygons: negative inside, positive outside.

    Inside follows the even-odd rule (a ring inside another is a hole).

    Parameters
    ----------
    outline : (n, 2) array or list of them
        Polygons in mm.
    points : array_like, shape (..., 2)
    step_mm : float, optional
        Edges are subdivided to this length for the nearest-vertex search;
        the distance itself is measured to the edges next to the nearest
        vertex. 1/200 of the outline's larger extent by default.

    Notes
    -----
    The sign is read at the closest boundary point: the side of its edge, or
    at a vertex the side of the bisecting (pseudo-)normal of the two edges
    there, which is correct for the closest feature of a polygon
    (Baerentzen and Aanaes 2005, the angle-weighted pseudo-normal).
    """
    from scipy.spatial import cKDTree

    rings = _as_rings(outline)
    pts = np.asarray(points, dtype=float)
    shape = pts.shape[:-1]
    pts = pts.reshape(-1, 2)
    if step_mm is None:
        step_mm = float(np.ptp(np.vstack(rings), axis=0).max()) / 200.0
    dense = [_subdivide(r, step_mm) for r in rings]
    v = np.vstack(dense)
    offsets = np.cumsum([0] + [len(d) for d in dense])
    prev = np.concatenate([o + np.roll(np.arange(len(d)), 1) for o, d in zip(offsets, dense)])
    nxt = np.concatenate([o + np.roll(np.arange(len(d)), -1) for o, d in zip(offsets, dense)])
    edge = v[nxt] - v                                       # edge k runs from vertex k to nxt[k]
    normal = np.column_stack([edge[:, 1], -edge[:, 0]]) / np.hypot(*edge.T)[:, None]  # outward
    _, i = cKDTree(v).query(pts)
    d_before, t_before = _closest_on_segments(pts, v[prev[i]], v[i])
    d_after, t_after = _closest_on_segments(pts, v[i], v[nxt[i]])
    after = d_after <= d_before
    dist = np.where(after, d_after, d_before)
    t = np.where(after, t_after, t_before)
    k = np.where(after, i, prev[i])                         # the closer edge
    at_vertex = np.where(after, t <= 0.0, t >= 1.0)
    side = _cross(edge[k], pts - v[k])                      # > 0: left of the edge, inside
    vertex_normal = normal[prev[i]] + normal[i]
    outside = np.where(at_vertex, np.einsum("ij,ij->i", pts - v[i], vertex_normal) > 0.0, side < 0.0)
    return np.where(outside, dist, -dist).reshape(shape)


def hausdorff_distance_mm(outline_a, outline_b, step_mm: float = 0.01) -> float:
    """Hausdorff distance between two sets of polygon boundaries (mm).

    The boundaries are sampled every ``step_mm`` and the distances measured
    to the other set's edges, so the result is exact to within ``step_mm / 2``.
    """
    a, b = _as_rings(outline_a, "outline_a"), _as_rings(outline_b, "outline_b")
    sample_a = np.vstack([_subdivide(r, step_mm) for r in a])
    sample_b = np.vstack([_subdivide(r, step_mm) for r in b])
    return float(max(np.abs(signed_distance_mm(b, sample_a)).max(), np.abs(signed_distance_mm(a, sample_b)).max()))


# ---------------------------------------------------------------------------
# Level sets
# ---------------------------------------------------------------------------

class _LevelSetGrid:
    """A grid over the outline with its signed distance, for level sets ``phi + lam * s = 0``."""

    def __init__(self, rings: list[np.ndarray], pad_mm: float, nodes: int) -> None:
        pts = np.vstack(rings)
        lo, hi = pts.min(axis=0) - pad_mm, pts.max(axis=0) + pad_mm
        self.spacing_mm = float((hi - lo).max() / nodes)
        n = np.ceil((hi - lo) / self.spacing_mm).astype(int) + 1
        self.x = lo[0] + self.spacing_mm * np.arange(n[0])
        self.y = lo[1] + self.spacing_mm * np.arange(n[1])
        xx, yy = np.meshgrid(self.x, self.y)
        self.points = np.column_stack([xx.ravel(), yy.ravel()])
        self.phi = signed_distance_mm(rings, self.points, step_mm=self.spacing_mm)
        self.shape = xx.shape

    def rings(self, field_values: np.ndarray) -> list[np.ndarray]:
        """Closed rings of ``field_values = 0``, the negative side inside (outer rings counter-clockwise)."""
        import contourpy

        gen = contourpy.contour_generator(self.x, self.y, -field_values.reshape(self.shape),
                                          line_type=contourpy.LineType.Separate)
        out = []
        for r in gen.lines(0.0):
            r = np.asarray(r, dtype=float)
            if len(r) < 4 or abs(_signed_area_mm2(r)) < self.spacing_mm**2:
                continue
            if not np.allclose(r[0], r[-1]):
                raise ValueError("the shifted outline reaches the edge of its grid")
            out.append(r)
        return out

    def area(self, field_values: np.ndarray) -> float:
        return float(sum(_signed_area_mm2(r) for r in self.rings(field_values)))


def _solve_scale(grid: _LevelSetGrid, shift: np.ndarray, target: float, first_step: float) -> float:
    """The scale ``lam`` at which the level set of ``phi + lam * shift`` encloses ``target``."""
    from scipy.optimize import brentq

    def excess(lam: float) -> float:
        return grid.area(grid.phi + lam * shift) - target

    at_zero = excess(0.0)
    if at_zero == 0.0:
        return 0.0
    step = abs(first_step) if at_zero > 0 else -abs(first_step)
    other = step
    for _ in range(60):
        if np.sign(excess(other)) != np.sign(at_zero):
            break
        other *= 2.0
    else:
        raise ValueError(f"no shifted outline encloses {target:g} mm2")
    lo, hi = sorted((0.0, other))
    return float(brentq(excess, lo, hi, xtol=1e-9 * max(1.0, abs(other)), rtol=1e-10))


def shrink_outline(outline, area_mm2, shift: Callable[[np.ndarray], np.ndarray] | None = None, *,
                   grid_nodes: int = GRID_NODES) -> tuple[list[list[np.ndarray]], np.ndarray]:
    """Shrink (or grow) an outline along a shift field until it encloses given areas.

    Parameters
    ----------
    outline : (n, 2) array or list of them
        The measured polygons (mm).
    area_mm2 : float or sequence of float
        Target areas (> 0).
    shift : callable, optional
        ``shift(points) -> values``: the outward shift field ``s`` at
        ``(N, 2)`` points in the outline's frame (module notes); uniform
        (``s = 1``, a normal offset) by default.
    grid_nodes : int
        Level-set grid nodes across the outline's larger extent.

    Returns
    -------
    outlines : list of list of ndarray
        For each target, closed rings (outer counter-clockwise).
    scale : ndarray
        ``lam`` for each target: the inward offset in mm for a uniform
        shift, the fraction of the model's shift otherwise.
    """
    rings = _as_rings(outline)
    targets = np.atleast_1d(np.asarray(area_mm2, dtype=float))
    if targets.ndim != 1 or not np.all(np.isfinite(targets)) or np.any(targets <= 0):
        raise ValueError("area_mm2 must be finite and > 0")
    if int(grid_nodes) < 16:
        raise ValueError(f"grid_nodes must be >= 16, got {grid_nodes}")
    measured = outline_area_mm2(rings)
    perimeter = outline_perimeter_mm(rings)
    boundary = np.vstack(rings)
    s_boundary = np.ones(len(boundary)) if shift is None else np.asarray(shift(boundary), dtype=float)
    mean_s = float(np.mean(s_boundary))
    if not np.isfinite(mean_s) or mean_s <= 0:
        raise ValueError("the shift field must point outwards on the outline (positive mean)")
    ratio = max(1.0, float(np.max(np.abs(s_boundary))) / mean_s)
    growth = max(0.0, (targets.max() - measured) / perimeter) * ratio
    extent = float(np.ptp(boundary, axis=0).max())
    pad = 3.0 * growth + 0.05 * extent
    grid = _LevelSetGrid(rings, pad, int(grid_nodes))
    s = np.ones(len(grid.points)) if shift is None else np.asarray(shift(grid.points), dtype=float)
    if s.shape != (len(grid.points),) or not np.all(np.isfinite(s)):
        raise ValueError("the shift field must return one finite value per point")
    scales, outlines = [], []
    for target in targets:
        first = (measured - target) / (perimeter * mean_s) * 1.5 or grid.spacing_mm / mean_s
        lam = _solve_scale(grid, s, float(target), first)
        scales.append(lam)
        outlines.append(grid.rings(grid.phi + lam * s))
    return outlines, np.array(scales)


def offset_outline(outline, distance_mm: float, *, grid_nodes: int = GRID_NODES) -> list[np.ndarray]:
    """Offset polygons along their normals: inwards by ``distance_mm`` (outwards if negative).

    Returns closed rings (outer counter-clockwise): the level set at
    ``-distance_mm`` of the signed distance, so corners and narrow waists are
    handled without self-intersections.
    """
    d = as_finite("distance_mm", distance_mm)
    rings = _as_rings(outline)
    extent = float(np.ptp(np.vstack(rings), axis=0).max())
    grid = _LevelSetGrid(rings, max(0.0, -d) + 0.05 * extent, int(grid_nodes))
    out = grid.rings(grid.phi + d)
    if not out:
        raise ValueError(f"an inward offset of {d:g} mm leaves nothing of the outline")
    return out


# ---------------------------------------------------------------------------
# The model's shift and the corrected outline
# ---------------------------------------------------------------------------

@dataclass
class ModelOutlines:
    """A contact's outlines from the model, with and without film (x along the rail, y towards the field side, mm).

    Attributes
    ----------
    film_mm, no_film_mm : list of ndarray
        Outline rings with and without film.
    """

    film_mm: list[np.ndarray] = field(repr=False)
    no_film_mm: list[np.ndarray] = field(repr=False)

    def __post_init__(self) -> None:
        self.film_mm = _as_rings(self.film_mm, "film_mm")
        self.no_film_mm = _as_rings(self.no_film_mm, "no_film_mm")

    def shift_field(self, measured, field_side: str = "right") -> Callable[[np.ndarray], np.ndarray]:
        """The film's shift ``phi_0 - phi_f`` in the frame of a measured outline.

        Parameters
        ----------
        measured : (n, 2) array or list of them
            The measured outline (image frame: x right, y up, mm).
        field_side : str
            Image direction of the rail's field side: "right", "left", "up"
            or "down"; the rolling direction is the other image axis.
        """
        rotation = FIELD_SIDES[check_choice("field_side", field_side, tuple(FIELD_SIDES))]
        origin = outline_centroid_mm(measured)
        target = outline_centroid_mm(self.film_mm)

        def shift(points: np.ndarray) -> np.ndarray:
            model_points = (np.asarray(points, dtype=float) - origin) @ rotation.T + target
            return signed_distance_mm(self.no_film_mm, model_points) - signed_distance_mm(self.film_mm, model_points)

        return shift


def wheel_rail_outlines(offset_mm: float, force_n: float, film, **wheel_rail) -> ModelOutlines:
    """The model's wheel-rail outlines with and without film for one configuration.

    Parameters
    ----------
    offset_mm, force_n : float
        Lateral offset eta (mm) and vertical load (N).
    film : filmcal.wheelrail.FilmLayer
        The film (e.g. at the posterior median modulus).
    **wheel_rail
        Passed to `filmcal.wheelrail.solve_wheel_rail` (wheel, rail, rail_inclination, ...).
    """
    from filmcal.wheelrail import solve_wheel_rail

    with_film = solve_wheel_rail(offset_mm, force_n, film=film, **wheel_rail)
    without = solve_wheel_rail(offset_mm, force_n, film=None, **wheel_rail)
    return ModelOutlines(with_film.outline_mm, without.outline_mm)


@dataclass
class CorrectedOutline:
    """Outlines of the contact without film: at the posterior mean area and the ends of its 90 % interval.

    Attributes
    ----------
    measured_mm : list of ndarray
        The measured outline.
    mean_mm, lo_mm, hi_mm : list of ndarray
        Closed rings enclosing the posterior mean area, its 5 % quantile
        (inner edge of the band) and its 95 % quantile (outer edge).
    area_mm2 : ndarray, shape (3,)
        The target areas (mean, 5 %, 95 %).
    shift_scale : ndarray, shape (3,)
        ``lam`` for each: the inward offset in mm for the uniform rule, the
        fraction of the model's shift for the wheel-rail rule.
    rule : str
        "uniform offset" or "wheel-rail model shift".
    """

    measured_mm: list[np.ndarray] = field(repr=False)
    mean_mm: list[np.ndarray] = field(repr=False)
    lo_mm: list[np.ndarray] = field(repr=False)
    hi_mm: list[np.ndarray] = field(repr=False)
    area_mm2: np.ndarray
    shift_scale: np.ndarray
    rule: str

    def rows(self) -> list[tuple[str, int, float, float]]:
        """``(part, ring, x_mm, y_mm)`` for every vertex; part is measured, mean, lo or hi."""
        out = []
        for part, rings in (("measured", self.measured_mm), ("mean", self.mean_mm), ("lo", self.lo_mm),
                            ("hi", self.hi_mm)):
            for k, ring in enumerate(rings):
                out.extend((part, k, float(x), float(y)) for x, y in _closed(ring))
        return out

    def write_csv(self, path) -> Path:
        """Write `rows` as CSV with the header ``part,ring,x_mm,y_mm`` (whole or not at all); returns the path."""
        from filmcal._io import atomic_open

        path = Path(path)
        with atomic_open(path, "w", newline="", encoding="utf-8") as fh:
            writer = csv.writer(fh)
            writer.writerow(["part", "ring", "x_mm", "y_mm"])
            writer.writerows((p, k, f"{x:.5f}", f"{y:.5f}") for p, k, x, y in self.rows())
        return path


def _target_areas(areas) -> np.ndarray:
    if hasattr(areas, "area_ci90_mm2"):
        if np.ndim(areas.area_mm2) != 0:
            raise ValueError("correct_outline takes the corrected area of one imprint (a scalar CorrectedArea)")
        lo, hi = np.asarray(areas.area_ci90_mm2, dtype=float)
        values = np.array([float(areas.area_mm2), lo, hi])
    else:
        values = np.asarray(areas, dtype=float)
        if values.shape != (3,):
            raise ValueError("areas must be a CorrectedArea or (mean, lo, hi) in mm2")
    if not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError("the corrected areas must be finite and > 0")
    return values


def correct_outline(measured, areas, model: ModelOutlines | None = None, *, field_side: str = "right",
                    grid_nodes: int = GRID_NODES) -> CorrectedOutline:
    """The outline of the contact without film behind a measured imprint outline.

    Parameters
    ----------
    measured : (n, 2) array or list of them
        The imprint's outline (e.g. `Imprint.outlines_mm`; image frame, mm).
    areas : CorrectedArea or sequence of 3 floats
        The corrected area of this imprint (posterior mean and 90 % interval),
        or (mean, lo, hi) in mm2.
    model : ModelOutlines, optional
        The model's outlines with and without film (`wheel_rail_outlines`):
        the wheel-rail rule. Without it, a uniform normal offset (exact for
        the circular sphere-on-flat contact).
    field_side : str
        Wheel-rail rule: image direction of the rail's field side ("right",
        "left", "up" or "down").
    grid_nodes : int
        Level-set grid nodes across the outline's larger extent.

    Returns
    -------
    CorrectedOutline
    """
    rings = _as_rings(measured, "measured")
    targets = _target_areas(areas)
    check_choice("field_side", field_side, tuple(FIELD_SIDES))
    shift = None if model is None else model.shift_field(rings, field_side)
    outlines, scales = shrink_outline(rings, targets, shift, grid_nodes=grid_nodes)
    return CorrectedOutline(measured_mm=[_closed(r) for r in rings], mean_mm=outlines[0], lo_mm=outlines[1],
                            hi_mm=outlines[2], area_mm2=targets, shift_scale=scales,
                            rule="uniform offset" if model is None else "wheel-rail model shift")
