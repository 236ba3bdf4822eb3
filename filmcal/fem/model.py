"""The axisymmetric finite-element model of a steel sphere pressed on a steel
flat with a Prescale film between them (the paper's section 2.1).

Speed by reuse: the steel bodies depend only on (R, mesh). Each is condensed
once onto its contact-face DOFs (`filmcal.fem.condense`); an evaluation for a
film (E, nu) and force F then works on the film's few hundred DOFs and the
pair forces only.

Interfaces
----------
sphere-film : unilateral contact; ``frictionless`` (default), ``friction``
    (Coulomb, coefficient mu) or ``tied`` (no slip once in contact).
film-flat : the film never separates from the flat (bilateral normal contact,
    as in the paper's model); tangentially ``tied`` (default),
    ``frictionless`` or ``friction``.

The default (frictionless at the sphere, tied to the flat) is a linear
complementarity problem with a unique, loading-path independent solution,
solved exactly in one step. It holds the film laterally, so that it is
compressed oedometrically like the paper's friction-held film, and it is the
configuration in which the thin-layer model (`filmcal.fem.thinlayer`) is an
independent check. Friction and no-slip cases depend on the loading path and
are solved in load increments.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from skfem import Basis, ElementQuad1, ElementVector, FacetBasis
from threadpoolctl import threadpool_limits

from filmcal._validation import FILM_MODULUS_MPA_BOUNDS, check_poisson, check_positive, check_range
from filmcal.contact import DEFAULT_IMPRINT_MODEL, film_tip_length_mm, get_imprint_model
from filmcal.contact.options import ContactOptions
from filmcal.fem.condense import CondensedBody, condense, nested_dissection
from filmcal.fem.contact import CLOSED, FREE, OPEN, ContactState, PairSystem, load_sensitivity, solve_pairs
from filmcal.fem.forms import (axial_traction, film_bases, film_stiffness_parts, lame_parameters, linear_elasticity,
                               oedometric_modulus_mpa)
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm
from filmcal.fem.largestrain import film_internal_force_and_tangent
from filmcal.fem.mesh import FILM_LAYERS, BodyGrid, MeshSettings, film_grid, flat_grid, sphere_grid
from filmcal.fem.result import FEResult

__all__ = ["Film", "SphereOnFlat", "NODE_CLOSING_LEAD", "FILM_EDGE_LEAD_PER_MM", "MIN_FILM_THICKNESS_PER_ELEMENT",
           "min_film_thickness_mm", "check_film_thickness"]

#: A node-to-node pair closes when the continuum edge lies this many element
#: sizes beyond it (measured against Hertz, see `SphereOnFlat._closing_edge_mm`).
NODE_CLOSING_LEAD = 0.25
#: The film's elements at the edge move the closing edge out by this times h^2
#: (h in mm; measured against the second formulation, `bench/fe_reference.py`).
FILM_EDGE_LEAD_PER_MM = 0.55
#: The thinnest film the model resolves, per unit of the contact-zone element size h: a film is valid for
#: t >= 0.1 h (0.01 mm at the default 0.1 mm). Below it the film's change of the contact radius is no longer
#: large against the mesh's error at the edge (measured in docs/fem.md, "Film thickness").
MIN_FILM_THICKNESS_PER_ELEMENT = 0.1


def min_film_thickness_mm(element_size_mm: float) -> float:
    """The thinnest film (mm) the FE resolves with contact-zone elements of this size:
    ``MIN_FILM_THICKNESS_PER_ELEMENT * element_size_mm``."""
    return MIN_FILM_THICKNESS_PER_ELEMENT * check_positive("element_size_mm", element_size_mm)


def check_film_thickness(film_thickness_mm: float, element_size_mm: float, film_layers: int = FILM_LAYERS) -> float:
    """Return the film thickness t (mm) if the FE model is valid for it at this element size, else raise.

    Valid: 0 < t <= 5 mm and t >= ``MIN_FILM_THICKNESS_PER_ELEMENT`` h (h the contact-zone
    element size). The lower limit is measured, not a rule of thumb: at R450/50 kN, E 2500 MPa,
    nu 0.3 the radius excess over the no-film answer at h = 0.1 mm lies within 0.005 mm
    (2 %) of the h = 0.025 mm answer at t = 0.01 mm, but 0.0063 mm (7 %) off at 0.003 mm and
    0.0067 mm (18 %) at 0.001 mm; as t -> 0 the reading tends to the no-film radius minus the
    film's edge lead (``FILM_EDGE_LEAD_PER_MM`` h^2, fitted to 90 um films), a mesh-dependent
    number below the no-film answer, and by t ~ 1e-9 mm (elements 2e8:1 flat) the film's
    stiffness is numerically singular with a film free to slide on the flat.

    Raises
    ------
    ValueError
        Naming ``film_thickness_mm``, the limit and why.
    """
    t = check_range("film_thickness_mm", film_thickness_mm, 0.0, 5.0, high_open=False)
    if isinstance(film_layers, bool) or int(film_layers) != film_layers or film_layers < 1:
        raise ValueError(f"film_layers must be an integer >= 1, got {film_layers!r}")
    h = check_positive("element_size_mm", element_size_mm)
    t_min = min_film_thickness_mm(h)
    if t < t_min * (1.0 - 1e-9):
        finer = t / MIN_FILM_THICKNESS_PER_ELEMENT
        refine = (f"refine the mesh to element_size_mm <= {finer:.3g}" if finer >= 0.005
                  else "no practical mesh resolves a film this thin")
        raise ValueError(
            f"film_thickness_mm {t:g} is below the {t_min:.3g} mm the FE resolves at element_size_mm {h:g} "
            f"(valid: film_thickness_mm >= element_size_mm / {1 / MIN_FILM_THICKNESS_PER_ELEMENT:g}): its elements "
            f"would be {h * int(film_layers) / t:.3g}:1 flat and the mesh's error at the contact edge (about "
            f"{0.6 * h * h:.2g} mm) no longer small against the film's effect on the radius; for the no-film "
            f"answer solve without a film, else {refine}")
    return t



@dataclass(frozen=True)
class Film:
    """A linear elastic (or neo-Hookean, with large strain) film.

    Parameters
    ----------
    modulus_mpa : float
        Young's modulus E (MPa), > 0.
    poisson : float
        Poisson's ratio nu, -1 < nu < 0.5. The paper fixes 0.33.
    """

    modulus_mpa: float
    poisson: float = 0.33

    def __post_init__(self) -> None:
        object.__setattr__(self, "modulus_mpa", check_range("film_modulus_mpa", self.modulus_mpa,
                                                            *FILM_MODULUS_MPA_BOUNDS, low_open=False, high_open=False))
        object.__setattr__(self, "poisson", check_poisson("film_poisson", self.poisson))

    @property
    def oedometric_modulus_mpa(self) -> float:
        """M = E (1 - nu) / ((1 + nu)(1 - 2 nu))."""
        return oedometric_modulus_mpa(self.modulus_mpa, self.poisson)


def _face_dofs(basis: Basis, grid: BodyGrid) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Face DOFs in condensation order and the positions of each node's z and r DOF.

    The axis node has no r DOF (u_r = 0 on the axis); its r position is -1.
    """
    nodes = grid.face_nodes
    dofs, zpos, rpos = [], np.zeros(len(nodes), int), -np.ones(len(nodes), int)
    for i, node in enumerate(nodes):
        if i > 0:
            rpos[i] = len(dofs)
            dofs.append(basis.nodal_dofs[0, node])
        zpos[i] = len(dofs)
        dofs.append(basis.nodal_dofs[1, node])
    return np.asarray(dofs), zpos, rpos


