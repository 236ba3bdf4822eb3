"""Graded tensor-product meshes of the axisymmetric sphere-on-flat model.

Coordinates: x[0] = r (radial, mm), x[1] = z (axial, mm). The flat occupies
-L <= z <= 0, the film 0 <= z <= t, the sphere body rests on the film with its
lowest point at z = t. Every body is a tensor grid in (r, depth from the contact
face), so its nodes on the contact face share the radial positions r_0 < r_1 < ...
of the film's nodes: contact pairs are node to node.

The sphere body's contact face is the exact sphere z = t + R - sqrt(R^2 - r^2);
the body's top is flat at z = t + L (the depth coordinate is morphed linearly).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from skfem import MeshQuad

from filmcal._validation import check_positive, check_range
from filmcal.contact.names import FILM_LAYERS

__all__ = ["FILM_LAYERS", "MeshSettings", "BodyGrid", "graded_coordinates", "sphere_grid", "flat_grid", "film_grid",
           "default_contact_zone_mm"]


@dataclass(frozen=True)
class MeshSettings:
    """Mesh density and extent of the axisymmetric model.

    Parameters
    ----------
    element_size_mm : float
        Element size h in the contact zone (radial size of the contact-face and
        film elements, and depth of the first element rows). The paper uses 0.1 mm.
    far_element_size_mm : float
        Element size far from the contact (the paper: 1.25 mm).
    body_size_mm : float
        Width and height of each steel body's cross-section (the paper: 50 mm).
    growth_ratio : float
        Ratio between neighbouring element sizes where the mesh grades from
        fine to far.
    fine_depth_mm : float
        Depth below the contact face meshed with uniform elements of size h
        before grading starts.
    contact_zone_mm : float or None
        Radius of the refined zone on the contact faces where contact may occur
        (and of the film). ``None`` chooses 1.6 times the Hertz radius of the
        sphere at 150 kN, at least 4 mm.
    """

    element_size_mm: float = 0.1
    far_element_size_mm: float = 1.25
    body_size_mm: float = 50.0
    growth_ratio: float = 1.15
    fine_depth_mm: float = 0.3
    contact_zone_mm: float | None = None

    def __post_init__(self) -> None:
        h = check_range("element_size_mm", self.element_size_mm, 0.0, 1.0, high_open=False)
        check_positive("far_element_size_mm", self.far_element_size_mm)
        if self.far_element_size_mm < h:
            raise ValueError(f"far_element_size_mm must be >= element_size_mm ({h:g}), "
                             f"got {self.far_element_size_mm:g}")
        check_range("body_size_mm", self.body_size_mm, 5.0, 1000.0, low_open=False, high_open=False)
        check_range("growth_ratio", self.growth_ratio, 1.0, 2.0, low_open=False, high_open=False)
        check_range("fine_depth_mm", self.fine_depth_mm, 0.0, self.body_size_mm, low_open=False)
        if self.contact_zone_mm is not None:
            check_range("contact_zone_mm", self.contact_zone_mm, 20 * h, 0.6 * self.body_size_mm,
                        low_open=False, high_open=False)


def default_contact_zone_mm(sphere_radius_mm: float, settings: MeshSettings, body_modulus_mpa: float | None = None,
                            body_poisson: float | None = None) -> float:
    """Radius of the refined contact zone used when the settings leave it open: 1.6 Hertz radii at 150 kN
    (of steel bodies, or of both bodies of this modulus and Poisson's ratio), at least 4 mm."""
    if settings.contact_zone_mm is not None:
        return float(settings.contact_zone_mm)
    from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm
    e = STEEL_MODULUS_MPA if body_modulus_mpa is None else body_modulus_mpa
    nu = STEEL_POISSON if body_poisson is None else body_poisson
    zone = max(4.0, 1.6 * hertz_radius_mm(sphere_radius_mm, 150e3, e, nu))
    zone = min(zone, 0.6 * settings.body_size_mm)
    h = settings.element_size_mm
    return float(np.ceil(zone / h - 1e-9) * h)


def graded_coordinates(h_mm: float, h_far_mm: float, length_mm: float, fine_length_mm: float,
                       growth_ratio: float) -> np.ndarray:
    """Node coordinates on [0, length]: uniform size h up to `fine_length`, then
    sizes growing geometrically by `growth_ratio` up to `h_far`, then uniform.

    The last element is merged with its neighbour if it would be shorter than
    half the local size, so that no sliver element appears at the end.
    """
    n_fine = int(round(fine_length_mm / h_mm))
    x = list(np.arange(n_fine + 1) * h_mm)
    size = h_mm
    while x[-1] < length_mm - 1e-9:
        size = min(size * growth_ratio, h_far_mm)
        x.append(min(x[-1] + size, length_mm))
    if len(x) > 2 and x[-1] - x[-2] < 0.5 * (x[-2] - x[-3]):
        del x[-2]
    return np.asarray(x)


@dataclass
class BodyGrid:
    """A tensor-product quad mesh of one body with its grid bookkeeping.

    Attributes
    ----------
    mesh : skfem.MeshQuad
        The mesh in physical (r, z) coordinates.
    node_at : ndarray of int, shape (n_r, n_depth)
        Mesh node index at radial index i and depth index j (j = 0 on the
        contact face).
    n_face : int
        Number of contact-face nodes in the refined contact zone (i < n_face).
    r_face_mm : ndarray
        Radial positions of those nodes.
    """

    mesh: MeshQuad
    node_at: np.ndarray
    n_face: int
    r_face_mm: np.ndarray

    @property
    def face_nodes(self) -> np.ndarray:
        """Mesh node indices of the contact-zone face nodes, ordered by r."""
        return self.node_at[: self.n_face, 0]


def _tensor_grid(r: np.ndarray, depth: np.ndarray, z_of) -> tuple[MeshQuad, np.ndarray]:
    """Quad mesh on the tensor grid r x depth with physical z = z_of(r, depth)."""
    rr, dd = np.meshgrid(r, depth, indexing="ij")
    node_at = np.arange(rr.size).reshape(rr.shape)
    p = np.vstack([rr.ravel(), z_of(rr, dd).ravel()])
    i, j = np.meshgrid(np.arange(len(r) - 1), np.arange(len(depth) - 1), indexing="ij")
    i, j = i.ravel(), j.ravel()
    corners = [node_at[i, j], node_at[i + 1, j], node_at[i + 1, j + 1], node_at[i, j + 1]]
    t = np.vstack(corners)
    # counter-clockwise in (r, z): flip where the depth axis points downwards
    area2 = ((p[0, t[1]] - p[0, t[0]]) * (p[1, t[3]] - p[1, t[0]])
             - (p[1, t[1]] - p[1, t[0]]) * (p[0, t[3]] - p[0, t[0]]))
    flip = area2 < 0
    t[:, flip] = t[::-1][:, flip]
    return MeshQuad(p, t), node_at


def _radial_and_depth(zone_mm: float, s: MeshSettings) -> tuple[np.ndarray, np.ndarray]:
    r = graded_coordinates(s.element_size_mm, s.far_element_size_mm, s.body_size_mm, zone_mm, s.growth_ratio)
    depth = graded_coordinates(s.element_size_mm, s.far_element_size_mm, s.body_size_mm,
                               s.fine_depth_mm, s.growth_ratio)
    return r, depth


#: The smallest sphere radius over the body's size: at R = L the cap's face reaches the body's top at its rim
#: and the outer elements collapse (zero Jacobian); at 1.1 L the rim's face is 0.54 L deep.
MIN_SPHERE_TO_BODY = 1.1


def sphere_grid(sphere_radius_mm: float, settings: MeshSettings, film_thickness_mm: float = 0.0) -> BodyGrid:
    """Mesh of the sphere body: exact spherical contact face, flat top.

    Its lowest point lies at z = film_thickness_mm.
    """
    R = check_positive("sphere_radius_mm", sphere_radius_mm)
    L = settings.body_size_mm
    if R < round(MIN_SPHERE_TO_BODY * L, 9):
        raise ValueError(f"sphere_radius_mm must be at least {MIN_SPHERE_TO_BODY:g} times the FE body's size "
                         f"({round(MIN_SPHERE_TO_BODY * L, 9):g} mm) for a spherical cap body, got {R:g}")
    zone = default_contact_zone_mm(R, settings)
    r, depth = _radial_and_depth(zone, settings)

    def z_of(rr, dd):
        face = R - np.sqrt(R**2 - rr**2)
        return film_thickness_mm + face + dd * (L - face) / L

    mesh, node_at = _tensor_grid(r, depth, z_of)
    n_face = int(np.searchsorted(r, zone + 1e-9))
    return BodyGrid(mesh, node_at, n_face, r[:n_face].copy())


def flat_grid(settings: MeshSettings, zone_mm: float) -> BodyGrid:
    """Mesh of the flat body, -L <= z <= 0, contact face at z = 0."""
    r, depth = _radial_and_depth(zone_mm, settings)
    mesh, node_at = _tensor_grid(r, depth, lambda rr, dd: -dd)
    n_face = int(np.searchsorted(r, zone_mm + 1e-9))
    return BodyGrid(mesh, node_at, n_face, r[:n_face].copy())


def film_grid(r_face_mm: np.ndarray, thickness_mm: float, layers: int = 1) -> BodyGrid:
    """Mesh of the film: the contact-zone radial nodes times `layers` element rows.

    Depth index j = 0 is the film's bottom (on the flat), j = layers its top.
    """
    t = check_positive("film_thickness_mm", thickness_mm)
    if int(layers) != layers or layers < 1:
        raise ValueError(f"film_layers must be an integer >= 1, got {layers!r}")
    depth = np.linspace(0.0, t, int(layers) + 1)
    mesh, node_at = _tensor_grid(np.asarray(r_face_mm), depth, lambda rr, dd: dd)
    return BodyGrid(mesh, node_at, len(r_face_mm), np.asarray(r_face_mm).copy())
