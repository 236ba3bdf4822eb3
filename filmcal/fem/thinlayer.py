"""An independent second method: the thin-layer model of sphere on flat with film.

Both steel bodies are elastic half-spaces (axisymmetric boundary elements:
uniform pressure on rings, exact surface displacements from the closed-form
solution for a uniformly loaded disc, Johnson, Contact Mechanics, eqs. 3.25,
3.26); the film is a layer of independent springs of stiffness M/t per unit
area in series with them, M = E(1-nu)/((1+nu)(1-2nu)) being the oedometric
modulus of a film held laterally. The contact problem is the same LCP as in
the FE model but shares none of its discretisation.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ellipe, ellipk

from filmcal._validation import (FILM_MODULUS_MPA_BOUNDS, FILM_THICKNESS_MM_BOUNDS, check_poisson, check_positive,
                                 check_range)
from filmcal.fem.contact import CLOSED, OPEN, ContactState, PairSystem, solve_pairs
from filmcal.hertz import contact_modulus_mpa, hertz_radius_mm

__all__ = ["ThinLayerResult", "disc_displacement_mm", "thin_layer_contact"]


def disc_displacement_mm(r_mm: np.ndarray, disc_radius_mm: float, contact_modulus_mpa: float) -> np.ndarray:
    """Mutual surface approach at radius r from unit pressure on a disc of radius c.

    u(r) = 4 c E(r/c) / (pi E*) for r <= c and
    u(r) = 4 r [E(c/r) - (1 - c^2/r^2) K(c/r)] / (pi E*) for r > c,
    with complete elliptic integrals of modulus k (scipy takes m = k^2).
    """
    r = np.asarray(r_mm, dtype=float)
    c = float(disc_radius_mm)
    out = np.empty_like(r)
    inside = r <= c
    out[inside] = 4.0 * c * ellipe((r[inside] / c) ** 2) / np.pi
    ro = r[~inside]
    m = (c / ro) ** 2
    out[~inside] = 4.0 * ro * (ellipe(m) - (1.0 - m) * ellipk(m)) / np.pi
    return out / contact_modulus_mpa


@dataclass
class ThinLayerResult:
    """Contact of the thin-layer model (lengths mm, pressures MPa).

    ``edge_mm`` brackets the edge between the centres of the last loaded ring and the first unloaded one;
    ``contact_radius_mm`` is the zero of the pressure between them, read as the pressure falls to the edge:
    linearly behind springs, as a square root (``p**2`` linearly) without a film.
    """

    contact_radius_mm: float
    edge_mm: tuple[float, float]
    max_pressure_mpa: float
    r_mm: np.ndarray
    pressure_mpa: np.ndarray
    approach_mm: float
    converged: bool


def thin_layer_contact(sphere_radius_mm: float, force_n: float, film_modulus_mpa: float | None = None,
                       film_poisson: float = 0.33, film_thickness_mm: float = 0.09,
                       ring_width_mm: float = 0.02, zone_mm: float | None = None) -> ThinLayerResult:
    """Solve sphere-on-flat contact of two steel half-spaces with a spring film between.

    Parameters
    ----------
    sphere_radius_mm, force_n : float
        Sphere radius R (mm) and normal force F (N).
    film_modulus_mpa : float or None
        Film Young's modulus; None for no film.
    film_poisson, film_thickness_mm : float
        Film Poisson's ratio and thickness.
    ring_width_mm : float
        Width of the uniform-pressure rings.
    zone_mm : float, optional
        Outer radius of the discretised zone (default 2.2 Hertz radii + 2 mm).

    Returns
    -------
    ThinLayerResult
        ``contact_radius_mm`` is the zero of the line through the last two
        loaded rings' pressures (springs) or squared pressures (no film),
        within ``edge_mm`` (the centres of the last loaded ring and the first
        unloaded one). At R 300-450 mm through films of 1200-2800 MPa it
        agrees within 0.0001 mm between rings of 0.01, 0.005 and 0.0025 mm,
        where the centre of the first unloaded ring (the reading before 29
        Nov 2026) lay up to half a ring outside.
    """
    R = check_positive("sphere_radius_mm", sphere_radius_mm)
    F = check_positive("force_n", force_n)
    ring = check_positive("ring_width_mm", ring_width_mm)
    estar = contact_modulus_mpa()
    a_h = hertz_radius_mm(R, F)
    zone = check_positive("zone_mm", zone_mm) if zone_mm is not None else 2.2 * a_h + 2.0
    if zone < 10.0 * ring or zone > 1e4 * ring:
        raise ValueError(f"zone_mm / ring_width_mm must be 10 to 10000 rings, got {zone / ring:g}")
    edges = np.arange(0.0, zone + ring / 2, ring)
    mid = 0.5 * (edges[1:] + edges[:-1])
    area = np.pi * (edges[1:] ** 2 - edges[:-1] ** 2)
    # C[i, j]: approach at ring i from unit pressure on ring j (annulus = disc - disc)
    discs = np.stack([disc_displacement_mm(mid, c, estar) if c > 0 else np.zeros_like(mid) for c in edges])
    C = (discs[1:] - discs[:-1]).T
    spring = 0.0
    if film_modulus_mpa is not None:
        e = check_range("film_modulus_mpa", film_modulus_mpa, *FILM_MODULUS_MPA_BOUNDS, low_open=False,
                        high_open=False)
        nu = check_poisson("film_poisson", film_poisson)
        t = check_range("film_thickness_mm", film_thickness_mm, *FILM_THICKNESS_MM_BOUNDS, low_open=False,
                        high_open=False)
        spring = t * (1 + nu) * (1 - 2 * nu) / (e * (1 - nu))
    H = C / area[None, :] + np.diag(spring / area)  # unknowns: ring forces (N)
    gap = R - np.sqrt(R**2 - mid**2)
    n = len(mid)
    pairs = PairSystem(np.arange(n), np.zeros(0, int), np.zeros(0), np.zeros(0, int),
                       np.zeros((0, n)), np.zeros(0))
    status = np.where(mid <= a_h, CLOSED, OPEN)
    state = solve_pairs(H, gap, -np.ones(n), F, pairs, ContactState(np.zeros(n), 0.0, status, np.zeros(0, int)),
                        np.zeros(n), max_iterations=200)
    p = np.where(state.normal_status == CLOSED, state.forces / area, 0.0)
    k = int(np.flatnonzero(p > 0)[-1])
    if k >= n - 1:  # the contact reaches the last ring: the zone truncates it
        raise ValueError(f"the contact reaches the edge of the zone ({zone:g} mm): give a larger zone_mm (a "
                         "softer or thicker film spreads it beyond the default 2.2 Hertz radii + 2 mm)")
    edge = (float(mid[k]), float(mid[min(k + 1, n - 1)]))
    q = p if spring > 0.0 else p**2  # what falls linearly to the edge
    radius = edge[0]
    if k > 0 and q[k - 1] > q[k]:
        radius = min(edge[0] + q[k] * (mid[k] - mid[k - 1]) / (q[k - 1] - q[k]), edge[1])
    return ThinLayerResult(float(radius), edge, float(p.max()), mid, p, state.rigid_w, state.converged)