def _condense_body(grid: BodyGrid, fixed: np.ndarray, load: np.ndarray | None,
                   basis: Basis, K) -> tuple[CondensedBody, np.ndarray, np.ndarray]:
    face, zpos, rpos = _face_dofs(basis, grid)
    order_nodes = nested_dissection(grid.node_at[:, 1:])
    rest_face = grid.node_at[grid.n_face:, 0]
    order_nodes = np.concatenate([order_nodes, rest_face])
    interior = basis.nodal_dofs[:, order_nodes].T.ravel()
    interior = interior[~np.isin(interior, np.concatenate([fixed, face]))]
    return condense(K, interior, face, load), zpos, rpos


@dataclass
class _Lower:
    """The film plus the flat's face as one linear system (for one flat mode)."""

    n_x: int
    film_index: np.ndarray  # film DOF -> x index (-1: fixed on the axis)
    flat_index: np.ndarray  # flat face DOF (condensed order) -> x index
    top_z: np.ndarray  # x index of the upper face's z DOF per face node
    top_r: np.ndarray  # x index of the upper face's r DOF per face node (-1 on the axis)
    film_bottom_r: np.ndarray
    flat_r: np.ndarray
    flat_z: np.ndarray


def _factorised(K: np.ndarray, nonlinear: bool):
    """A solver of ``K y = b``: Cholesky, or for a large-strain film's tangent that has lost positive
    definiteness, LU.

    Under heavy compression (through-thickness strain near -0.5) the film's geometric stiffness makes its
    tangent indefinite on fine meshes while the equilibrium still exists; Newton on the indefinite but
    regular tangent still converges. A singular matrix raises `numpy.linalg.LinAlgError`.
    """
    try:
        cho = sla.cho_factor(K)
        return lambda b: sla.cho_solve(cho, b)
    except np.linalg.LinAlgError:
        if not nonlinear:
            raise
    with warnings.catch_warnings():
        warnings.simplefilter("error", sla.LinAlgWarning)
        try:
            lu = sla.lu_factor(K)
        except sla.LinAlgWarning as exc:
            raise np.linalg.LinAlgError(str(exc)) from None
    return lambda b: sla.lu_solve(lu, b)


