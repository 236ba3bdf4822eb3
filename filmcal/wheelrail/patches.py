"""The patches of a contact outline: which ring belongs to which connected patch, and each patch's area.

The half-space solver contours its outline over the whole grid (outer
boundaries and holes, any number of patches, `filmcal.wheelrail.halfspace`);
a wheel-rail contact reports each connected patch (tread, flange) with its own
area.
"""
from __future__ import annotations

import numpy as np

from filmcal.contact.geometry import ring_signed_area_mm2

__all__ = ["patch_ring_areas_mm2"]


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
