"""The contact edge read from the pressure profile next to it.

Where exactly a contact ends depends on how the edge is read. A Winkler film
(the film springs ``t/M`` of :mod:`filmcal.wheelrail.interface`) lets the
pressure fall linearly to zero over a tail about one film-spring length wide,
while the continuum film of the axisymmetric finite-element model
(:mod:`filmcal.fem`) ends more sharply; the last few hundredths of a
millimetre of either tail lie below the 0.1 mm resolution of a Prescale
imprint. The finite-element model therefore reads its contact radius from the
mesh-converged pressure *inside* the edge: it fits

    p(r) = b (a**2 - r**2)**gamma,   gamma in [0.3, 1.5],

to the nodal pressures in the window ``a - 1.0 <= r <= a - 0.2`` mm (iterated,
as ``a`` is not known beforehand; narrowed to ``a - 0.5`` mm when the relative
RMS misfit exceeds 1e-3) and returns the fitted ``a``
(``filmcal.fem.result.read_contact_radius``).

This module applies the same reading to a contact solved on a grid, so that
the areas of the two models are compared -- and the calibrated film is used
-- with one definition of the edge:

* along a grid line through the contact, the pressure of a chord from ``u_l``
  to ``u_r`` is modelled as ``b ((u - u_l)(u_r - u))**gamma`` (the
  finite-element form is the diameter of an axisymmetric contact, and the
  chords of a Hertz ellipse are exactly of this form with gamma = 1/2);
* at every point where the contact outline crosses a grid line whose
  direction lies within 45 degrees of the outline normal, the chord end is
  fitted to the cell pressures in the same window, measured along the normal
  (0.2-1.0 mm, i.e. ``[0.2, 1.0] / cos(alpha)`` along the line at an angle
  ``alpha`` from the normal), giving the offset of the fitted edge from the
  outline;
* crossings on chords shorter than twice the window are not fitted (the
  reading needs a contact large compared with the window, as the FE reading
  does: its contact radii are 4-10 mm);
* the offsets are smoothed by a running mean along the outline (+-0.5 mm of
  arc: single-line fits scatter by a few hundredths of a millimetre as cells
  enter and leave the discrete window), interpolated to the remaining
  vertices, and the outline is moved inwards along its normal by them: the
  *fitted outline*, whose enclosed area is the fitted contact area.

With hard contact the fit recovers the zero-pressure edge (gamma = 1/2); with
a film it removes the Winkler tail beyond the extrapolated profile, as the
finite-element reading does for the continuum film. The fits are done for all
crossings at once by a vectorised Levenberg-Marquardt iteration.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["EdgeWindow", "EdgeReading", "read_radial_edge_mm", "read_fitted_outline",
           "read_contact_edge", "patch_ring_areas_mm2"]

_GAMMA_BOUNDS = (0.3, 1.5)
_MIN_POINTS = 3
_PASSES = 3
_MIN_COS_ALPHA = math.sqrt(0.5) - 1e-9


@dataclass(frozen=True)
class EdgeWindow:
    """Where the edge profile is fitted (the finite-element reading's settings).

    Parameters
    ----------
    outer_mm, inner_mm : float
        The window spans ``inner_mm`` to ``outer_mm`` inside the fitted edge,
        measured along the outline normal.
    narrowed_outer_mm : float
        Outer bound used instead when the fit's relative RMS misfit exceeds
        ``max_misfit`` (kinks in the profile further in).
    max_misfit : float
        RMS residual relative to the largest pressure in the window.
    smoothing_mm : float
        Contacts on a grid only: half-width (arc length along the outline) of
        the running mean applied to the fitted offsets.
    """

    outer_mm: float = 1.0
    inner_mm: float = 0.2
    narrowed_outer_mm: float = 0.5
    max_misfit: float = 1e-3
    smoothing_mm: float = 0.5


@dataclass
class EdgeReading:
    """The fitted edge of a contact on a grid.

    Attributes
    ----------
    area_mm2 : float
        Area enclosed by the fitted outline.
    rings_mm : list of ndarray
        Fitted outline rings, each ``(n, 2)`` closed, in grid coordinates.
    ring_areas_mm2 : ndarray
        Signed area of every fitted ring (outer boundaries and holes have
        opposite signs).
    ring_labels : ndarray of int
        Connected component (patch, numbered from 1) of every ring.
    offsets_mm : list of ndarray
        Inward normal offset of the fitted edge from the outline at every
        ring vertex (the closing vertex excluded).
    n_fitted, n_failed : int
        Outline crossings fitted, and those of them where the window held
        fewer than three loaded cells. Crossings on chords shorter than twice
        the window (where the windows of the two ends would overlap) are not
        fitted; failed and unfitted crossings take offsets interpolated along
        the outline, and a ring without any fitted crossing keeps its
        positive-pressure outline.
    mean_gamma : float
        Mean fitted edge exponent (1/2 for a Hertzian edge).
    """

    area_mm2: float
    rings_mm: list[np.ndarray] = field(repr=False)
    ring_areas_mm2: np.ndarray = field(repr=False)
    ring_labels: np.ndarray = field(repr=False)
    offsets_mm: list[np.ndarray] = field(repr=False)
    n_fitted: int
    n_failed: int
    mean_gamma: float

    def patch_areas_mm2(self, n_patches: int) -> np.ndarray:
        """Fitted area of each patch (components 1..n_patches)."""
        out = np.zeros(n_patches)
        for label, area in zip(self.ring_labels, self.ring_areas_mm2):
            if 1 <= label <= n_patches:
                out[label - 1] += area
        return np.abs(out)


# ---------------------------------------------------------------------------
# Batched fit of the chord-end model
# ---------------------------------------------------------------------------

@dataclass
class _Crossings:
    """Data of n chord ends, padded to m cells each.

    ``distance`` holds the distances of the cells from the reference point of
    the chord end (the outline crossing), positive inwards; ``valid`` marks
    loaded cells of the chord except the boundary cell; ``chord`` is the
    distance from the reference to the reference of the chord's other end,
    ``partner`` the index of that end (-1 if it is not fitted), ``outside``
    the distance to the first unloaded cell beyond the reference, ``scale``
    the factor from normal to along-line distances, ``start`` the initial
    edge offset.
    """

    distance: np.ndarray
    pressure: np.ndarray
    valid: np.ndarray
    chord: np.ndarray
    partner: np.ndarray
    outside: np.ndarray
    scale: np.ndarray
    start: np.ndarray


def _model(distance, offset, chord, gamma):
    """``q = (d - e)(L - d)`` and the unit profile ``q**gamma``."""
    q = np.clip((distance - offset[:, None]) * (chord[:, None] - distance), 1e-300, None)
    return q, q ** gamma[:, None]


def _levenberg_marquardt(c: _Crossings, window: np.ndarray, chord: np.ndarray, offset, b, gamma,
                         lower, upper, iterations: int = 100):
    """Least squares of ``(b q**gamma - p) / p_max`` over each window, all ends at once.

    Returns the offsets, amplitudes, exponents and relative RMS misfits.
    """
    w = window.astype(float)
    p_max = np.maximum((c.pressure * w).max(axis=1), 1e-300)

    def residual(e, bb, g):
        q, u = _model(c.distance, e, chord, g)
        return q, u, w * (bb[:, None] * u - c.pressure) / p_max[:, None]

    q, u, r = residual(offset, b, gamma)
    cost = (r * r).sum(axis=1)
    lam = np.full(offset.shape, 1e-3)
    converged = np.zeros(offset.shape, dtype=bool)
    for _ in range(iterations):
        gap = np.where(w > 0, c.distance - offset[:, None], 1.0)
        jac = np.stack([-gamma[:, None] * b[:, None] * u / gap, u,
                        b[:, None] * u * np.log(q)], axis=-1) * (w / p_max[:, None])[..., None]
        jac_t = jac.transpose(0, 2, 1)
        a = jac_t @ jac
        grad = (jac_t @ r[..., None])[..., 0]
        diag = np.maximum(a[:, [0, 1, 2], [0, 1, 2]], 1e-30)
        damped = a + lam[:, None, None] * (diag[:, :, None] * np.eye(3))
        step = -np.linalg.solve(damped, grad[..., None])[..., 0]
        e_new = np.clip(offset + step[:, 0], lower, upper)
        b_new = np.maximum(b + step[:, 1], 0.0)
        g_new = np.clip(gamma + step[:, 2], *_GAMMA_BOUNDS)
        q_new, u_new, r_new = residual(e_new, b_new, g_new)
        cost_new = (r_new * r_new).sum(axis=1)
        better = (cost_new < cost) & ~converged
        small = np.abs(cost - cost_new) <= 1e-13 * np.maximum(cost, 1e-300)
        converged |= (better & small) | (lam > 1e10)
        offset = np.where(better, e_new, offset)
        b = np.where(better, b_new, b)
        gamma = np.where(better, g_new, gamma)
        q = np.where(better[:, None], q_new, q)
        u = np.where(better[:, None], u_new, u)
        r = np.where(better[:, None], r_new, r)
        cost = np.where(better, cost_new, cost)
        lam = np.where(better, lam / 3.0, lam * 4.0)
        if converged.all():
            break
    n_points = np.maximum(w.sum(axis=1), 1.0)
    return offset, b, gamma, np.sqrt(cost / n_points)


def _fit_passes(c: _Crossings, offset: np.ndarray, outer: np.ndarray, inner: float,
                active: np.ndarray):
    """Iterate the window selection as the finite-element reading does."""
    b = np.zeros_like(offset)
    gamma = np.full(offset.shape, 0.5)
    misfit = np.full(offset.shape, np.inf)
    ok = np.zeros(offset.shape, dtype=bool)
    for _ in range(_PASSES):
        partner_offset = np.where(c.partner >= 0, offset[np.maximum(c.partner, 0)], 0.0)
        chord = c.chord - partner_offset
        lo = offset[:, None] + inner * c.scale[:, None]
        hi = offset[:, None] + outer[:, None] * c.scale[:, None]
        window = c.valid & (c.distance >= lo) & (c.distance <= hi)
        ok = active & (window.sum(axis=1) >= _MIN_POINTS)
        if not ok.any():
            break
        sub = np.flatnonzero(ok)
        d_win = np.where(window[sub], c.distance[sub], np.inf)
        upper = d_win.min(axis=1) - 1e-9
        lower = -c.outside[sub] - outer[sub] * c.scale[sub]
        e0 = np.clip(offset[sub], lower, upper)
        g0 = gamma[sub]
        _, u = _model(c.distance[sub], e0, chord[sub], g0)
        f = u * window[sub]
        b0 = (f * c.pressure[sub]).sum(axis=1) / np.maximum((f * f).sum(axis=1), 1e-300)
        sub_c = _Crossings(c.distance[sub], c.pressure[sub], c.valid[sub], c.chord[sub],
                           c.partner[sub], c.outside[sub], c.scale[sub], c.start[sub])
        e, bb, g, mis = _levenberg_marquardt(sub_c, window[sub], chord[sub], e0, b0, g0,
                                             lower, upper)
        offset = offset.copy()
        offset[sub], b[sub], gamma[sub], misfit[sub] = e, bb, g, mis
    return offset, gamma, misfit, ok


def _fit_crossings(c: _Crossings, window: EdgeWindow,
                   attempt: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Fitted edge offsets, exponents and success flags of the chord ends in `attempt`."""
    n = c.start.size
    outer = np.full(n, window.outer_mm)
    attempt = np.ones(n, dtype=bool) if attempt is None else attempt
    offset, gamma, misfit, ok = _fit_passes(c, c.start.copy(), outer, window.inner_mm, attempt)
    redo = ok & (misfit > window.max_misfit) & (window.outer_mm > window.narrowed_outer_mm)
    if redo.any():
        outer = np.where(redo, window.narrowed_outer_mm, outer)
        offset2, gamma2, _, ok2 = _fit_passes(c, offset, outer, window.inner_mm, redo)
        keep = redo & ok2
        offset = np.where(keep, offset2, offset)
        gamma = np.where(keep, gamma2, gamma)
    return offset, gamma, ok


# ---------------------------------------------------------------------------
# Axisymmetric profile
# ---------------------------------------------------------------------------

def read_radial_edge_mm(r_mm: np.ndarray, pressure_mpa: np.ndarray,
                        window: EdgeWindow = EdgeWindow()) -> float:
    """Contact radius of an axisymmetric pressure profile, read as the FE model reads it.

    Fits ``b (a**2 - r**2)**gamma`` to the pressures between ``a - 1.0`` and
    ``a - 0.2`` mm (iterated from the last loaded point; window narrowed to
    0.5 mm when the misfit exceeds 1e-3), the last loaded point excluded.

    Parameters
    ----------
    r_mm : ndarray
        Radii (ascending) of the pressure samples (nodes, or a radial line of
        cells through the centre of a grid solution).
    pressure_mpa : ndarray
        Pressures there; loaded where > 0.

    Returns
    -------
    float
        The fitted radius; the middle between the last loaded and the next
        point when the window holds fewer than three points.
    """
    r = np.asarray(r_mm, dtype=float)
    p = np.asarray(pressure_mpa, dtype=float)
    loaded = np.flatnonzero(p > 0)
    if loaded.size == 0:
        return 0.0
    k = int(loaded[-1])
    step = float(r[1] - r[0]) if r.size > 1 else 0.0
    r_next = float(r[k + 1]) if k + 1 < r.size else float(r[k]) + step
    ref = float(r[k])
    inside = np.arange(k - 1, -1, -1)
    c = _Crossings(distance=(ref - r[inside])[None, :], pressure=p[inside][None, :],
                   valid=(p[inside] > 0)[None, :], chord=np.array([2.0 * ref]),
                   partner=np.array([0]), outside=np.array([r_next - ref]),
                   scale=np.ones(1), start=np.zeros(1))
    offset, _, ok = _fit_crossings(c, window)
    return ref - float(offset[0]) if ok[0] else 0.5 * (ref + r_next)


# ---------------------------------------------------------------------------
# Contacts on a grid
# ---------------------------------------------------------------------------

def _ring_vertices(ring: np.ndarray) -> np.ndarray:
    return ring[:-1] if len(ring) > 1 and np.allclose(ring[0], ring[-1]) else ring


def _signed_area(ring: np.ndarray) -> float:
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - y * np.roll(x, -1)))


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


