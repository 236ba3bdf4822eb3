"""A second FE formulation of sphere-on-flat with a film, for verification.

It shares the geometry with `SphereOnFlat` (steel sphere with an exact
spherical face on a steel flat, 50 x 50 mm bodies, the film between, frictionless
at the sphere and tied to the flat) but none of its formulation:

- biquadratic 9-node Lagrange quadrilaterals (no locking of the film at
  nu up to 0.45, second-order accurate displacements), isotropic elements of
  size h in the contact zone and several element layers through the film;
- the film and the flat are one body with shared nodes (the tied interface),
  condensed onto the film's top z-DOFs; the sphere onto its face z-DOFs;
- the contact edge is read from the *closing load* of each face node: with the
  contact set fixed the solution is affine in the force, so the load at which
  the next node's gap closes is exact, and the radius at the given force is
  interpolated between the two nodes whose closing loads bracket it
  (a^3 linear in F, exact for Hertz). No pressure profile is fitted.
- with ``kinematics='large'`` the film is neo-Hookean (`filmcal.fem.neohookean`,
  written independently of the production kernel): the film keeps its own
  mesh, tied to the flat condensed onto its top face, Newton iterations run
  at each contact set, and the closing loads are found by Newton with the
  force among the unknowns.

It is slower than `SphereOnFlat` (seconds per film instead of milliseconds;
10-80 s for a large-strain film at h = 0.05 mm)
and is not used by the calibration: `bench/verification.py` and the tests run
the production model against it.
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, BilinearForm, ElementQuad2, ElementVector, FacetBasis, LinearForm, MeshQuad

from filmcal._validation import check_poisson, check_positive, check_range
from filmcal.elastic import lame_parameters
from filmcal.fem.condense import condense, nested_dissection
from filmcal.fem.neohookean import minimum_jacobian, neo_hookean_force_and_tangent
from filmcal.fem.mesh import MeshSettings, default_contact_zone_mm, graded_coordinates
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm

__all__ = ["ReferenceResult", "QuadraticSphereOnFlat"]

#: Condensed lower bodies (flat with film) kept per process, shared by spheres on the same mesh.
_LOWERS: dict = {}
_LOWERS_KEPT = 4


def _constitutive(lam, mu):
    """Axisymmetric D-matrix on (eps_rr, eps_zz, eps_tt, gamma_rz)."""
    d = lam + 2.0 * mu
    return np.array([[d, lam, lam, 0.0], [lam, d, lam, 0.0], [lam, lam, d, 0.0], [0.0, 0.0, 0.0, mu]])


@BilinearForm
def _stiffness(u, v, w):
    r = np.asarray(w.x[0])
    gu, gv = np.asarray(u.grad), np.asarray(v.grad)
    eu = [gu[0, 0], gu[1, 1], np.asarray(u)[0] / r, gu[0, 1] + gu[1, 0]]
    ev = [gv[0, 0], gv[1, 1], np.asarray(v)[0] / r, gv[0, 1] + gv[1, 0]]
    D = w.D
    out = 0.0
    for i in range(4):
        for j in range(4):
            if D[i, j] != 0.0:
                out = out + D[i, j] * eu[j] * ev[i]
    return out * 2.0 * np.pi * r


@LinearForm
def _downward_traction(v, w):
    return -w.traction * v[1] * 2.0 * np.pi * w.x[0]


def _quad_mesh(points: np.ndarray, cells: np.ndarray) -> MeshQuad:
    """A MeshQuad with counter-clockwise cells."""
    p, t = points, cells.copy()
    area2 = ((p[0, t[1]] - p[0, t[0]]) * (p[1, t[3]] - p[1, t[0]])
             - (p[1, t[1]] - p[1, t[0]]) * (p[0, t[3]] - p[0, t[0]]))
    flip = area2 < 0
    t[:, flip] = t[::-1][:, flip]
    return MeshQuad(p, t)


def _grid_cells(index: np.ndarray) -> np.ndarray:
    """Quad cells of a node-index grid, where every corner index is >= 0."""
    a, b = index[:-1, :-1], index[1:, :-1]
    c, d = index[1:, 1:], index[:-1, 1:]
    keep = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    return np.vstack([a[keep], b[keep], c[keep], d[keep]])


def _midpoints(x: np.ndarray) -> np.ndarray:
    out = np.empty(2 * len(x) - 1)
    out[0::2] = x
    out[1::2] = 0.5 * (x[:-1] + x[1:])
    return out


@dataclass
class ReferenceResult:
    """Sphere-on-flat contact from the second formulation (mm, N, MPa).

    ``contact_radius_mm`` is read from the closing loads of the face nodes;
    ``bracket_mm`` are the two element vertices whose closing loads bracket the
    force, ``closing_force_n`` their closing loads.
    """

    contact_radius_mm: float
    hertz_radius_mm: float
    approach_mm: float
    max_pressure_mpa: float
    bracket_mm: tuple[float, float]
    closing_force_n: tuple[float, float]
    element_size_mm: float
    film_layers: int
    n_dofs: int
    r_mm: np.ndarray
    pressure_mpa: np.ndarray
    elapsed_s: float

    def read_imprint(self, model: str, film_type, tip_mm: float) -> float:
        """Imprint radius (mm) of `film_type` under imprint `model`, read from this solution's own nodes.

        The nodal pressures of the closed set (the face's mass matrix spreads small values beyond it), read as
        point samples with the closing-load edge; the edge shape of tip `tip_mm`
        (`filmcal.contact.reading.film_tip_length_mm`) only within 2.5 elements of it.
        """
        from filmcal.contact.imprint import get_imprint_model
        from filmcal.contact.reading import read_radial_profile

        closed = np.where(self.r_mm < self.contact_radius_mm, self.pressure_mpa, 0.0)
        profile = read_radial_profile(self.r_mm, closed, tip_mm, samples="point", edge_mm=self.contact_radius_mm,
                                      window_mm=2.5 * self.element_size_mm)
        return get_imprint_model(model).radius_from_profile(profile, film_type)


class QuadraticSphereOnFlat:
    """Sphere on flat with a film, biquadratic elements, closing-load reading.

    Parameters
    ----------
    sphere_radius_mm : float
        Sphere radius R (mm), >= the body size.
    element_size_mm : float
        Element size h in the contact zone (isotropic down to `fine_depth_mm`).
    film_thickness_mm : float
        Film thickness t (mm).
    film_layers : int, optional
        Element layers through the film (default: round(t / h), at least 1,
        so that refining h refines the film alike).
    contact_zone_mm : float, optional
        Radius of the refined zone (default as `MeshSettings`).
    fine_depth_mm : float
        Depth of uniform elements of size h below the contact faces.
    """

    def __init__(self, sphere_radius_mm: float, element_size_mm: float = 0.025, film_thickness_mm: float = 0.09,
                 film_layers: int | None = None, contact_zone_mm: float | None = None, fine_depth_mm: float = 0.3,
                 steel_modulus_mpa: float = STEEL_MODULUS_MPA, steel_poisson: float = STEEL_POISSON) -> None:
        t0 = time.perf_counter()
        self.sphere_radius_mm = R = check_positive("sphere_radius_mm", sphere_radius_mm)
        self.element_size_mm = h = check_range("element_size_mm", element_size_mm, 0.0, 0.5, high_open=False)
        self.film_thickness_mm = t = check_positive("film_thickness_mm", film_thickness_mm)
        if film_layers is None:  # isotropic elements through the film as well
            film_layers = max(1, int(round(t / h)))
        if int(film_layers) != film_layers or film_layers < 1:
            raise ValueError(f"film_layers must be an integer >= 1, got {film_layers!r}")
        self.film_layers = int(film_layers)
        settings = MeshSettings(element_size_mm=h, fine_depth_mm=fine_depth_mm, contact_zone_mm=contact_zone_mm)
        L = settings.body_size_mm
        if R < L:
            raise ValueError(f"sphere_radius_mm must be >= {L:g} mm, got {R:g}")
        zone = default_contact_zone_mm(R, settings)
        self._r = graded_coordinates(h, settings.far_element_size_mm, L, zone, settings.growth_ratio)
        self._depth = graded_coordinates(h, settings.far_element_size_mm, L, fine_depth_mm, settings.growth_ratio)
        self.n_zone = int(np.searchsorted(self._r, zone + 1e-9))
        self._steel = _constitutive(*lame_parameters(steel_modulus_mpa, steel_poisson))
        self.element = ElementVector(ElementQuad2())

        # the sphere: tensor grid in (r, depth), the face morphed onto the exact sphere
        r, d = self._r, self._depth
        nr, nd = len(r), len(d)
        idx = np.arange(nr * nd).reshape(nr, nd)
        rr, dd = np.meshgrid(r, d, indexing="ij")
        face = R - np.sqrt(R**2 - rr**2)
        pts = np.vstack([rr.ravel(), (face + dd * (L - face) / L).ravel()])
        mesh_s = _quad_mesh(pts, _grid_cells(idx))
        bs = Basis(mesh_s, self.element)
        Ks = _stiffness.assemble(bs, D=self._steel)
        top = mesh_s.facets_satisfying(lambda x: np.isclose(x[1], L))
        f_top = _downward_traction.assemble(FacetBasis(mesh_s, self.element, facets=top), traction=1.0 / (np.pi * L**2))
        on_axis = np.isclose(bs.doflocs[0], 0.0)
        ax_r = np.flatnonzero(on_axis & (np.arange(bs.N) % 2 == 0))
        top_axis_z = np.flatnonzero(on_axis & np.isclose(bs.doflocs[1], L) & (np.arange(bs.N) % 2 == 1))
        fixed = np.concatenate([ax_r, top_axis_z])
        # grid of DOF locations in (r, depth): the face is depth index 0
        grid = _dof_grid_morphed(bs, _midpoints(r), _midpoints(d), R, L)
        face_z = grid[: 2 * self.n_zone - 1, 0] + 1
        self.r_face_mm = bs.doflocs[0, face_z]
        self._sphere = _condense_grid(Ks, grid, face_z, fixed, f_top)
        self.gap0_mm = R - np.sqrt(R**2 - self.r_face_mm**2)
        self._n_dofs_sphere = bs.N
        self.setup_time_s = time.perf_counter() - t0

    # ------------------------------------------------------------------ lower body
    def _lower(self, film_modulus_mpa: float | None, film_poisson: float, radial_face: bool = False):
        """The flat (with the film tied on it) condensed onto its top z-DOFs; with `radial_face` onto
        its top r-DOFs off the axis, then its top z-DOFs."""
        r, d = self._r, self._depth
        nr, nd = len(r), len(d)
        t = self.film_thickness_mm
        n_film = self.film_layers if film_modulus_mpa is not None else 0
        # rows from the top: film layers (only r <= zone), then the flat's depth
        z_rows = np.concatenate([np.linspace(t, 0.0, n_film + 1)[:-1], -d]) if n_film else -d
        nz = len(z_rows)
        idx = -np.ones((nr, nz), int)
        idx[:, n_film:] = np.arange(nr * nd).reshape(nr, nd)
        count = nr * nd
        if n_film:
            zone = self.n_zone
            idx[:zone, :n_film] = count + np.arange(zone * n_film).reshape(zone, n_film)
        pts = np.zeros((2, int(idx.max()) + 1))
        ii, jj = np.nonzero(idx >= 0)
        pts[0, idx[ii, jj]] = r[ii]
        pts[1, idx[ii, jj]] = z_rows[jj]
        cells = _grid_cells(idx)
        mesh = _quad_mesh(pts, cells)
        z_mid = pts[1, cells].mean(axis=0)
        film_cells = np.flatnonzero(z_mid > 0.0)
        steel_cells = np.flatnonzero(z_mid < 0.0)
        K = _stiffness.assemble(Basis(mesh, self.element, elements=steel_cells), D=self._steel)
        if n_film:
            film_D = _constitutive(*lame_parameters(film_modulus_mpa, film_poisson))
            K = K + _stiffness.assemble(Basis(mesh, self.element, elements=film_cells), D=film_D)
        b = Basis(mesh, self.element)
        on_axis = np.isclose(b.doflocs[0], 0.0)
        ax_r = np.flatnonzero(on_axis & (np.arange(b.N) % 2 == 0))
        bottom_z = np.flatnonzero(np.isclose(b.doflocs[1], -self._depth[-1]) & (np.arange(b.N) % 2 == 1))
        fixed = np.concatenate([ax_r, bottom_z])
        top = t if n_film else 0.0
        # DOF grid from the top surface downwards
        rg = _midpoints(r)
        zg = _midpoints(z_rows)
        grid = -np.ones((len(rg), len(zg)), int)
        comp0 = np.arange(0, b.N, 2)
        ri = np.searchsorted(rg, b.doflocs[0, comp0] - 1e-9)
        zi = np.searchsorted(-zg, -b.doflocs[1, comp0] - 1e-9)
        grid[ri, zi] = comp0
        face_z = grid[: 2 * self.n_zone - 1, 0] + 1
        if not np.allclose(b.doflocs[1, face_z], top) or not np.allclose(b.doflocs[0, face_z], self.r_face_mm):
            raise RuntimeError("the lower body's face DOFs do not match the sphere's")
        face = np.concatenate([face_z[1:] - 1, face_z]) if radial_face else face_z
        return _condense_grid(K, grid, face, fixed, None), b.N

    # ------------------------------------------------------------------ the solve
    def solve(self, force_n: float, film_modulus_mpa: float | None = None, film_poisson: float = 0.33,
              kinematics: str = "small") -> ReferenceResult:
        """Press with force F (N); `film_modulus_mpa` None solves steel on steel.

        ``kinematics='large'`` makes the film neo-Hookean (:mod:`filmcal.fem.neohookean`; the
        steel bodies stay linear, as in the production model): Newton iterations at each
        contact set, and the closing loads of the bracketing nodes found by Newton on the force.
        """
        t0 = time.perf_counter()
        F = check_positive("force_n", force_n)
        if kinematics not in ("small", "large"):
            raise ValueError(f"kinematics must be 'small' or 'large', got {kinematics!r}")
        if film_modulus_mpa is not None:
            film_modulus_mpa = check_positive("film_modulus_mpa", film_modulus_mpa)
            film_poisson = check_poisson("film_poisson", film_poisson)
            if kinematics == "large":
                return self._solve_large(F, film_modulus_mpa, film_poisson, t0)
        # the lower body depends on the film and the mesh only, not on the sphere
        key = (self.element_size_mm, self.film_thickness_mm, self.film_layers, len(self._r), self.n_zone,
               float(self._r[-1]), film_modulus_mpa, film_poisson if film_modulus_mpa is not None else None)
        if key not in _LOWERS:
            while len(_LOWERS) >= _LOWERS_KEPT:
                _LOWERS.pop(next(iter(_LOWERS)))
            _LOWERS[key] = self._lower(film_modulus_mpa, film_poisson)
        lower, n_lower = _LOWERS[key]
        # gap g = g0 - w + F d + C lam  (lam >= 0 pushes the faces apart)
        C = self._sphere.compliance + lower.compliance
        d_unit = self._sphere.load_displacement
        g0 = self.gap0_mm

        def affine(k: int):
            """With nodes 0..k closed: (lam, w) = s0 + F s1, and the gaps likewise."""
            A = np.arange(k + 1)
            M = np.zeros((k + 2, k + 2))
            M[: k + 1, : k + 1] = C[np.ix_(A, A)]
            M[: k + 1, k + 1] = -1.0
            M[k + 1, : k + 1] = 1.0
            rhs0 = np.concatenate([-g0[A], [0.0]])
            rhs1 = np.concatenate([-d_unit[A], [1.0]])
            sol = sla.solve(M, np.column_stack([rhs0, rhs1]))
            lam0, lam1 = sol[: k + 1, 0], sol[: k + 1, 1]
            w0, w1 = sol[k + 1, 0], sol[k + 1, 1]
            gap0 = g0 - w0 + C[:, A] @ lam0
            gap1 = d_unit - w1 + C[:, A] @ lam1
            return lam0, lam1, w0, w1, gap0, gap1

        @functools.lru_cache(maxsize=None)
        def closing_force(k: int) -> float:
            """The force at which node k + 1 closes with nodes 0..k closed."""
            *_, gap0, gap1 = affine(k)
            return float(-gap0[k + 1] / gap1[k + 1])

        # bracket between vertex nodes (even indices): closing(v) <= F < closing(v + 2),
        # closing(v) being the force at which vertex v closes with nodes 0..v-1 closed
        n = len(g0)
        n_vertex = (n + 1) // 2

        def vertex_closing(j: int) -> float:
            return 0.0 if j == 0 else closing_force(2 * j - 1)

        lo, hi = 0, n_vertex - 1
        if vertex_closing(hi) <= F:
            raise ValueError(f"the contact reaches the refined zone's edge at F = {F:g} N")
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if vertex_closing(mid) <= F:
                lo = mid
            else:
                hi = mid
        f_k, f_k1 = vertex_closing(lo), vertex_closing(hi)
        r0, r1 = self.r_face_mm[2 * lo], self.r_face_mm[2 * hi]
        s = (F - f_k) / (f_k1 - f_k)
        a = float(np.cbrt(r0**3 + s * (r1**3 - r0**3)))
        # the closed set at F itself: nodes 0..k with closing(k - 1) <= F < closing(k)
        k = 2 * lo if closing_force(2 * lo) > F else 2 * lo + 1
        lam0, lam1, w0, w1, _, _ = affine(k)
        lam = lam0 + F * lam1
        if lam.min() < -1e-9 * F:
            raise RuntimeError("the closed set has a tensile pair force: the contact set is not contiguous")
        forces = np.zeros(n)
        forces[: k + 1] = lam
        pressure = _nodal_pressure(self.r_face_mm, forces)
        pmax = float(pressure[0])
        return ReferenceResult(a, hertz_radius_mm(self.sphere_radius_mm, F), float(w0 + F * w1), pmax,
                               (float(r0), float(r1)), (float(f_k), float(f_k1)), self.element_size_mm,
                               self.film_layers if film_modulus_mpa is not None else 0,
                               int(self._n_dofs_sphere + n_lower), self.r_face_mm.copy(), pressure,
                               time.perf_counter() - t0)


    # ------------------------------------------------------------------ large-strain film
    def _large_lower(self, film_modulus_mpa: float, film_poisson: float) -> "_NeoHookeanLower":
        key = ("large", self.element_size_mm, self.film_thickness_mm, self.film_layers, len(self._r), self.n_zone,
               float(self._r[-1]), film_modulus_mpa, film_poisson)
        if key not in _LOWERS:
            while len(_LOWERS) >= _LOWERS_KEPT:
                _LOWERS.pop(next(iter(_LOWERS)))
            flat, n_flat = self._lower(None, film_poisson, radial_face=True)
            _LOWERS[key] = _NeoHookeanLower(self._r[: self.n_zone], self.r_face_mm, self.film_thickness_mm,
                                            self.film_layers, self.element, flat.stiffness, n_flat,
                                            film_modulus_mpa, film_poisson)
        return _LOWERS[key]

    def _solve_large(self, F: float, film_modulus_mpa: float, film_poisson: float, t0: float) -> ReferenceResult:
        """The large-strain film: the edge between the closing loads of two vertex nodes (see `solve`)."""
        low = self._large_lower(film_modulus_mpa, film_poisson)
        n = len(self.gap0_mm)
        start = self.solve(F, film_modulus_mpa, film_poisson)  # the small-strain film's edge: where to start
        j = int(np.searchsorted(self.r_face_mm[0::2], start.bracket_mm[0] + 1e-9)) - 1
        k0 = int(np.searchsorted(start.r_mm, start.bracket_mm[1] + 1e-9))
        state = _State(np.zeros(low.n_x), _face_mass(start.r_mm)[:k0] @ start.pressure_mpa, start.approach_mm)
        closings: dict[int, tuple[float, _State]] = {}

        def vertex_closing(v: int) -> float:
            """The force at which vertex v closes with nodes 0..2v-1 closed."""
            if v == 0:
                return 0.0
            if v not in closings:
                near = min(closings, key=lambda u: abs(u - v)) if closings else None
                seed = state if near is None else closings[near][1]
                closings[v] = low.closing_force(self, 2 * v, F, seed)
            return closings[v][0]

        n_vertex = (n + 1) // 2
        vertex_r = self.r_face_mm[0::2]
        exponent, last = 1.0 / 3.0, None
        for _ in range(8):  # jump towards the vertex whose closing load is F: a ~ F^k, k from the last two
            if j == 0:
                break
            f_j = vertex_closing(j)
            if last is not None and last[1] != f_j:
                exponent = float(np.clip(np.log(vertex_r[j] / last[0]) / np.log(f_j / last[1]), 0.1, 1.0))
            last = (vertex_r[j], f_j)
            guess = vertex_r[j] * (F / f_j) ** exponent
            jump = int(np.clip(np.argmin(np.abs(vertex_r - guess)), 1, n_vertex - 2))
            if jump == j:
                break
            j = jump
        while j > 0 and vertex_closing(j) > F:
            j -= 1
        while j + 1 < n_vertex - 1 and vertex_closing(j + 1) <= F:
            j += 1
        if j + 1 >= n_vertex - 1:
            raise ValueError(f"the contact reaches the refined zone's edge at F = {F:g} N")
        f_k, f_k1 = vertex_closing(j), vertex_closing(j + 1)
        r0, r1 = self.r_face_mm[2 * j], self.r_face_mm[2 * j + 2]
        s = (F - f_k) / (f_k1 - f_k)
        a = float(np.cbrt(r0**3 + s * (r1**3 - r0**3)))
        # the contact at F itself: nodes 0..2j closed, and the midside node after it if its gap is closed
        seed = closings.get(j + 1, closings.get(j, (0.0, state)))[1]
        at_f, gap = low.equilibrium(self, 2 * j + 1, F, seed)
        if gap < 0.0:
            at_f, _ = low.equilibrium(self, 2 * j + 2, F, at_f)
        if at_f.lam.min() < -1e-9 * F:
            raise RuntimeError("the closed set has a tensile pair force: the contact set is not contiguous")
        forces = np.zeros(n)
        forces[: len(at_f.lam)] = at_f.lam
        pressure = _nodal_pressure(self.r_face_mm, forces)
        return ReferenceResult(a, hertz_radius_mm(self.sphere_radius_mm, F), float(at_f.w), float(pressure[0]),
                               (float(r0), float(r1)), (float(f_k), float(f_k1)), self.element_size_mm,
                               self.film_layers, int(self._n_dofs_sphere + low.n_dofs), self.r_face_mm.copy(),
                               pressure, time.perf_counter() - t0)


@dataclass
class _State:
    """Film DOFs, the pair forces of the closed nodes 0..m-1 (N) and the sphere's approach (mm)."""

    x: np.ndarray
    lam: np.ndarray
    w: float


class _NeoHookeanLower:
    """A neo-Hookean film (biquadratic, its own mesh over the refined zone) tied to the linear flat (`flat_dofs`
    DOFs), whose top face is condensed to its stiffness `flat_stiffness` (r-DOFs off the axis, then z-DOFs)."""

    def __init__(self, r_grid: np.ndarray, r_face: np.ndarray, thickness_mm: float, layers: int, element,
                 flat_stiffness: np.ndarray, flat_dofs: int, modulus_mpa: float, poisson: float) -> None:
        self.modulus_mpa, self.poisson = modulus_mpa, poisson
        z = np.linspace(0.0, thickness_mm, layers + 1)
        idx = np.arange(len(r_grid) * len(z)).reshape(len(r_grid), len(z))
        pts = np.vstack([np.repeat(r_grid, len(z)), np.tile(z, len(r_grid))])
        self.basis = Basis(_quad_mesh(pts, _grid_cells(idx)), element, intorder=4)
        loc = self.basis.doflocs
        n_face = len(r_face)
        comp = np.arange(self.basis.N) % 2

        def face_dofs(height: float, component: int) -> np.ndarray:
            dofs = np.flatnonzero(np.isclose(loc[1], height) & (comp == component))
            dofs = dofs[np.argsort(loc[0, dofs])]
            if len(dofs) != n_face or not np.allclose(loc[0, dofs], r_face):
                raise RuntimeError("the film's face DOFs do not match the contact face")
            return dofs

        axis_r = np.flatnonzero(np.isclose(loc[0], 0.0) & (comp == 0))
        self.free = np.setdiff1d(np.arange(self.basis.N), axis_r)
        index = -np.ones(self.basis.N, int)
        index[self.free] = np.arange(len(self.free))
        self.n_x = len(self.free)
        # the film's bottom DOFs are the flat's face DOFs (its r-DOF on the axis too, fixed in both)
        self.n_dofs = self.basis.N + flat_dofs - len(flat_stiffness) - 1
        self.top_z = index[face_dofs(thickness_mm, 1)]
        bottom = index[np.concatenate([face_dofs(0.0, 0)[1:], face_dofs(0.0, 1)])]
        rows = np.repeat(bottom, len(bottom))
        cols = np.tile(bottom, len(bottom))
        self.flat = sp.csr_matrix((np.asarray(flat_stiffness).ravel(), (rows, cols)), shape=(self.n_x, self.n_x))

    def force_and_tangent(self, x: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        u = np.zeros(self.basis.N)
        u[self.free] = x
        f, K = neo_hookean_force_and_tangent(self.basis, self.modulus_mpa, self.poisson, u)
        return f[self.free] + self.flat @ x, K[self.free][:, self.free] + self.flat

    def equilibrium(self, model: "QuadraticSphereOnFlat", m: int, force_n: float, seed: _State,
                    closing: bool = False) -> tuple[_State, float]:
        """Equilibrium with nodes 0..m-1 closed (gap 0, pair forces of either sign), by Newton from `seed`.

        At the force `force_n`, returning the state and the gap of node m (mm); or with `closing`, at
        the force where node m's gap closes too (the force an unknown of the same Newton iterations,
        `force_n` its start), returning the state and that force (N). Where a step would invert a film
        element it is halved; a load that Newton does not reach from the seed is approached in quarters.
        """
        try:
            return self._newton(model, m, force_n, seed, closing)
        except _NotConverged:
            pass
        mid = seed
        try:
            for fraction in (0.25, 0.5, 0.75):
                mid, _ = self._newton(model, m, fraction * force_n, mid, False)
            return self._newton(model, m, force_n, mid, closing)
        except _NotConverged:
            raise RuntimeError(f"the large-strain film's Newton iterations did not converge at {force_n:g} N "
                               f"with {m} nodes closed") from None

    def _newton(self, model, m, force_n, seed, closing, max_iterations: int = 50):
        C = model._sphere.compliance
        d = model._sphere.load_displacement
        g0 = model.gap0_mm
        top = self.top_z
        if m >= len(g0):
            raise ValueError(f"the contact reaches the refined zone's edge at F = {force_n:g} N")
        rows = np.arange(m + 1)  # the closed nodes and node m
        x = seed.x.copy()
        lam = np.zeros(m)
        lam[: min(m, len(seed.lam))] = seed.lam[:m]
        w, force = float(seed.w), float(force_n)
        unit = np.zeros((self.n_x, m + 1))
        unit[top[rows], rows] = 1.0
        n_eq = m + 2 if closing else m + 1
        for _ in range(max_iterations):
            f, K = self.force_and_tangent(x)
            f[top[:m]] += lam
            lu = spla.splu(K.tocsc())
            Y = lu.solve(unit)  # the film's response to a unit pair force at nodes 0..m
            dx0 = -lu.solve(f)
            gap = g0[rows] - w + force * d[rows] + C[np.ix_(rows, rows[:m])] @ lam - x[top[rows]]
            # unknowns (dlam, dw[, dF]); equations: gaps of the closed nodes, force balance[, gap of node m]
            M = np.zeros((n_eq, n_eq))
            M[:m, :m] = C[:m, :m] + Y[top[:m], :m]
            M[:m, m] = -1.0
            M[m, :m] = 1.0
            rhs = np.concatenate([-gap[:m] + dx0[top[:m]], [force - lam.sum()]])
            if closing:
                M[:m, m + 1] = d[:m]
                M[m, m + 1] = -1.0
                M[m + 1, :m] = C[m, :m] + Y[top[m], :m]
                M[m + 1, m] = -1.0
                M[m + 1, m + 1] = d[m]
                rhs = np.concatenate([rhs, [-gap[m] + dx0[top[m]]]])
            sol = np.linalg.solve(M, rhs)
            dx = dx0 - Y[:, :m] @ sol[:m]
            step = 1.0
            while not _admissible(self.basis, self.free, x + step * dx):
                step /= 2
                if step < 1e-3:
                    raise _NotConverged
            x, lam, w = x + step * dx, lam + step * sol[:m], w + step * sol[m]
            if closing:
                force += step * sol[m + 1]
            if step == 1.0 and np.max(np.abs(dx)) < 1e-11:
                break
        else:
            raise _NotConverged
        state = _State(x, lam, w)
        if closing:
            return state, force
        return state, float(g0[m] - w + force * d[m] + C[m, :m] @ lam - x[top[m]])

    def closing_force(self, model, m: int, force_n: float, seed: _State) -> tuple[float, _State]:
        """The force at which node m closes with nodes 0..m-1 closed, and the equilibrium there."""
        state, force = self.equilibrium(model, m, force_n, seed, closing=True)
        return force, state


class _NotConverged(Exception):
    pass


def _admissible(basis: Basis, free: np.ndarray, x: np.ndarray) -> bool:
    u = np.zeros(basis.N)
    u[free] = x
    return bool(minimum_jacobian(basis, u) > 0.0)


def _dof_grid_morphed(basis: Basis, r_grid: np.ndarray, depth_grid: np.ndarray, R: float, L: float) -> np.ndarray:
    """DOF-location grid of the sphere body, in (r, depth) with the face at depth 0."""
    comp0 = np.arange(0, basis.N, 2)
    r = basis.doflocs[0, comp0]
    z = basis.doflocs[1, comp0]
    face = R - np.sqrt(R**2 - r**2)
    depth = (z - face) * L / (L - face)
    ri = np.searchsorted(r_grid, r - 1e-9)
    # midside DOFs of curved edges sit on the chord: match depth to the nearest grid line
    zi = np.clip(np.searchsorted(depth_grid, depth - 1e-6), 0, len(depth_grid) - 1)
    near = np.abs(depth_grid[np.maximum(zi - 1, 0)] - depth) < np.abs(depth_grid[zi] - depth)
    zi = np.where(near, np.maximum(zi - 1, 0), zi)
    grid = -np.ones((len(r_grid), len(depth_grid)), int)
    grid[ri, zi] = comp0
    if (grid < 0).any():
        raise RuntimeError("the sphere's DOF locations do not form a grid")
    return grid


def _face_mass(r: np.ndarray) -> np.ndarray:
    """Consistent nodal forces per nodal pressure of the quadratic interpolation on the face nodes at `r`
    (vertex, midside, ..., vertex): forces = M p."""
    n = len(r)
    M = np.zeros((n, n))
    xg, wg = np.polynomial.legendre.leggauss(4)
    for e in range(0, n - 2, 2):
        r0, r2 = r[e], r[e + 2]
        s = 0.5 * (xg + 1.0)
        shape = np.array([2 * (s - 0.5) * (s - 1.0), -4 * s * (s - 1.0), 2 * s * (s - 0.5)])
        rr = r0 + s * (r2 - r0)
        wt = 0.5 * wg * (r2 - r0) * 2.0 * np.pi * rr
        M[e:e + 3, e:e + 3] += (shape * wt) @ shape.T
    return M


def _nodal_pressure(r: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """Nodal pressures p whose quadratic interpolation has the consistent nodal
    forces `forces` on the face nodes at `r` (vertex, midside, ..., vertex)."""
    return np.linalg.solve(_face_mass(r), forces)


def _condense_grid(K, grid: np.ndarray, face_z: np.ndarray, fixed: np.ndarray, load):
    """Condense onto `face_z`, eliminating in nested-dissection order of the DOF grid."""
    order_points = nested_dissection(grid, stride=2)
    order_points = order_points[order_points >= 0]
    dofs = np.column_stack([order_points, order_points + 1]).ravel()
    interior = dofs[~np.isin(dofs, np.concatenate([fixed, face_z]))]
    return condense(K, interior, face_z, load)
