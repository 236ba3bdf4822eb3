"""The contact edge of a contact solved on a grid: the FE model's edge, in 2D.

The finite-element model (:mod:`filmcal.fem`) reads its contact radius as the
zero-pressure edge, with sub-element accuracy
(:mod:`filmcal.contact.reading`). A contact solved on a grid is read with the
same definition, by the same code as the ``edge`` imprint model
(:class:`filmcal.contact.GridField`): the outline where ``p**2``, extended one
cell beyond the loaded cells by linear extrapolation along the grid lines,
vanishes. ``p**2`` is smooth across a Hertzian edge, so the outline lies
inside the boundary cells where the pressure would fall to zero, not at the
centres of the first unloaded cells.

For the film springs of :mod:`filmcal.contact.laws` (Winkler springs
``t / M`` in series with the steel half-spaces) this outline agrees with the
finite-element continuum film's edge within 0.01 mm in radius on sphere-on-
flat cases of Table 1 for E = 1000-5000 MPa
(``tests/test_wheelrail_edge.py``), and with Hertz's ellipse without a film.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from filmcal.contact.geometry import ring_signed_area_mm2
from filmcal.contact.reading import GridField, read_radial_profile

__all__ = ["EdgeWindow", "EdgeReading", "read_radial_edge_mm", "read_fitted_outline",
           "read_contact_edge", "patch_ring_areas_mm2"]


@dataclass(frozen=True)
class EdgeWindow:
    """Settings of the grid edge reading.

    The zero-pressure edge needs no fit window; the class stays as the
    settings object that :class:`filmcal.wheelrail.WheelRailModel` holds and
    passes on.
    """


@dataclass
class EdgeReading:
    """The zero-pressure edge of a contact on a grid.

    Attributes
    ----------
    area_mm2 : float
        Area enclosed by the outline.
    rings_mm : list of ndarray
        Outline rings, each ``(n, 2)`` closed, in grid coordinates.
    ring_areas_mm2 : ndarray
        Signed area of every ring (outer boundaries and holes have opposite signs).
    ring_labels : ndarray of int
        Connected component (patch, numbered from 1) of every ring (0: none).
    """

    area_mm2: float
    rings_mm: list[np.ndarray] = field(repr=False)
    ring_areas_mm2: np.ndarray = field(repr=False)
    ring_labels: np.ndarray = field(repr=False)

    def patch_areas_mm2(self, n_patches: int) -> np.ndarray:
        """Area of each patch (components 1..n_patches)."""
        out = np.zeros(n_patches)
        for label, area in zip(self.ring_labels, self.ring_areas_mm2):
            if 1 <= label <= n_patches:
                out[label - 1] += area
        return np.abs(out)


def read_radial_edge_mm(r_mm: np.ndarray, pressure_mpa: np.ndarray, tip_mm: float = math.inf) -> float:
    """Zero-pressure edge of a radial line of cell pressures through a contact's centre.

    The axisymmetric reading of :func:`filmcal.contact.read_radial_profile`
    with point samples (cell centres).

    Parameters
    ----------
    r_mm : ndarray
        Distances of the cell centres from the contact's centre (ascending).
    pressure_mpa : ndarray
        Pressures there; loaded where > 0.
    tip_mm : float
        Tip length of the edge (inf: Hertzian edge).
    """
    return read_radial_profile(r_mm, pressure_mpa, tip_mm, samples="point").edge_mm


def _ring_vertices(ring: np.ndarray) -> np.ndarray:
    return ring[:-1] if len(ring) > 1 and np.allclose(ring[0], ring[-1]) else ring


def _outward_normals(vertices: np.ndarray, mask: np.ndarray, origin, spacing) -> np.ndarray:
    """Unit normals of a ring pointing out of the loaded region."""
    tangent = np.roll(vertices, -1, axis=0) - np.roll(vertices, 1, axis=0)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1), 1e-300)[:, None]
    normal = np.column_stack([tangent[:, 1], -tangent[:, 0]])
    probe = vertices + 0.6 * min(spacing) * normal
    idx = [np.clip(np.rint((probe[:, k] - origin[k]) / spacing[k]).astype(int), 0,
                   mask.shape[k] - 1) for k in (0, 1)]
    if mask[idx[0], idx[1]].mean() > 0.5:
        normal = -normal
    return normal


def _ring_label(vertices: np.ndarray, labels: np.ndarray, origin, spacing) -> int:
    """Component of the loaded cells just inside a ring."""
    normal = _outward_normals(vertices, labels > 0, origin, spacing)
    probe = vertices - 0.6 * min(spacing) * normal
    idx = [np.clip(np.rint((probe[:, k] - origin[k]) / spacing[k]).astype(int), 0,
                   labels.shape[k] - 1) for k in (0, 1)]
    found = labels[idx[0], idx[1]]
    found = found[found > 0]
    return int(np.bincount(found).argmax()) if found.size else 0


def _grid_frame(x_mm: np.ndarray, y_mm: np.ndarray) -> tuple[tuple[float, float], tuple[float, float]]:
    return ((float(x_mm[0]), float(y_mm[0])),
            (float(x_mm[1] - x_mm[0]), float(y_mm[1] - y_mm[0])))


def read_fitted_outline(x_mm: np.ndarray, y_mm: np.ndarray, pressure_mpa: np.ndarray,
                        outline_mm: list[np.ndarray] | None, labels: np.ndarray,
                        window: EdgeWindow = EdgeWindow()) -> EdgeReading:
    """Zero-pressure edge of a contact on a grid, with each ring assigned to its patch.

    Parameters
    ----------
    x_mm, y_mm : ndarray
        Cell-centre coordinates along the two grid axes.
    pressure_mpa : ndarray, shape (len(x_mm), len(y_mm))
        Cell pressures.
    outline_mm : list of ndarray or None
        The solver's positive-pressure outline; not needed by the reading
        (the outline is contoured from the pressures), accepted for callers
        that pass it.
    labels : ndarray of int
        Connected components of the loaded cells (``scipy.ndimage.label``).
    window : EdgeWindow
        Settings (see :class:`EdgeWindow`).
    """
    grid_field = GridField(x_mm, y_mm, pressure_mpa)
    area, rings = grid_field.level_area_mm2(0.0)
    origin, spacing = _grid_frame(grid_field.x_mm, grid_field.y_mm)
    closed, ring_areas, ring_labels = [], [], []
    for ring in rings:
        v = _ring_vertices(np.asarray(ring, dtype=float))
        closed.append(np.vstack([v, v[:1]]))
        ring_areas.append(ring_signed_area_mm2(v))
        ring_labels.append(_ring_label(v, labels, origin, spacing))
    return EdgeReading(area_mm2=float(area), rings_mm=closed, ring_areas_mm2=np.array(ring_areas),
                       ring_labels=np.array(ring_labels, dtype=int))


def read_contact_edge(result, window: EdgeWindow = EdgeWindow()) -> EdgeReading:
    """The edge of a :class:`filmcal.wheelrail.halfspace.ContactResult`.

    Patches are the 8-connected components of the loaded cells.
    """
    from scipy import ndimage

    p = result.pressure_mpa
    labels, _ = ndimage.label(p > 0.0, structure=np.ones((3, 3), dtype=int))
    grid = result.grid
    return read_fitted_outline(grid.x_mm, grid.y_mm, p, result.outline_mm, labels, window)


def patch_ring_areas_mm2(x_mm: np.ndarray, y_mm: np.ndarray, rings: list[np.ndarray],
                         labels: np.ndarray, n_patches: int) -> np.ndarray:
    """Area enclosed by the outline rings of each patch (components 1..n_patches).

    Each ring (outer boundary or hole) is assigned to the component of the
    loaded cells just inside it; the signed ring areas are summed per patch.
    """
    origin, spacing = _grid_frame(np.asarray(x_mm, float), np.asarray(y_mm, float))
    out = np.zeros(n_patches)
    for ring in rings:
        v = _ring_vertices(np.asarray(ring, dtype=float))
        label = _ring_label(v, labels, origin, spacing)
        if 1 <= label <= n_patches:
            out[label - 1] += ring_signed_area_mm2(v)
    return np.abs(out)