def _line_position(vertices: np.ndarray, origin, spacing):
    """For each vertex: the axis its grid line runs along (0: x, 1: y), the
    index of that line and the lower index of the two cells it lies between."""
    fx = (vertices[:, 0] - origin[0]) / spacing[0]
    fy = (vertices[:, 1] - origin[1]) / spacing[1]
    on_row = np.abs(fy - np.rint(fy)) < 1e-6  # constant y: the line runs along x
    axis = np.where(on_row, 0, 1)
    line = np.where(on_row, np.rint(fy), np.rint(fx)).astype(int)
    lower = np.where(on_row, np.floor(fx + 1e-9), np.floor(fy + 1e-9)).astype(int)
    on_grid = on_row | (np.abs(fx - np.rint(fx)) < 1e-6)
    return axis, line, lower, on_grid


def _crossing_records(verts, lines, normals, mask) -> list[tuple]:
    """Outline crossings of grid lines within 45 degrees of the outline normal.

    Each record is (ring, vertex, axis of the line, line index, inside cell,
    inward step, cos of the angle between line and normal).
    """
    records = []
    for ri, (axis, line, lower, on_grid) in enumerate(lines):
        n = normals[ri]
        for k in np.flatnonzero(on_grid):
            ax = int(axis[k])
            cos_alpha = abs(n[k, ax])
            lo, hi = int(lower[k]), int(lower[k]) + 1
            if cos_alpha < _MIN_COS_ALPHA or lo < 0 or hi >= mask.shape[ax]:
                continue
            row = mask[:, line[k]] if ax == 0 else mask[line[k], :]
            if row[lo] == row[hi]:
                continue
            inside, step = (lo, -1) if row[lo] else (hi, 1)
            records.append((ri, int(k), ax, int(line[k]), inside, step, cos_alpha))
    return records


