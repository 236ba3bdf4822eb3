"""Large-strain film law: the oedometric law of the FE's neo-Hookean film."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from filmcal.elastic import lame_parameters, oedometric_modulus_mpa
from filmcal.contact.laws import (ExponentialLaw, FilmLayer, LargeStrainFilm, SeriesLaw,
                                         film_law)


@pytest.mark.parametrize("modulus", [500.0, 2800.0, 10000.0])
def test_small_strain_limit_is_the_linear_film(modulus):
    """At small strain the law is the linear oedometric spring t/M (analytic limit)."""
    film = LargeStrainFilm(modulus, 0.33, 0.09)
    linear = FilmLayer(modulus, 0.33, 0.09)
    p = np.array([1e-3, 1e-2]) * modulus
    ratio = film.closure_mm(p) / (linear.compliance_mm_per_mpa * p)
    # first-order correction: the strain is 1e-3 or 1e-2 of E/M, the ratio 1 - O(strain)
    assert ratio[0] == pytest.approx(1.0, abs=2e-3)
    assert ratio[1] == pytest.approx(1.0, abs=2e-2)
    assert film.initial_compliance_mm_per_mpa == pytest.approx(linear.compliance_mm_per_mpa,
                                                               rel=1e-12)
    assert film.oedometric_modulus_mpa == pytest.approx(
        oedometric_modulus_mpa(modulus, 0.33), rel=1e-12)


def test_pressure_is_minus_the_energy_derivative():
    """p = -dW/dlambda of the documented energy, by finite differences of W (second method)."""
    e, nu, t = 768.0, 0.33, 0.09
    lam, mu = lame_parameters(e, nu)

    def energy(stretch):  # W = mu/2 (tr C - 3) - mu ln J + lam/2 (ln J)^2, C = diag(l^2, 1, 1)
        return 0.5 * mu * (stretch ** 2 - 1.0) - mu * math.log(stretch) + 0.5 * lam * math.log(stretch) ** 2

    film = LargeStrainFilm(e, nu, t)
    for stretch in (0.95, 0.7, 0.3):
        h = 1e-6
        expected = -(energy(stretch + h) - energy(stretch - h)) / (2 * h)
        got = film.pressure_mpa(np.array([t * (1.0 - stretch)]))[0]
        assert got == pytest.approx(expected, rel=1e-6)


def test_nominal_stress_of_the_fe_film_element():
    """The FE's large-strain film (filmcal.fem.largestrain) compressed uniaxially by 50 %
    carries the pressure of the law (independent code path: FE assembly of P)."""
    from skfem import ElementQuad1, ElementVector, MeshQuad

    from filmcal.fem.forms import film_bases
    from filmcal.fem.largestrain import film_internal_force_and_tangent

    class Material:
        modulus_mpa, poisson = 768.0, 0.33

    t = 0.09
    mesh = MeshQuad.init_tensor(np.linspace(1.0, 2.0, 3), np.linspace(0.0, t, 3))
    basis = film_bases(mesh, ElementVector(ElementQuad1()))
    for strain in (0.1, 0.5, 0.7):
        u = np.zeros(basis[0].N)
        u[basis[0].nodal_dofs[1]] = -strain * (mesh.p[1] - t)
        force, _ = film_internal_force_and_tangent(*basis, Material, u)
        top = np.isclose(mesh.p[1], t)
        stress = -force[basis[0].nodal_dofs[1]][top].sum() / (math.pi * (2.0 ** 2 - 1.0 ** 2))
        law = LargeStrainFilm(768.0, 0.33, t).pressure_mpa(np.array([strain * t]))[0]
        assert law == pytest.approx(stress, rel=1e-9)


def test_inverse_tangent_and_integral():
    film = LargeStrainFilm(768.0, 0.33, 0.09)
    p = np.array([0.0, 5.0, 100.0, 900.0, 3000.0])
    c = film.closure_mm(p)
    assert np.all(np.diff(c) > 0) and c[-1] < 0.09
    assert film.pressure_mpa(c) == pytest.approx(p, rel=1e-9, abs=1e-9)
    for q in (10.0, 700.0):
        h = 1e-3 * q
        fd = (film.closure_mm(np.array([q + h])) - film.closure_mm(np.array([q - h]))) / (2 * h)
        assert film.tangent_compliance_mm_per_mpa(np.array([q]))[0] == pytest.approx(fd[0], rel=1e-6)
        integral = quad(lambda s: float(film.closure_mm(np.array([s]))[0]), 0.0, q)[0]
        assert film.closure_integral(np.array([q]))[0] == pytest.approx(integral, rel=1e-8)
    # MS at about 70 % compression: far below the linear extrapolation (which exceeds t)
    p70 = film.pressure_mpa(np.array([0.7 * 0.09]))[0]
    assert FilmLayer(768.0).compliance_mm_per_mpa * p70 > 0.09


def test_series_law_adds_closures_and_inverts():
    film = LargeStrainFilm(2739.0)
    rough = ExponentialLaw(5.0, 0.002)
    law = SeriesLaw(film, rough)
    p = np.array([0.0, 1.0, 50.0, 500.0])
    assert law.closure_mm(p) == pytest.approx(film.closure_mm(p) + rough.closure_mm(p))
    assert law.pressure_mpa(law.closure_mm(p)) == pytest.approx(p, rel=1e-8, abs=1e-8)
    assert law.closure_integral(p) == pytest.approx(film.closure_integral(p) + rough.closure_integral(p))
    f, l = film_law(FilmLayer(2739.0), rough, kinematics="large")
    assert f is None and isinstance(l, SeriesLaw)
    f, l = film_law(FilmLayer(2739.0), None, kinematics="small")
    assert isinstance(f, FilmLayer) and l is None
    with pytest.raises(ValueError, match="modulus_mpa"):
        LargeStrainFilm(-1.0)
    with pytest.raises(ValueError, match="poisson"):
        LargeStrainFilm(1000.0, 0.5)


@pytest.mark.parametrize("modulus, force_kn", [(300.0, 50.0), (768.0, 100.0), (2739.0, 100.0)])
def test_large_strain_sphere_on_flat_matches_the_fe(modulus, force_kn):
    """Second method: the half-space with the large-strain film law against the FE model
    with its large-strain (neo-Hookean) film, R450. The film shrinks the contact by
    0.1-0.9 mm against the linear film; both methods agree on that shift within 0.02 mm
    and on the radius within 0.06 mm (the Winkler film's pressure tail)."""
    from filmcal.fem import ContactOptions, Film, solve_sphere_on_flat
    from filmcal.wheelrail.halfspace import HalfSpaceContactSolver, sphere_on_flat_contact

    solver = HalfSpaceContactSolver()
    film = FilmLayer(modulus, 0.33, 0.09)
    radius = {}
    for large in (False, True):
        fe = solve_sphere_on_flat(450.0, 1e3 * force_kn, Film(modulus, 0.33),
                                  ContactOptions(kinematics="large" if large else "small"))
        assert fe.converged
        f, law = film_law(film, None, kinematics="large" if large else "small")
        hs = sphere_on_flat_contact(450.0, 1e3 * force_kn, film=f, law=law, solver=solver)
        radius[large] = (fe.contact_radius_mm, hs.equivalent_radius_mm)
    shift_fe = radius[True][0] - radius[False][0]
    shift_hs = radius[True][1] - radius[False][1]
    assert shift_fe < -0.05
    assert shift_hs == pytest.approx(shift_fe, abs=0.02)
    assert radius[True][1] == pytest.approx(radius[True][0], abs=0.06)


def test_fe_film_tangent_is_the_derivative_of_its_internal_force():
    """The large-strain film's tangent stiffness equals central differences of its internal force
    at a general (sheared, compressed, radially displaced) state."""
    from skfem import ElementQuad1, ElementVector, MeshQuad

    from filmcal.fem.forms import film_bases
    from filmcal.fem.largestrain import film_internal_force_and_tangent

    class Material:
        modulus_mpa, poisson = 2800.0, 0.33

    mesh = MeshQuad.init_tensor(np.linspace(0.5, 2.0, 4), np.linspace(0.0, 0.09, 3))
    bases = film_bases(mesh, ElementVector(ElementQuad1()))
    basis = bases[0]
    rng = np.random.default_rng(2)
    u = np.zeros(basis.N)
    u[basis.nodal_dofs[1]] = -0.3 * (mesh.p[1] - 0.09) + 0.002 * rng.standard_normal(mesh.p.shape[1])
    u[basis.nodal_dofs[0]] = 0.01 * mesh.p[1] + 0.002 * rng.standard_normal(mesh.p.shape[1])
    _, K = film_internal_force_and_tangent(*bases, Material, u)
    h = 1e-7
    fd = np.empty_like(K)
    for j in range(basis.N):
        step = np.zeros(basis.N)
        step[j] = h
        fd[:, j] = (film_internal_force_and_tangent(*bases, Material, u + step)[0]
                    - film_internal_force_and_tangent(*bases, Material, u - step)[0]) / (2 * h)
    assert np.abs(K - fd).max() <= 1e-6 * np.abs(K).max()
    assert np.allclose(K, K.T, rtol=0, atol=1e-9 * np.abs(K).max())


def test_large_strain_law_stays_finite_far_beyond_the_film_modulus():
    """p = 10^4 E crushed a 0.1 MPa film's Newton start p/M into sinh overflow (NaN, then an IndexError in the
    wheel-rail solver); from the bound ln(1 + p/mu) the root is found, and it is the root: p(s(p)) = p. (The
    softest film a FilmLayer takes is now 1 MPa; the pressures keep their ratios to it, up to 10^6 E.)"""
    import warnings

    from filmcal.contact.laws import FilmLayer, LargeStrainFilm

    law = LargeStrainFilm.from_film(FilmLayer(1.0, 0.33, 0.09))
    p = np.array([1e-2, 1.0, 100.0, 1e4, 1e6])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = law.log_compression(p)
    assert np.all(np.isfinite(s)) and np.all(np.diff(s) > 0)
    np.testing.assert_allclose(law._pressure_of_log(s), p, rtol=1e-10)


def test_the_large_strain_film_reuses_its_last_solve_only_for_the_same_pressures():
    """log_compression keeps its last answer (a solver asks for the closure, its slope and its integral at one
    pressure): an array changed in place, or another array, is solved anew; answers equal a fresh law's."""
    import numpy as np

    from filmcal.contact.laws import LargeStrainFilm

    p = np.linspace(0.0, 900.0, 50)
    law = LargeStrainFilm(538.0, 0.33, 0.09)
    first = law.closure_mm(p)
    p *= 0.5  # the caller's array, changed in place
    assert np.array_equal(law.closure_mm(p), LargeStrainFilm(538.0, 0.33, 0.09).closure_mm(p))
    assert not np.array_equal(law.closure_mm(p), first)
    s = law.log_compression(p)
    s[:] = -1.0  # a returned array changed by the caller does not change the next answer
    assert np.array_equal(law.log_compression(p), LargeStrainFilm(538.0, 0.33, 0.09).log_compression(p))
