"""Polygon geometry of contact outlines: signed and enclosed areas of rings.

A contact outline is a list of rings, each an ``(n, 2)`` array of vertices
(closed or not). Outer boundaries and holes come with opposite orientations
(as contourpy and the half-space solver produce them), so the enclosed area of
an outline is the absolute value of the sum of its signed ring areas.
"""
from __future__ import annotations

from typing import Iterable

import numpy as np

__all__ = ["ring_signed_area_mm2", "outline_area_mm2"]


def ring_signed_area_mm2(ring: np.ndarray) -> float:
    """Shoelace area of one ring, positive when counter-clockwise.

    Parameters
    ----------
    ring : ndarray, shape (n, 2)
        Vertices in mm; a repeated closing vertex is allowed (it adds nothing).

    Returns
    -------
    float
        Signed area (mm^2); 0 for fewer than three vertices.
    """
    v = np.asarray(ring, dtype=float)
    if v.ndim != 2 or v.shape[0] < 3 or v.shape[1] != 2:
        return 0.0
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def outline_area_mm2(rings: Iterable[np.ndarray]) -> float:
    """Area enclosed by an outline: |sum of the signed areas of its rings| (mm^2)."""
    return abs(sum(ring_signed_area_mm2(r) for r in rings))