def _crossing_data(p: np.ndarray, records: list[tuple], verts: list[np.ndarray],
                   along: dict, centres: tuple, spacing: tuple, m: int) -> _Crossings:
    """Cells along the line inwards from every crossing, and the chord they belong to."""
    n_rec = len(records)
    distance = np.zeros((n_rec, m))
    pressure = np.zeros((n_rec, m))
    valid = np.zeros((n_rec, m), dtype=bool)
    chord = np.zeros(n_rec)
    outside = np.zeros(n_rec)
    scale = np.zeros(n_rec)
    start = np.zeros(n_rec)
    other_key = []
    index_of = {}
    for j, (ri, k, ax, line, inside, step, cos_alpha) in enumerate(records):
        coord = verts[ri][k, ax]
        profile = p[:, line] if ax == 0 else p[line, :]
        centre = centres[ax]
        idx = inside + step * np.arange(m)
        inb = (idx >= 0) & (idx < profile.size)
        idx_c = np.clip(idx, 0, profile.size - 1)
        run = np.cumprod(inb & (profile[idx_c] > 0)).astype(bool)
        distance[j] = np.abs(centre[idx_c] - coord) + (~inb) * 1e6
        pressure[j] = np.where(run, profile[idx_c], 0.0)
        valid[j] = run
        valid[j, 0] = False  # the boundary cell, as the FE reading leaves out the last node
        start[j] = abs(centre[inside] - coord)
        outside[j] = spacing[ax] - start[j]
        scale[j] = 1.0 / cos_alpha
        # the chord's other end lies past the last loaded cell of the run
        end = inside
        while 0 <= end + step < profile.size and profile[end + step] > 0:
            end += step
        key = (ax, line, end if step > 0 else end - 1)
        other_key.append(key)
        other = along.get(key)
        chord[j] = abs(other - coord) if other is not None else \
            abs(centre[end] - coord) + 0.5 * spacing[ax]
        index_of[(ax, line, min(inside, inside - step))] = j
    partner = np.array([index_of.get(key, -1) for key in other_key], dtype=int)
    return _Crossings(distance, pressure, valid, chord, partner, outside, scale, start)


