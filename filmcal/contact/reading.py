"""Readings of a contact pressure field with sub-element accuracy.

Two kinds of field are read, with one set of rules:

* an axisymmetric profile of nodal pressures ``p_i = f_i / A_i`` (nodal
  force over the tributary area ``A_i = int phi_i 2 pi r dr`` of linear
  elements), as the finite-element model (:mod:`filmcal.fem`) reports it;
* a cell-centred pressure field on a regular 2D grid, as the half-space
  solver (:mod:`filmcal.wheelrail.halfspace`) reports it.

From either, :class:`RadialProfile` and :class:`GridField` give the zero-
pressure edge, the outermost contour at a pressure level, and integrals of a
function of the pressure over the contact (used by the imprint models of
:mod:`filmcal.contact.imprint`).

The edge of an axisymmetric profile
-----------------------------------
Near its edge a contact through a thin film has two scales. Well inside,
the film acts as a bed of springs of stiffness ``M / t`` (oedometric modulus
over thickness) in series with the steel, and the pressure falls nearly
linearly towards the edge; within about one film thickness of the edge the
film acts like an elastic body of its own and the pressure ends with a
square-root tip, as at a Hertzian edge. On meshes down to h = 0.0125 mm the
finite-element pressure shows exactly that. A mesh of h = 0.1 mm does not
resolve the tip, but its last nodal forces carry the tip's integral, so the
edge is read by fitting, to the nodal forces of the nodes within
:data:`EDGE_WINDOW_MM` (0.2 mm; without a film :data:`HERTZ_WINDOW_MM`, 1 mm)
of the last loaded node (and the first unloaded node,
whose force is zero), the force-consistent integrals of

    p(r) = c sqrt(q (1 + q / (2 a l))),   q = a^2 - r^2,

where ``a`` is the edge and ``l`` the tip length (``c`` follows by linear
least squares for every ``a``; ``a`` by a bounded scalar search). Without a
film ``l`` is infinite and the profile is Hertz's ``c sqrt(a^2 - r^2)``
exactly; with a film ``l`` is :func:`film_tip_length_mm`. Fitting the
nodal forces, not the nodal pressures at the nodes, removes the bias of the
last node (whose tributary area reaches beyond the edge); fitting the two-
scale shape, not a power law, removes the bias of extrapolating the linear
bulk to zero (0.02-0.04 mm, growing with E, in the reading this replaces).

Levels (the activation contour) are read from the same profile: within the
fit window from the fitted profile, further in by interpolating ``p**2``
linearly between the nodes (``p**2`` is smooth across both a Hertzian and a
film profile).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Iterator, Sequence

import numpy as np

from filmcal.contact.geometry import outline_area_mm2

__all__ = ["FILM_CONTOUR_POWER", "NOMINAL_LEVEL", "nominal_area_mm2", "EDGE_WINDOW_MM", "HERTZ_WINDOW_MM", "TIP_SCALE", "TIP_STIFFNESS_FACTOR", "film_tip_length_mm", "tributary_areas_mm2",
           "RadialProfile", "read_radial_profile", "GridField", "INTEGRAL_NODES"]

#: The contoured power of the pressure through a film (`GridField`): it rises linearly from the edge.
FILM_CONTOUR_POWER = 1
#: Gauss-Legendre nodes over the values of the integrand in `GridField.integral_mm2` (each a contour of the
#: field): 48 read the capsule imprint within 0.00003 mm in radius of 96 (sphere-on-flat, MS/HS/HHS).
INTEGRAL_NODES = 48

#: Width of the window of nodes inside the last loaded node fitted for the edge
#: of a contact through a film (mm): the two-scale shape holds near the edge only. Levels
#: within it are read from the fitted shape; on a stiff film the shape does not hold over
#: 0.3 mm (three elements of the default mesh; 0.2 mm spans two): against the second FE
#: formulation read from its own nodes, the default mesh's activation and capsule radii
#: missed by rms 0.0024 mm, at most 0.0088 mm (E 13647 MPa), over 14 films of E 474-19701 MPa,
#: and by rms 0.0016 mm, at most 0.0050 mm, with 0.2 mm (docs/verification.md).
EDGE_WINDOW_MM = 0.2
#: The same without a film (mm): Hertz's profile holds over the whole contact.
HERTZ_WINDOW_MM = 1.0
#: Tip length per film thickness of a compressible film at nu = 0 (see film_tip_length_mm).
TIP_SCALE = 0.92
#: Growth of the tip length with the film's stiffness relative to steel (see film_tip_length_mm).
TIP_STIFFNESS_FACTOR = 17.9

_GAUSS_X, _GAUSS_W = np.polynomial.legendre.leggauss(16)


def film_tip_length_mm(thickness_mm: float | None, oedometric_modulus_mpa: float | None = None,
                       poisson: float = 0.33, contact_modulus_mpa: float | None = None) -> float:
    """Length of the square-root tip at the edge of a contact through a film.

    ``l = c t (1 - 2 nu) (1 + k M / E*)`` with ``c`` = :data:`TIP_SCALE` and
    ``k`` = :data:`TIP_STIFFNESS_FACTOR`. The tip shortens as the film nears
    incompressibility (a squeezed layer turns its edge sharply) and lengthens
    as the film stiffens towards steel (where the contact becomes Hertzian,
    ``l`` infinite). Both constants were fitted to the edge of the second FE
    formulation (:mod:`filmcal.fem.reference`: biquadratic elements, the
    exact load at which each node closes, extrapolated in the mesh) over
    E 500-10000 MPa, nu 0.25-0.45, R 250-600 mm, 20-100 kN: read with this
    tip, the FE at h = 0.025 mm matches it within 0.0013 mm (``python
    bench/fe_reference.py`` prints the comparison, also on held-out films).

    Parameters
    ----------
    thickness_mm : float or None
        Film thickness t (mm); None or 0 for no film (returns inf).
    oedometric_modulus_mpa : float, optional
        Film's M = E (1 - nu) / ((1 + nu)(1 - 2 nu)); None ignores the stiffness term.
    poisson : float
        Film's Poisson's ratio nu (the paper's 0.33 by default).
    contact_modulus_mpa : float, optional
        E* of the two steel bodies (default: steel on steel).
    """
    if thickness_mm is None or thickness_mm == 0:
        return math.inf
    if not (math.isfinite(thickness_mm) and thickness_mm > 0):
        raise ValueError(f"thickness_mm must be > 0, got {thickness_mm!r}")
    if not (math.isfinite(poisson) and -1.0 < poisson < 0.5):
        raise ValueError(f"poisson must lie in (-1, 0.5), got {poisson!r}")
    base = TIP_SCALE * float(thickness_mm) * (1.0 - 2.0 * poisson)
    if oedometric_modulus_mpa is None:
        return base
    if not (math.isfinite(oedometric_modulus_mpa) and oedometric_modulus_mpa > 0):
        raise ValueError(f"oedometric_modulus_mpa must be > 0, got {oedometric_modulus_mpa!r}")
    if contact_modulus_mpa is None:
        from filmcal.hertz import contact_modulus_mpa as _estar
        contact_modulus_mpa = float(_estar())
    return base * (1.0 + TIP_STIFFNESS_FACTOR * oedometric_modulus_mpa / contact_modulus_mpa)


def tributary_areas_mm2(r_mm: np.ndarray) -> np.ndarray:
    """``int phi_i 2 pi r dr`` of the linear hat functions on the nodes ``r_mm``."""
    r = np.asarray(r_mm, dtype=float)
    h = np.diff(r)
    areas = np.zeros(r.size)
    areas[:-1] += 2 * np.pi * h * (2 * r[:-1] + r[1:]) / 6.0
    areas[1:] += 2 * np.pi * h * (r[:-1] + 2 * r[1:]) / 6.0
    return areas


def _shape(q: np.ndarray, a: float, tip_mm: float) -> np.ndarray:
    """Unit profile ``sqrt(q (1 + q / (2 a l)))`` (q clipped at 0)."""
    q = np.clip(q, 0.0, None)
    w = 0.0 if math.isinf(tip_mm) else 1.0 / (2.0 * a * tip_mm)
    return np.sqrt(q * (1.0 + w * q))


def _hat_integrals(r: np.ndarray, nodes: np.ndarray, a: float, tip_mm: float) -> np.ndarray:
    """``int shape(r) phi_i(r) 2 pi r dr`` for the given nodes (unit amplitude).

    Each element half is integrated in ``t = sqrt(a - r)``, which makes the
    square-root tip smooth for Gauss quadrature (all halves at once).
    """
    n = r.size
    prev = np.maximum(nodes - 1, 0)
    nxt = np.minimum(nodes + 1, n - 1)
    # two halves per node: [r_{i-1}, r_i] rising, [r_i, r_{i+1}] falling
    lo = np.concatenate([r[prev], r[nodes]])
    hi = np.concatenate([r[nodes], r[nxt]])
    anchor = np.concatenate([r[prev], r[nxt]])
    sign = np.concatenate([np.ones(nodes.size), -np.ones(nodes.size)])
    hi = np.minimum(hi, a)
    length = np.abs(np.concatenate([r[nodes] - r[prev], r[nxt] - r[nodes]]))
    use = (hi > lo) & (length > 0)
    t_lo = np.sqrt(np.clip(a - hi, 0.0, None))
    t_hi = np.sqrt(np.clip(a - lo, 0.0, None))
    half = 0.5 * (t_hi - t_lo)
    t = half[:, None] * _GAUSS_X[None, :] + (0.5 * (t_hi + t_lo))[:, None]
    x = a - t * t
    phi = sign[:, None] * (x - anchor[:, None]) / np.where(use, length, 1.0)[:, None]
    f = _shape(a * a - x * x, a, tip_mm) * phi * (4.0 * np.pi) * x * t
    piece = np.where(use, half * (f @ _GAUSS_W), 0.0)
    return piece[: nodes.size] + piece[nodes.size:]


@dataclass
class RadialProfile:
    """A continuous reading of an axisymmetric nodal pressure profile.

    Attributes
    ----------
    r_mm, pressure_mpa : ndarray
        The nodes and their nodal pressures.
    edge_mm : float
        The zero-pressure edge (0 without contact).
    amplitude : float
        ``c`` of the fitted edge profile (nan when the fallback was used).
    tip_mm : float
        Tip length used (inf: Hertzian edge).
    window_start_mm : float
        Inside this radius the profile interpolates ``p**2`` between nodes;
        beyond it, the fitted edge profile holds.
    fitted : bool
        False when too few loaded nodes allowed a fit (the edge is then the
        middle of the element beyond the last loaded node).
    misfit : float
        RMS residual of the fit relative to the largest pressure in the window.
    """

    r_mm: np.ndarray = field(repr=False)
    pressure_mpa: np.ndarray = field(repr=False)
    edge_mm: float
    amplitude: float
    tip_mm: float
    window_start_mm: float
    fitted: bool
    misfit: float

    def __call__(self, r_mm: np.ndarray) -> np.ndarray:
        """Pressure (MPa) at radii `r_mm` (0 beyond the edge)."""
        r = np.asarray(r_mm, dtype=float)
        p2 = np.interp(r, self.r_mm, np.clip(self.pressure_mpa, 0.0, None) ** 2)
        out = np.sqrt(p2)
        if self.fitted:
            tail = r >= self.window_start_mm
            out = np.where(tail, self.amplitude * _shape(self.edge_mm**2 - r * r, self.edge_mm, self.tip_mm),
                           out)
        return np.where(r < self.edge_mm, out, 0.0)

    def level_radius_mm(self, level_mpa: float) -> float:
        """Outermost radius where the pressure equals `level_mpa` (0 if it never reaches it)."""
        if not (math.isfinite(level_mpa) and level_mpa >= 0):
            raise ValueError(f"level_mpa must be finite and >= 0, got {level_mpa!r}")
        if level_mpa == 0:
            return self.edge_mm
        r, p = self.r_mm, self.pressure_mpa
        if self.fitted:
            # the fitted tail first: it is monotonic in r between window start and edge
            r0 = self.window_start_mm
            if float(self(np.array([r0]))[0]) >= level_mpa:
                lo, hi = r0, self.edge_mm
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if float(self(np.array([mid]))[0]) >= level_mpa else (lo, mid)
                return 0.5 * (lo + hi)
            inner = r < r0
            r, p = np.append(r[inner], r0), np.append(p[inner], float(self(np.array([r0]))[0]))
        above = np.flatnonzero(p >= level_mpa)
        if above.size == 0:
            return 0.0
        k = int(above[-1])
        if k + 1 >= r.size:
            return float(r[k])
        p0, p1 = p[k] ** 2, max(p[k + 1], 0.0) ** 2
        return float(r[k] + (r[k + 1] - r[k]) * (p0 - level_mpa**2) / (p0 - p1))

    def integral_mm2(self, fn: Callable[[np.ndarray], np.ndarray], per_element: int = 32) -> float:
        """``int fn(p(r)) 2 pi r dr`` over the contact (mm^2 times fn's unit)."""
        if self.edge_mm <= 0:
            return 0.0
        r = self.r_mm[self.r_mm < self.edge_mm]
        knots = np.append(r, self.edge_mm)
        t = (np.arange(per_element) + 0.5) / per_element
        x = (knots[:-1, None] + np.diff(knots)[:, None] * t[None, :]).ravel()
        dx = np.repeat(np.diff(knots) / per_element, per_element)
        return float(np.sum(fn(self(x)) * 2.0 * np.pi * x * dx))


def read_radial_profile(r_mm: np.ndarray, pressure_mpa: np.ndarray, tip_mm: float = math.inf,
                        window_mm: float | None = None, samples: str = "nodal",
                        edge_mm: float | None = None) -> RadialProfile:
    """Read an axisymmetric nodal pressure profile (see the module notes).

    Parameters
    ----------
    r_mm : ndarray
        Radii of the nodes, ascending from the axis (r = 0).
    pressure_mpa : ndarray
        Nodal pressures (nodal force over tributary area); loaded where > 0.
    tip_mm : float
        Tip length of the edge (:func:`film_tip_length_mm`); inf for a
        Hertzian edge (no film).
    window_mm : float, optional
        Nodes within this distance inside the last loaded node are fitted;
        default :data:`EDGE_WINDOW_MM` with a film (finite tip),
        :data:`HERTZ_WINDOW_MM` without.
    samples : {'nodal', 'point'}
        ``nodal``: nodal forces over tributary areas of linear elements (the
        FE model's pressures), fitted through their hat-function integrals;
        ``point``: pressures at the points themselves (e.g. cell centres of a
        grid along a line through the centre of a contact).
    edge_mm : float, optional
        The edge when it is known from elsewhere (the FE model's closing-load
        reading, :mod:`filmcal.fem.model`): only the amplitude ``c`` is then
        fitted, and the edge is this value.

    Returns
    -------
    RadialProfile
    """
    r = np.asarray(r_mm, dtype=float)
    p = np.asarray(pressure_mpa, dtype=float)
    if r.ndim != 1 or r.shape != p.shape or r.size < 2 or np.any(np.diff(r) <= 0):
        raise ValueError("r_mm must be ascending and of the same length as pressure_mpa (>= 2 nodes)")
    if not (tip_mm > 0):
        raise ValueError(f"tip_mm must be > 0 (inf for no film), got {tip_mm!r}")
    if window_mm is None:
        window_mm = HERTZ_WINDOW_MM if math.isinf(tip_mm) else EDGE_WINDOW_MM
    if not (window_mm > 0):
        raise ValueError(f"window_mm must be > 0, got {window_mm!r}")
    if samples not in ("nodal", "point"):
        raise ValueError(f"samples must be 'nodal' or 'point', got {samples!r}")
    loaded = np.flatnonzero(p > 0)
    if loaded.size == 0:
        return RadialProfile(r, p, 0.0, math.nan, tip_mm, 0.0, False, math.nan)
    k = int(loaded[-1])
    h_out = float(r[k + 1] - r[k]) if k + 1 < r.size else float(r[k] - r[k - 1])
    r_next = float(r[k + 1]) if k + 1 < r.size else float(r[k]) + h_out
    fallback = RadialProfile(r, p, 0.5 * (float(r[k]) + r_next), math.nan, tip_mm, r_next, False, math.nan)
    nodes = np.flatnonzero((r >= r[k] - window_mm - 1e-9) & (np.arange(r.size) <= k + 1))
    if k < 2 or np.count_nonzero(p[nodes] > 0) < 2 or k + 1 >= r.size:
        return fallback
    areas = tributary_areas_mm2(r)[nodes]
    target = p[nodes]
    scale = max(float(target.max()), 1e-300)

    def solve_amplitude(a: float) -> tuple[float, float]:
        if samples == "nodal":
            unit = _hat_integrals(r, nodes, a, tip_mm) / areas
        else:
            unit = _shape(a * a - r[nodes] ** 2, a, tip_mm)
        denom = float(unit @ unit)
        c = float(unit @ target) / denom if denom > 0 else 0.0
        res = (c * unit - target) / scale
        return c, float(res @ res)

    if edge_mm is not None:
        if not (math.isfinite(edge_mm) and edge_mm > r[k - 1]):
            raise ValueError(f"edge_mm must lie beyond the last loaded node but one ({r[k - 1]:g} mm), got {edge_mm!r}")
        c, cost = solve_amplitude(float(edge_mm))
        if not c > 0:
            return fallback
        return RadialProfile(r, p, float(edge_mm), c, tip_mm, float(r[nodes[0]]), True, math.sqrt(cost / nodes.size))

    from scipy.optimize import minimize_scalar

    lo, hi = float(r[k - 1]), r_next + h_out
    grid = np.linspace(lo, hi, 13)
    costs = [solve_amplitude(a)[1] for a in grid]
    j = int(np.argmin(costs))
    bracket_lo, bracket_hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    best = minimize_scalar(lambda a: solve_amplitude(a)[1], bounds=(bracket_lo, bracket_hi),
                           method="bounded", options={"xatol": 1e-7})
    a = float(best.x)
    c, cost = solve_amplitude(a)
    if not (c > 0 and math.isfinite(a)):
        return fallback
    start = float(r[nodes[0]])
    return RadialProfile(r, p, a, c, tip_mm, start, True, math.sqrt(cost / nodes.size))


@dataclass
class GridField:
    """A cell-centred pressure field on a regular grid, read with sub-cell accuracy.

    Contours are taken of ``p**power``, extended one ring of cells beyond the
    loaded region by linear extrapolation along the grid lines, so that the
    zero level lies where the extrapolated field vanishes (not at the centres
    of the first unloaded cells) and a level close to the edge is interpolated
    correctly. The power follows the pressure profile near the edge: 2 for a
    contact without film (``p**2`` is linear across a Hertzian edge, where
    ``p`` has a square-root tip), 1 through a film (the film's springs make
    ``p`` rise linearly from the edge; contouring ``p**2`` there moved an
    activation contour by up to 0.015 mm with the edge's phase within a
    0.1 mm cell, against 0.004 mm with ``p``).

    Parameters
    ----------
    x_mm, y_mm : ndarray
        Cell-centre coordinates along the two grid axes (uniform, ascending).
    pressure_mpa : ndarray, shape (len(x_mm), len(y_mm))
        Cell pressures, indexed ``[ix, iy]``.
    power : {2, 1}
        The contoured power of the pressure (:data:`FILM_CONTOUR_POWER` with a film).
    """

    x_mm: np.ndarray
    y_mm: np.ndarray
    pressure_mpa: np.ndarray
    power: float = 2.0

    def __post_init__(self) -> None:
        self.x_mm = np.asarray(self.x_mm, dtype=float)
        self.y_mm = np.asarray(self.y_mm, dtype=float)
        self.pressure_mpa = np.asarray(self.pressure_mpa, dtype=float)
        if self.pressure_mpa.shape != (self.x_mm.size, self.y_mm.size):
            raise ValueError(f"pressure_mpa must have shape (len(x_mm), len(y_mm)) = "
                             f"({self.x_mm.size}, {self.y_mm.size}), got {self.pressure_mpa.shape}")
        for name, v in (("x_mm", self.x_mm), ("y_mm", self.y_mm)):
            if v.size < 2 or np.any(np.diff(v) <= 0):
                raise ValueError(f"{name} must be ascending with at least 2 cells")
        if not np.all(np.isfinite(self.pressure_mpa)):
            raise ValueError("pressure_mpa must be finite")
        if self.power not in (1, 2):
            raise ValueError(f"power must be 1 (through a film) or 2 (without), got {self.power!r}")

    @property
    def cell_area_mm2(self) -> float:
        return float((self.x_mm[1] - self.x_mm[0]) * (self.y_mm[1] - self.y_mm[0]))

    def contoured_extended(self) -> np.ndarray:
        """``p**power`` on loaded cells, its linear extrapolation (< 0) on their
        unloaded 4-neighbours, and ``-max(p**power)`` further out."""
        p = np.clip(self.pressure_mpa, 0.0, None)
        f = p * p if self.power == 2 else p
        loaded = p > 0
        big = float(f.max()) if f.size else 1.0
        total = np.zeros_like(f)
        count = np.zeros_like(f)
        for axis in (0, 1):
            for step in (1, -1):
                # cell j unloaded, j - step loaded (i), j - 2 step (ii)
                i = np.roll(f, step, axis=axis)
                ii = np.roll(f, 2 * step, axis=axis)
                li = np.roll(loaded, step, axis=axis)
                lii = np.roll(loaded, 2 * step, axis=axis)
                valid = ~loaded & li
                n = f.shape[axis]
                edge_idx = np.arange(n)
                wrap = (edge_idx < 2) if step == 1 else (edge_idx >= n - 2)
                shape = [1, 1]
                shape[axis] = n
                valid &= ~wrap.reshape(shape)
                extrap = np.where(lii, 2.0 * i - ii, -i)
                extrap = np.minimum(extrap, -1e-6 * np.maximum(i, 1e-300))
                total += np.where(valid, extrap, 0.0)
                count += valid
        out = np.where(loaded, f, -big)
        ring = count > 0
        out[ring] = total[ring] / count[ring]
        return out

    def level_area_mm2(self, level_mpa: float) -> tuple[float, list[np.ndarray]]:
        """Area (mm^2) and outline rings of the region where the pressure exceeds `level_mpa`.

        ``level_mpa = 0`` gives the zero-pressure edge.
        """
        if not (math.isfinite(level_mpa) and level_mpa >= 0):
            raise ValueError(f"level_mpa must be finite and >= 0, got {level_mpa!r}")
        rings = next(self._outlines([float(level_mpa)]))
        return float(outline_area_mm2(rings)), rings

    def _outlines(self, levels_mpa: Sequence[float]) -> Iterator[list[np.ndarray]]:
        """The outline rings above each level in turn, from one contour generator of the field."""
        import contourpy

        f = self.contoured_extended()
        top = float(f.max())
        gen = contourpy.contour_generator(self.x_mm, self.y_mm, f.T, fill_type=contourpy.FillType.OuterOffset)
        for level_mpa in levels_mpa:
            level = level_mpa**self.power
            if top <= level:
                yield []
                continue
            points, offsets = gen.filled(level, top + 1.0)
            yield [np.asarray(pts[lo:hi]) for pts, offs in zip(points, offsets)
                   for lo, hi in zip(offs[:-1], offs[1:])]

    def integral_mm2(self, fn: Callable[[np.ndarray], np.ndarray], nodes: int = INTEGRAL_NODES) -> float:
        """``int fn(p) dA`` over the loaded region (mm^2 times fn's unit).

        Read as layers: ``int fn(p) dA = fn(0+) A(0) + int fn'(q) A(q) dq`` over ``0 < q < p_max``, ``A(q)``
        the area where the pressure exceeds ``q`` (`level_area_mm2`, sub-cell contours), by Gauss-Legendre
        quadrature with `nodes` nodes over the variation of ``fn`` (tabulated at 4096 pressures): for a
        nondecreasing ``fn`` (a stain probability, a coverage) that is ``int A(fn^-1(u)) du``; a run over which
        ``fn`` falls has its own nodes, its layers counted negatively. A sum of ``fn`` over the cells instead moved the capsule imprint
        of a sphere through MS film by up to 0.0025 mm in radius with the grid's phase against the patch; read
        as layers, by 0.0002 mm. Contours interpolated linearly between cell centres lie inside a concave
        field's, so the layers read the capsule imprint of a sphere (R 300 mm, 35 kN, a film of 1200 MPa)
        0.0004-0.0005 mm smaller at 0.1 mm cells than at 0.025 mm (the cell sum: -0.0001..+0.0002 mm), an
        error the transfer term, fitted on the same grid, carries.
        """
        p = np.clip(self.pressure_mpa, 0.0, None)
        top = float(p.max()) if p.size else 0.0
        if not top > 0.0:
            return 0.0
        table_p = np.linspace(0.0, top, 4097)[1:]
        table_u = np.asarray(fn(table_p), dtype=float)
        step = np.diff(table_u)
        variation = np.concatenate([[0.0], np.cumsum(np.abs(step))])
        total = float(variation[-1])
        # the runs over which fn rises or falls (a flat step joins the run before it), each by Gauss-Legendre
        # nodes in its variation, as many as its share of the total (at least 4)
        moving = np.flatnonzero(step != 0.0)
        turns = moving[1:][np.sign(step[moving[1:]]) != np.sign(step[moving[:-1]])]
        levels, weights = [0.0], []
        for lo, hi in zip([0, *turns], [*turns, step.size]):
            v0, v1 = float(variation[lo]), float(variation[hi])
            if not v1 - v0 > 1e-12 * total:
                continue
            x, w = np.polynomial.legendre.leggauss(max(4, round(nodes * (v1 - v0) / total)))
            v = v0 + 0.5 * (v1 - v0) * (x + 1.0)
            k = np.clip(np.searchsorted(variation, v, side="right") - 1, lo, hi - 1)  # the table step of each node
            frac = (v - variation[k]) / np.where(step[k] != 0.0, np.abs(step[k]), 1.0)
            levels += list(table_p[k] + frac * (table_p[k + 1] - table_p[k]))
            weights += list(0.5 * (v1 - v0) * w * np.sign(step[k]))
        areas = np.array([outline_area_mm2(rings) for rings in self._outlines(levels)])
        return float(table_u[0] * areas[0] + np.dot(weights, areas[1:]))


#: The nominal contact of rough bodies: where the nominal pressure exceeds this fraction of its maximum. A
#: rough contact's pressure decays smoothly beyond the smooth edge, so its support depends on where the tail
#: is cut; 1 % of the maximum lies within 5e-5 of a smooth Hertzian edge in radius.
NOMINAL_LEVEL = 0.01


def nominal_area_mm2(x_mm: np.ndarray, y_mm: np.ndarray, pressure_mpa: np.ndarray,
                     level: float = NOMINAL_LEVEL) -> float:
    """Area (mm^2) where a gridded nominal pressure exceeds ``level`` times its maximum."""
    p = np.asarray(pressure_mpa, dtype=float)
    return GridField(np.asarray(x_mm, float), np.asarray(y_mm, float), p).level_area_mm2(level * float(p.max()))[0]
