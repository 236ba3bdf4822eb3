"""The result of one FE evaluation and the sub-element reading of the contact radius."""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

__all__ = ["FEResult", "read_contact_radius"]


def read_contact_radius(r_mm: np.ndarray, pressure_mpa: np.ndarray, active: np.ndarray,
                        window_mm: tuple[float, float] = (1.0, 0.2), max_misfit: float = 1e-3) -> float:
    """Contact radius read between the nodes from the pressure profile near the edge.

    An element-level reading (the last node in contact) is off by up to half
    an element, and the last one or two nodal pressures carry the O(h) error
    of the discrete contact edge. The reading therefore fits the edge profile

        p(r) = b (a^2 - r^2)^gamma,   gamma free in [0.3, 1.5],

    to the nodal pressures in a fixed physical window a - 1.0 <= r <= a - 0.2
    mm inside the edge (iterated, as a is not known beforehand), where the FE
    pressure is mesh-converged, and returns the fitted a. A Hertz edge has
    gamma = 1/2 (the fit recovers it on steel-on-steel cases); a film, stiff in
    thickness only at these scales (the thin-layer, Winkler-like limit), pushes
    gamma towards 1. Because the window is physical, the reading converges with
    the mesh. On meshes much finer than the film thickness, the pressure shows
    a sharper tail about one film thickness wide beyond the fitted edge (a few
    hundredths of a mm), below the 0.1 mm resolution of the film itself.

    With friction, stick-slip transitions put kinks into the profile; when the
    fit's RMS misfit (relative to the largest pressure in the window) exceeds
    `max_misfit`, the window is narrowed to a - 0.5 <= r <= a - 0.2 mm.

    Parameters
    ----------
    r_mm : ndarray
        Radial positions of the face nodes (ascending).
    pressure_mpa : ndarray
        Nodal contact pressure (nodal force over the node's tributary area).
    active : ndarray of bool
        Nodes in contact.
    window_mm : (float, float)
        Outer and inner distance of the fit window from the edge.
    max_misfit : float
        Relative RMS misfit above which the window is narrowed.

    Returns
    -------
    float
        Contact radius (mm). With fewer than three contact nodes, the middle of
        the element beyond the last contact node.
    """

    idx = np.flatnonzero(active)
    if len(idx) == 0:
        return 0.0
    k = int(idx[-1])
    h = r_mm[1] - r_mm[0]
    r_next = r_mm[k + 1] if k + 1 < len(r_mm) else r_mm[k] + h
    fallback = float(0.5 * (r_mm[k] + r_next))
    if k < 3:
        return fallback
    outer, inner = window_mm
    a, misfit = _fit_edge(r_mm, pressure_mpa, active, k, float(r_mm[k]), outer, inner, r_next)
    if a is not None and misfit > max_misfit and outer > 0.5:
        a, misfit = _fit_edge(r_mm, pressure_mpa, active, k, a, 0.5, inner, r_next)
    return fallback if a is None else a


def _fit_edge(r_mm, pressure_mpa, active, k, a, outer, inner, r_next) -> tuple[float | None, float]:
    """Fit b (a^2 - r^2)^gamma over the window [a - outer, a - inner] (iterated on a)."""
    from scipy.optimize import least_squares

    misfit = np.inf
    for _ in range(3):
        sel = np.flatnonzero((r_mm >= a - outer) & (r_mm <= a - inner) & active)
        sel = sel[sel < k]
        if len(sel) < 3:
            sel = np.arange(max(0, k - 3), k)
        p = pressure_mpa[sel]
        if np.any(p <= 0):
            return None, misfit
        b0 = p[0] / np.sqrt(max(a * a - r_mm[sel[0]] ** 2, 1e-12))

        def residual(q, r=r_mm[sel], p=p):
            return (q[1] * np.clip(q[0] ** 2 - r**2, 1e-300, None) ** q[2] - p) / p.max()

        lower = [float(r_mm[sel[-1]]) + 1e-9, 0.0, 0.3]
        upper = [float(r_next) + outer, np.inf, 1.5]
        start = [min(max(a, lower[0] + 1e-6), upper[0] - 1e-6), b0, 0.5]
        fit = least_squares(residual, start, bounds=(lower, upper), x_scale=[0.1, b0, 0.1])
        if not fit.success:
            return None, misfit
        a = float(fit.x[0])
        misfit = float(np.sqrt(np.mean(fit.fun**2)))
    return a, misfit


@dataclass
class FEResult:
    """The outcome of one evaluation of the sphere-on-flat FE model.

    Lengths in mm, forces in N, pressures in MPa. ``converged = False`` comes
    with a ``reason``; its numbers are then not to be used.
    """

    radius_mm: float
    force_n: float
    film_modulus_mpa: float | None
    film_poisson: float | None
    sphere_contact: str
    flat_contact: str
    friction_coefficient: float
    large_strain: bool
    contact_radius_mm: float
    contact_area_mm2: float
    max_pressure_mpa: float
    hertz_radius_mm: float
    approach_mm: float
    film_strain_max: float
    r_mm: np.ndarray
    pressure_mpa: np.ndarray
    gap_mm: np.ndarray
    film_strain: np.ndarray
    n_active: int
    imprint_radius_mm: float | None
    imprint_area_mm2: float | None
    activation_pressure_mpa: float | None
    converged: bool
    reason: str
    iterations: int
    elapsed_s: float
    n_dofs: int
    element_size_mm: float

    @property
    def radius_error_mm(self) -> float:
        """Contact radius minus the Hertz radius (the film's enlargement)."""
        return self.contact_radius_mm - self.hertz_radius_mm

    @property
    def hertz_area_mm2(self) -> float:
        return float(np.pi * self.hertz_radius_mm**2)

    def summary(self) -> dict:
        """The scalar fields as a JSON-ready dict (no arrays)."""
        d = {k: v for k, v in asdict(self).items() if not isinstance(v, np.ndarray)}
        d["radius_error_mm"] = self.radius_error_mm
        d["hertz_area_mm2"] = self.hertz_area_mm2
        return d