def read_fitted_outline(x_mm: np.ndarray, y_mm: np.ndarray, pressure_mpa: np.ndarray,
                        rings: list[np.ndarray], labels: np.ndarray,
                        window: EdgeWindow = EdgeWindow()) -> EdgeReading:
    """Fit the edge profile along grid lines at the outline and move the outline onto it.

    Parameters
    ----------
    x_mm, y_mm : ndarray
        Cell-centre coordinates of the grid (uniform spacing).
    pressure_mpa : ndarray, shape (nx, ny)
        Cell pressures (loaded where > 0).
    rings : list of ndarray
        Outline rings of the loaded region (contour of the solver), vertices
        on the lines joining neighbouring cell centres.
    labels : ndarray of int, shape (nx, ny)
        Connected component of every loaded cell (1, 2, ...; 0 outside).
    window : EdgeWindow

    Returns
    -------
    EdgeReading
    """
    p = np.asarray(pressure_mpa, dtype=float)
    mask = p > 0.0
    origin = (float(x_mm[0]), float(y_mm[0]))
    spacing = (float(x_mm[1] - x_mm[0]), float(y_mm[1] - y_mm[0]))
    verts = [_ring_vertices(np.asarray(r, dtype=float)) for r in rings]
    lines = [_line_position(v, origin, spacing) for v in verts]
    # every crossing by (axis, line, lower cell): its coordinate along the line
    along: dict[tuple[int, int, int], float] = {}
    for v, (axis, line, lower, on_grid) in zip(verts, lines):
        for k in np.flatnonzero(on_grid):
            along[(int(axis[k]), int(line[k]), int(lower[k]))] = float(v[k, axis[k]])
    normals = [_outward_normals(v, mask, origin, spacing) for v in verts]
    reach = window.outer_mm * math.sqrt(2.0) + 2.0 * max(spacing)
    m = int(math.ceil(reach / min(spacing))) + 2

    records = _crossing_records(verts, lines, normals, mask)
    offsets = [np.zeros(len(v)) for v in verts]
    fitted_flag = [np.zeros(len(v), dtype=bool) for v in verts]
    gammas = np.array([])
    n_failed = n_attempted = 0
    if records:
        centres = (np.asarray(x_mm, dtype=float), np.asarray(y_mm, dtype=float))
        crossings = _crossing_data(p, records, verts, along, centres, spacing, m)
        # the windows of the two ends of a chord must not overlap
        attempt = crossings.chord >= 2.0 * window.outer_mm * crossings.scale
        offset, gamma, ok = _fit_crossings(crossings, window, attempt)
        n_attempted = int(attempt.sum())
        n_failed = int((attempt & ~ok).sum())
        gammas = gamma[ok]
        for j, (ri, k, _, _, _, _, cos_alpha) in enumerate(records):
            if ok[j]:
                offsets[ri][k] = offset[j] * cos_alpha
                fitted_flag[ri][k] = True
    new_rings, ring_areas, ring_labels = [], [], []
    for ri, v in enumerate(verts):
        off = _smooth_around(v, offsets[ri], fitted_flag[ri], window.smoothing_mm)
        offsets[ri] = off
        moved = v - off[:, None] * normals[ri]
        ring_areas.append(_signed_area(moved))
        new_rings.append(np.vstack([moved, moved[:1]]))
        ring_labels.append(_ring_label(v, normals[ri], labels, origin, spacing))
    ring_areas = np.array(ring_areas)
    return EdgeReading(area_mm2=abs(float(ring_areas.sum())), rings_mm=new_rings,
                       ring_areas_mm2=ring_areas, ring_labels=np.array(ring_labels, dtype=int),
                       offsets_mm=offsets, n_fitted=n_attempted, n_failed=n_failed,
                       mean_gamma=float(gammas.mean()) if gammas.size else float("nan"))