@dataclass
class _StepProblem:
    """What a load step needs besides the load and the current state."""

    low: "_Lower"
    D: np.ndarray
    H_s: np.ndarray
    g0: np.ndarray
    d0_unit: np.ndarray
    a: np.ndarray
    normal: np.ndarray
    tangential: np.ndarray
    friction: np.ndarray
    gate: np.ndarray
    K_film: np.ndarray | None
    film: Film | None
    nonlinear: bool
    max_iterations: int
    solved: tuple | None = None  # (H, pairs) of the last converged load step


class SphereOnFlat:
    """Axisymmetric FE model of the paper's Hertzian experiment for one sphere.

    Built once per sphere radius and mesh (the steel bodies are condensed
    then); :meth:`solve` evaluates a film and force cheaply.

    Parameters
    ----------
    sphere_radius_mm : float
        Sphere radius R (mm).
    mesh : MeshSettings, optional
    film_thickness_mm : float
        Film thickness t (the paper: 0.09 mm), 0 < t <= 5 mm. A film is solved only
        where the model is valid, t >= ``MIN_FILM_THICKNESS_PER_ELEMENT`` h (0.01 mm at
        the default h = 0.1 mm; :func:`check_film_thickness`): :meth:`solve` with a film
        refuses a thinner one. Solves without film do not depend on t.
    film_layers : int
        Element layers through the film thickness (default
        :data:`filmcal.fem.mesh.FILM_LAYERS`, 2; the paper: 1).
    steel_modulus_mpa, steel_poisson : float
        Elastic constants of both bodies (default steel; a lab's bodies of another material, the sphere and
        the flat alike: the refined contact zone then follows their Hertz radius).

    Examples
    --------
    >>> model = SphereOnFlat(450.0)                          # doctest: +SKIP
    >>> res = model.solve(Film(2800.0, 0.33), force_n=75e3)  # doctest: +SKIP
    >>> res.contact_radius_mm - res.hertz_radius_mm          # doctest: +SKIP
    """

    def __init__(self, sphere_radius_mm: float, mesh: MeshSettings | None = None, film_thickness_mm: float = 0.09,
                 film_layers: int = FILM_LAYERS, steel_modulus_mpa: float = STEEL_MODULUS_MPA,
                 steel_poisson: float = STEEL_POISSON) -> None:
        t0 = time.perf_counter()
        self.sphere_radius_mm = check_positive("sphere_radius_mm", sphere_radius_mm)
        self.mesh = MeshSettings() if mesh is None else mesh
        self.film_thickness_mm = check_range("film_thickness_mm", film_thickness_mm, 0.0, 5.0, high_open=False)
        self.steel_modulus_mpa = check_positive("steel_modulus_mpa", steel_modulus_mpa)
        self.steel_poisson = check_poisson("steel_poisson", steel_poisson)
        lam, mu = lame_parameters(self.steel_modulus_mpa, self.steel_poisson)
        e = ElementVector(ElementQuad1())

        # sphere body: u_r = 0 on the axis, the axis node of the top pinned in z
        # (its rigid displacement w is an unknown fixed by the force balance)
        if (self.steel_modulus_mpa, self.steel_poisson) != (STEEL_MODULUS_MPA, STEEL_POISSON) and \
                self.mesh.contact_zone_mm is None:  # other bodies: the refined zone follows their Hertz radius
            from dataclasses import replace

            from filmcal.fem.mesh import default_contact_zone_mm

            self.mesh = replace(self.mesh, contact_zone_mm=default_contact_zone_mm(
                self.sphere_radius_mm, self.mesh, self.steel_modulus_mpa, self.steel_poisson))
        self.sphere = sphere_grid(self.sphere_radius_mm, self.mesh, self.film_thickness_mm)
        sb = Basis(self.sphere.mesh, e)
        Ks = linear_elasticity.assemble(sb, lam=lam, mu=mu)
        top = self.sphere.node_at[:, -1]
        fixed_s = np.concatenate([sb.nodal_dofs[0, self.sphere.node_at[0, :]], [sb.nodal_dofs[1, top[0]]]])
        top_facets = self.sphere.mesh.facets_satisfying(
            lambda x: np.isclose(x[1], self.film_thickness_mm + self.mesh.body_size_mm))
        area = np.pi * self.mesh.body_size_mm**2
        f_top = axial_traction.assemble(FacetBasis(self.sphere.mesh, e, facets=top_facets), traction=-1.0 / area)
        f_top[fixed_s] = 0.0
        self.sphere_body, self._s_z, self._s_r = _condense_body(self.sphere, fixed_s, f_top, sb, Ks)

        # flat body: bottom fixed in z, u_r = 0 on the axis
        self.flat = flat_grid(self.mesh, float(self.sphere.r_face_mm[-1]))
        fb = Basis(self.flat.mesh, e)
        Kf = linear_elasticity.assemble(fb, lam=lam, mu=mu)
        fixed_f = np.concatenate([fb.nodal_dofs[1, self.flat.node_at[:, -1]], fb.nodal_dofs[0, self.flat.node_at[0, :]]])
        self.flat_body, self._f_z, self._f_r = _condense_body(self.flat, fixed_f, None, fb, Kf)

        # film: stiffness split as lambda * K_lam + mu * K_mu (volumetric term at the element centres)
        self.r_face_mm = self.sphere.r_face_mm
        self.film = film_grid(self.r_face_mm, self.film_thickness_mm, film_layers)
        self.film_layers = int(film_layers)
        self._film_basis, self._film_centre_basis = film_bases(self.film.mesh, e)
        self._K_lam, self._K_mu = film_stiffness_parts(self._film_basis, self._film_centre_basis)
        self.gap0_mm = self.sphere_radius_mm - np.sqrt(self.sphere_radius_mm**2 - self.r_face_mm**2)
        self.face_area_mm2 = self._tributary_areas(self.r_face_mm)
        self._lower_cache: dict[str, _Lower] = {}
        self.n_dofs = int(sb.N + fb.N + self._film_basis.N)
        self.setup_time_s = time.perf_counter() - t0

    # ------------------------------------------------------------------ helpers
    @staticmethod
    def _tributary_areas(r: np.ndarray) -> np.ndarray:
        """Integral of each face node's hat function times 2 pi r (mm^2)."""
        areas = np.zeros(len(r))
        for i in range(len(r) - 1):
            r0, r1 = r[i], r[i + 1]
            h = r1 - r0
            areas[i] += 2 * np.pi * h * (2 * r0 + r1) / 6.0
            areas[i + 1] += 2 * np.pi * h * (r0 + 2 * r1) / 6.0
        return areas

    @property
    def n_face(self) -> int:
        return len(self.r_face_mm)

    def _lower(self, flat_contact: str, with_film: bool) -> _Lower:
        key = f"{flat_contact}:{with_film}"
        if key in self._lower_cache:
            return self._lower_cache[key]
        n = self.n_face
        n_flat = len(self.flat_body.face_dofs)
        flat_index = -np.ones(n_flat, int)
        if not with_film:
            flat_index = np.arange(n_flat)
            low = _Lower(n_flat, np.zeros(0, int), flat_index, self._f_z.copy(), self._f_r.copy(),
                         -np.ones(n, int), self._f_r.copy(), self._f_z.copy())
            self._lower_cache[key] = low
            return low
        fb = self._film_basis
        film_index = -np.ones(fb.N, int)
        axis_r = fb.nodal_dofs[0, self.film.node_at[0, :]]
        free = np.setdiff1d(np.arange(fb.N), axis_r)
        film_index[free] = np.arange(len(free))
        n_x = len(free)
        bottom = self.film.node_at[:, 0]
        for i in range(n):  # flat z merged with the film bottom's z (no separation)
            flat_index[self._f_z[i]] = film_index[fb.nodal_dofs[1, bottom[i]]]
            if i > 0:
                if flat_contact == "tied":
                    flat_index[self._f_r[i]] = film_index[fb.nodal_dofs[0, bottom[i]]]
                else:
                    flat_index[self._f_r[i]] = n_x
                    n_x += 1
        topn = self.film.node_at[:, -1]
        top_z = film_index[fb.nodal_dofs[1, topn]]
        top_r = np.where(np.arange(n) > 0, film_index[fb.nodal_dofs[0, topn]], -1)
        bot_r = np.where(np.arange(n) > 0, film_index[fb.nodal_dofs[0, bottom]], -1)
        flat_r = np.where(np.arange(n) > 0, flat_index[np.maximum(self._f_r, 0)], -1)
        flat_z = flat_index[self._f_z]
        low = _Lower(n_x, film_index, flat_index, top_z, top_r, bot_r, flat_r, flat_z)
        self._lower_cache[key] = low
        return low

    def _film_stiffness(self, film: Film) -> np.ndarray:
        lam, mu = lame_parameters(film.modulus_mpa, film.poisson)
        return lam * self._K_lam + mu * self._K_mu

    def _lower_stiffness(self, low: _Lower, K_film: np.ndarray | None) -> np.ndarray:
        K = np.zeros((low.n_x, low.n_x))
        S = self.flat_body.stiffness
        fi = low.flat_index
        K[np.ix_(fi, fi)] += S
        if K_film is not None:
            keep = low.film_index >= 0
            idx = low.film_index[keep]
            K[np.ix_(idx, idx)] += K_film[np.ix_(keep, keep)]
        return K

    # -------------------------------------------------------------- the solve
    def solve(self, film: Film | None, force_n: float, options: ContactOptions | None = None,
              activation_pressure_mpa: float | None = None, film_type=None,
              imprint_model: str = DEFAULT_IMPRINT_MODEL) -> FEResult:
        """Press the sphere on the flat with force F, with or without a film.

        Parameters
        ----------
        film : Film or None
            The film's material; None solves steel on steel (no film).
        force_n : float
            Normal force F (N), > 0.
        options : ContactOptions, optional
            Interfaces, kinematics and solver limits.
        activation_pressure_mpa : float, optional
            Shorthand for a film type with this activation pressure and no
            range (read with the ``activation`` or ``edge`` model).
        film_type : filmcal.films.FilmType, optional
            Also report the imprint of this film type (``imprint_radius_mm``,
            ``imprint_area_mm2``); not together with `activation_pressure_mpa`.
        imprint_model : {'activation', 'edge', 'capsule'}
            What the film records (:mod:`filmcal.contact.imprint`).

        Returns
        -------
        FEResult
            A result with ``converged = False`` and a reason when the solve
            fails (e.g. a film so soft that it collapses); never raises for a
            failed solve.

        Raises
        ------
        ValueError
            For bad input, and for a film thinner than the model resolves on
            this mesh (:func:`check_film_thickness`), before any work.
        """
        if film is not None:
            check_film_thickness(self.film_thickness_mm, self.mesh.element_size_mm, self.film_layers)
        # the dense work here is small: one BLAS thread is fastest, and leaves
        # the other cores to parallel evaluations
        if activation_pressure_mpa is not None:
            if film_type is not None:
                raise ValueError("give either film_type or activation_pressure_mpa, not both")
            from filmcal.films import FilmType
            act = check_positive("activation_pressure_mpa", activation_pressure_mpa)
            film_type = FilmType(f"p>{act:g}MPa", activation_pressure_mpa=act)
        if film_type is not None:
            get_imprint_model(imprint_model).check_film(film_type)
        with threadpool_limits(limits=1, user_api="blas"):
            return self._solve(film, force_n, options, film_type, imprint_model)

    def _hertz_radius_mm(self, force_n: float) -> float:
        """Hertz's contact radius of these bodies (steel by default)."""
        return hertz_radius_mm(self.sphere_radius_mm, force_n, self.steel_modulus_mpa, self.steel_poisson)

    def _solve(self, film, force_n, options, film_type, imprint_model) -> FEResult:
        t0 = time.perf_counter()
        force_n = check_positive("force_n", force_n)
        opts = ContactOptions() if options is None else options
        h = self.mesh.element_size_mm
        a_h = self._hertz_radius_mm(force_n)
        if a_h < 10.0 * h:
            raise ValueError(f"element_size_mm = {h:g} cannot resolve a contact radius of about {a_h:.2f} mm "
                             f"(R = {self.sphere_radius_mm:g} mm, F = {force_n:g} N): use element_size_mm <= {a_h / 10:.3g}")
        with_film = film is not None
        sphere_mode = opts.sphere_contact
        flat_mode = opts.flat_contact if with_film else "tied"
        low = self._lower(flat_mode, with_film)
        n = self.n_face
        mu_f = np.inf if sphere_mode == "tied" else opts.friction_coefficient

        # pair unknowns: sphere normals, sphere tangentials, flat tangentials
        normal = np.arange(n)
        tang_nodes = np.arange(1, n)
        blocks = [normal]
        tangential, friction, gate = [], [], []
        if sphere_mode != "frictionless":
            idx = n + np.arange(len(tang_nodes))
            tangential.append(idx)
            friction.append(np.full(len(idx), mu_f))
            gate.append(tang_nodes)
            blocks.append(idx)
        n_lam = n + sum(len(b) for b in blocks[1:])
        flat_t = np.zeros(0, int)
        if with_film and flat_mode == "friction":
            flat_t = n_lam + np.arange(len(tang_nodes))
            tangential.append(flat_t)
            friction.append(np.full(len(flat_t), opts.friction_coefficient))
            gate.append(-np.ones(len(flat_t), int))
            n_lam += len(flat_t)
        tangential = np.concatenate(tangential) if tangential else np.zeros(0, int)
        friction = np.concatenate(friction) if friction else np.zeros(0)
        gate = np.concatenate(gate) if gate else np.zeros(0, int)

        # maps: B_S (Lambda -> sphere face forces), D (Lambda -> lower body x)
        m_s = len(self.sphere_body.face_dofs)
        B_S = np.zeros((n_lam, m_s))
        D = np.zeros((n_lam, low.n_x))
        B_S[normal, self._s_z] = 1.0
        D[normal, low.top_z] = 1.0
        if sphere_mode != "frictionless":
            idx = n + np.arange(len(tang_nodes))
            B_S[idx, self._s_r[tang_nodes]] = 1.0
            D[idx, low.top_r[tang_nodes]] = 1.0
        if len(flat_t):
            D[flat_t, low.film_bottom_r[tang_nodes]] = -1.0
            D[flat_t, low.flat_r[tang_nodes]] = 1.0

        G = self.sphere_body.compliance
        H_s = B_S @ G @ B_S.T
        d0_unit = B_S @ self.sphere_body.load_displacement  # per newton of load
        g0 = np.zeros(n_lam)
        g0[normal] = self.gap0_mm
        a = np.zeros(n_lam)
        a[normal] = 1.0
        K_film = self._film_stiffness(film) if with_film else None

        steps = opts.steps()
        nonlinear = bool(opts.large_strain and with_film)
        problem = _StepProblem(low, D, H_s, g0, d0_unit, a, normal, tangential, friction, gate, K_film, film,
                               nonlinear, opts.max_iterations)
        state = self._initial_state(n_lam, normal, tangential, force_n / steps)
        d_prev = np.zeros(n_lam)
        x = np.zeros(low.n_x)
        total_iterations = 0
        reason = ""
        converged = True
        # load increments; an increment whose active set or Newton iterations fail is
        # retried in halves, down to 1/16 of the nominal increment
        nominal = force_n / steps
        increment, done = nominal, 0.0
        while done < force_n * (1 - 1e-12):
            load = min(done + increment, force_n)
            ok, why, x_new, new_state, its = self._load_step(problem, load, x, state, d_prev)
            total_iterations += its
            if not ok:
                if increment > nominal / 16 * (1 + 1e-9):
                    increment /= 2
                    continue
                converged, reason = False, f"at {load / force_n:.0%} of the load: {why}"
                break
            x, state, done = x_new, new_state, load
            increment = min(2 * increment, nominal)
            d_prev = state.relative.copy()
            strain = self._film_strain(low, x) if with_film else np.zeros(n)
            if with_film and np.min(strain) <= -0.95:
                converged, reason = False, "film collapsed: through-thickness strain beyond -95 %"
                break
        edge = self._closing_edge_mm(problem, state, force_n, with_film) if converged else 0.0
        return self._result(film, force_n, opts, state, x, low, converged, reason, total_iterations,
                            film_type, imprint_model, t0, edge)

    def _closing_edge_mm(self, pb: "_StepProblem", state: ContactState, force_n: float, with_film: bool) -> float:
        """The contact edge from the loads at which its bracketing nodes open and close.

        With the contact statuses held the solution is affine in the force
        (`load_sensitivity`; for a large-strain film, its tangent at the
        solution): the last closed node k would open at F_k, the first open
        node k + 1 close at F_k+1, and the edge lies between them with a^3
        linear in F (exact for Hertz). A node-to-node pair closes when the
        continuum edge is already h/4 beyond it (``NODE_CLOSING_LEAD``,
        measured against Hertz: 0.246-0.253 h for h = 0.05 and 0.1 mm), and a
        film's elements at the edge add ``FILM_EDGE_LEAD_PER_MM`` h^2; both
        are subtracted.
        """
        n = self.n_face
        closed = np.flatnonzero(state.normal_status[:n] == CLOSED)
        k = int(closed[-1])
        r = self.r_face_mm
        if k + 1 >= n:
            return float(r[k])
        H, pairs = pb.solved
        dlam, _, dd = load_sensitivity(H, pb.a, pb.d0_unit, pairs, state)
        f_open = force_n - state.forces[k] / dlam[k] if dlam[k] > 0 else 0.0
        f_close = force_n - state.relative[k + 1] / dd[k + 1] if dd[k + 1] < 0 else np.inf
        s = float(np.clip((force_n - f_open) / (f_close - f_open), 0.0, 1.0)) if np.isfinite(f_close) else 0.0
        edge = float(np.cbrt(r[k] ** 3 + s * (r[k + 1] ** 3 - r[k] ** 3)))
        h = float(r[k + 1] - r[k])
        return edge - NODE_CLOSING_LEAD * h - (FILM_EDGE_LEAD_PER_MM * h * h if with_film else 0.0)

    def _load_step(self, pb: "_StepProblem", load: float, x: np.ndarray, state: ContactState,
                   d_prev: np.ndarray) -> tuple[bool, str, np.ndarray, ContactState, int]:
        """Solve the pair problem at one load level (Newton on a large-strain film)."""
        iterations = 0
        for _ in range(pb.max_iterations if pb.nonlinear else 1):
            if pb.nonlinear:
                try:
                    f_int, K_t = film_internal_force_and_tangent(self._film_basis, self._film_centre_basis, pb.film, self._film_dofs(pb.low, x))
                except np.linalg.LinAlgError:
                    return False, "film element inverted (film collapsed)", x, state, iterations
                K_L = self._lower_stiffness(pb.low, K_t)
                r_x = self._lower_internal(pb.low, f_int, x)  # lower body's residual without pair forces
            else:
                K_L = self._lower_stiffness(pb.low, pb.K_film)
                r_x = np.zeros(pb.low.n_x)
            try:
                solve = _factorised(K_L, pb.nonlinear)
            except np.linalg.LinAlgError:
                return False, "film stiffness singular (film collapsed)", x, state, iterations
            Y = solve(pb.D.T)
            x_hat = x - solve(r_x) if pb.nonlinear else np.zeros(pb.low.n_x)
            H = pb.H_s + pb.D @ Y
            d0 = pb.g0 + load * pb.d0_unit - pb.D @ x_hat
            pairs = PairSystem(pb.normal, pb.tangential, pb.friction, pb.gate,
                               *self._normal_force_map(pb.low, Y, x_hat, pb.tangential, pb.gate))
            state = solve_pairs(H, d0, pb.a, load, pairs, state, d_prev, pb.max_iterations)
            iterations += state.iterations
            if not state.converged:
                return False, state.reason, x, state, iterations
            pb.solved = (H, pairs)
            x_new = x_hat - Y @ state.forces
            if not pb.nonlinear:
                return True, "", x_new, state, iterations
            dx = np.max(np.abs(x_new - x))
            x = x_new
            if dx < 1e-9 * max(self.film_thickness_mm, 1.0):
                return True, "", x, state, iterations
        return False, "film Newton iterations did not converge", x, state, iterations

    def _initial_state(self, n_lam, normal, tangential, force_n) -> ContactState:
        a_guess = self._hertz_radius_mm(force_n)
        ns = np.where(self.r_face_mm <= 0.8 * a_guess, CLOSED, OPEN)
        ns[0] = CLOSED
        return ContactState(np.zeros(n_lam), 0.0, ns, np.full(len(tangential), FREE))

    def _normal_force_map(self, low: _Lower, Y, x_hat, tangential, gate):
        """Normal force of each tangential component's pair as an affine map of Lambda."""
        nt = len(tangential)
        n_lam = Y.shape[1]
        rows = np.zeros((nt, n_lam))
        offset = np.zeros(nt)
        for k in range(nt):
            if gate[k] >= 0:
                rows[k, gate[k]] = 1.0
        flat_k = np.flatnonzero(gate < 0)
        if len(flat_k):
            # force of the film on the flat at face node i, z: (S x_T)_z; the
            # flat pushes the film with its negative
            S = self.flat_body.stiffness
            nodes = np.arange(1, self.n_face)
            Sz = S[self._f_z[nodes]]  # rows of S for the z DOFs
            Xmap = np.zeros((len(low.flat_index), low.n_x))
            Xmap[np.arange(len(low.flat_index)), low.flat_index] = 1.0
            rows[flat_k] = Sz @ Xmap @ Y  # x = x_hat - Y Lambda -> -(S x)_z = S Y Lambda - S x_hat
            offset[flat_k] = -(Sz @ (Xmap @ x_hat))
        return rows, offset

    def _film_dofs(self, low: _Lower, x: np.ndarray) -> np.ndarray:
        u = np.zeros(self._film_basis.N)
        keep = low.film_index >= 0
        u[keep] = x[low.film_index[keep]]
        return u

    def _lower_internal(self, low: _Lower, f_int_film: np.ndarray, x: np.ndarray) -> np.ndarray:
        r = np.zeros(low.n_x)
        keep = low.film_index >= 0
        np.add.at(r, low.film_index[keep], f_int_film[keep])
        S = self.flat_body.stiffness
        xt = x[low.flat_index]
        np.add.at(r, low.flat_index, S @ xt)
        return r

    def _film_strain(self, low: _Lower, x: np.ndarray) -> np.ndarray:
        top = x[low.top_z]
        bottom = x[low.flat_z]
        return (top - bottom) / self.film_thickness_mm

    def _result(self, film, force_n, opts, state: ContactState, x, low, converged, reason, iterations,
                film_type, imprint_model, t0, edge_mm: float) -> FEResult:
        n = self.n_face
        lam_n = state.forces[:n] if len(state.forces) else np.zeros(n)
        pressure = np.where(state.normal_status == CLOSED, lam_n / self.face_area_mm2, 0.0)
        active = state.normal_status == CLOSED
        gaps = state.relative[:n] if len(state.relative) else np.full(n, np.nan)
        tip = (film_tip_length_mm(self.film_thickness_mm, film.oedometric_modulus_mpa, film.poisson)
               if film is not None else float("inf"))
        if converged and active[-3:].any():
            converged = False
            reason = (f"contact reached the edge of the refined zone (r = {self.r_face_mm[-1]:.2f} mm): "
                      "enlarge MeshSettings.contact_zone_mm (filmcal fem sizes it to 1.6 Hertz radii at its force; "
                      "a film that spreads the contact further needs it larger)")
        a_h = self._hertz_radius_mm(force_n)
        strain = self._film_strain(low, x) if film is not None else np.zeros(n)
        result = FEResult(
            sphere_radius_mm=self.sphere_radius_mm, force_n=force_n,
            film_modulus_mpa=None if film is None else film.modulus_mpa,
            film_poisson=None if film is None else film.poisson,
            sphere_contact=opts.sphere_contact, flat_contact=opts.flat_contact if film is not None else "none",
            friction_coefficient=opts.friction_coefficient,
            kinematics="large" if opts.large_strain and film is not None else "small",
            contact_radius_mm=edge_mm, contact_area_mm2=float(np.pi * edge_mm**2),
            max_pressure_mpa=float(np.max(pressure)), hertz_radius_mm=a_h,
            approach_mm=float(-state.rigid_w), film_strain_max=float(-np.min(strain)) if film is not None else 0.0,
            r_mm=self.r_face_mm.copy(), pressure_mpa=pressure, gap_mm=gaps, film_strain=strain,
            n_active=int(active.sum()), imprint_radius_mm=None, imprint_area_mm2=None,
            activation_pressure_mpa=None if film_type is None else film_type.activation_pressure_mpa,
            imprint_model=None if film_type is None else imprint_model,
            film=None if film_type is None else film_type.name, edge_tip_mm=tip,
            converged=bool(converged), reason=reason, iterations=int(iterations),
            elapsed_s=0.0, n_dofs=self.n_dofs, element_size_mm=self.mesh.element_size_mm,
        )
        if edge_mm <= 0:  # a failed solve: the profile's own reading, for the record
            result.contact_radius_mm = float(result.profile().edge_mm)
            result.contact_area_mm2 = float(np.pi * result.contact_radius_mm**2)
        if film_type is not None:
            imprint = get_imprint_model(imprint_model).radius_from_profile(result.profile(), film_type)
            result.imprint_radius_mm = float(imprint)
            result.imprint_area_mm2 = float(np.pi * imprint**2)
        result.elapsed_s = time.perf_counter() - t0
        return result