def read_contact_edge(result, window: EdgeWindow = EdgeWindow()) -> EdgeReading:
    """The fitted edge of a :class:`filmcal.wheelrail.halfspace.ContactResult`.

    Patches are the 8-connected components of the loaded cells.
    """
    from scipy import ndimage

    p = result.pressure_mpa
    labels, _ = ndimage.label(p > 0.0, structure=np.ones((3, 3), dtype=int))
    grid = result.grid
    return read_fitted_outline(grid.x_mm, grid.y_mm, p, result.outline_mm, labels, window)


def _smooth_around(vertices: np.ndarray, values: np.ndarray, known: np.ndarray,
                   half_width_mm: float) -> np.ndarray:
    """Running mean of the known values along the ring, filled in between.

    Each known value is replaced by the mean of the known values within
    ``half_width_mm`` of arc length (periodic), which evens out the scatter
    of single-line fits without changing their integral along the outline;
    unknown vertices get the periodic linear interpolation of the smoothed
    values in arc length. A ring without known values gets 0.
    """
    if not known.any():
        return np.zeros_like(values)
    seg = np.linalg.norm(np.diff(np.vstack([vertices, vertices[:1]]), axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    period = float(seg.sum())
    s_known, v_known = s[known], values[known]
    ext_s = np.concatenate([s_known - period, s_known, s_known + period])
    ext_v = np.concatenate([v_known, v_known, v_known])
    lo = np.searchsorted(ext_s, s_known - half_width_mm, side="left")
    hi = np.searchsorted(ext_s, s_known + half_width_mm, side="right")
    total = np.concatenate([[0.0], np.cumsum(ext_v)])
    smoothed = (total[hi] - total[lo]) / (hi - lo)
    return np.interp(s, s_known, smoothed, period=period)


def _ring_label(vertices: np.ndarray, normal: np.ndarray, labels: np.ndarray, origin,
                spacing) -> int:
    """Component of the loaded cells just inside a ring."""
    probe = vertices - 0.6 * min(spacing) * normal
    idx = [np.clip(np.rint((probe[:, k] - origin[k]) / spacing[k]).astype(int), 0,
                   labels.shape[k] - 1) for k in (0, 1)]
    found = labels[idx[0], idx[1]]
    found = found[found > 0]
    return int(np.bincount(found).argmax()) if found.size else 0


def patch_ring_areas_mm2(x_mm: np.ndarray, y_mm: np.ndarray, rings: list[np.ndarray],
                         labels: np.ndarray, n_patches: int) -> np.ndarray:
    """Area enclosed by the outline rings of each patch (components 1..n_patches).

    Each ring (outer boundary or hole) is assigned to the component of the
    loaded cells just inside it; the signed ring areas are summed per patch.
    """
    origin = (float(x_mm[0]), float(y_mm[0]))
    spacing = (float(x_mm[1] - x_mm[0]), float(y_mm[1] - y_mm[0]))
    out = np.zeros(n_patches)
    for ring in rings:
        v = _ring_vertices(np.asarray(ring, dtype=float))
        label = _ring_label(v, _outward_normals(v, labels > 0, origin, spacing), labels, origin,
                            spacing)
        if 1 <= label <= n_patches:
            out[label - 1] += _signed_area(v)
    return np.abs(out)
