"""Edge reading of grid contacts, and the film springs against the axisymmetric FE model."""
from __future__ import annotations

import math

import numpy as np
import pytest

from filmcal.fem import Film, get_model, read_contact_radius
from filmcal.hertz import contact_modulus_mpa
from filmcal.wheelrail.edge import EdgeWindow, read_contact_edge, read_radial_edge_mm
from filmcal.wheelrail.halfspace import HalfSpaceContactSolver, sphere_on_flat_contact
from filmcal.wheelrail.interface import FilmLayer


@pytest.fixture(scope="module")
def solver():
    return HalfSpaceContactSolver()


@pytest.mark.parametrize("gamma", [0.5, 0.8, 1.2])
def test_radial_reading_recovers_an_exact_edge_profile(gamma):
    """Pressures exactly b (a^2 - r^2)^gamma on a 0.1 mm grid: the fit returns a."""
    r = np.arange(0.0, 9.0, 0.1)
    a = 7.1234
    p = 300.0 * np.clip(a * a - r * r, 0.0, None) ** gamma
    assert read_radial_edge_mm(r, p) == pytest.approx(a, abs=1e-6)


@pytest.mark.parametrize("film", [None, Film(1000.0, 0.33), Film(2800.0, 0.33)])
def test_radial_reading_is_the_fe_reading(model450, film):
    """Same data, same definition: the wheel-rail reader equals filmcal.fem's reader."""
    fe = model450.solve(film, 75e3)
    mine = read_radial_edge_mm(fe.r_mm, fe.pressure_mpa)
    theirs = read_contact_radius(fe.r_mm, fe.pressure_mpa, fe.pressure_mpa > 0)
    assert mine == pytest.approx(theirs, abs=1e-5)
    assert mine == pytest.approx(fe.contact_radius_mm, abs=1e-5)


def test_fitted_outline_of_a_hertz_contact_is_the_hertz_circle(solver):
    """Hard contact: the fitted edge is the zero-pressure edge of Hertz (gamma = 1/2)."""
    res = sphere_on_flat_contact(450.0, 75e3, solver=solver)
    reading = read_contact_edge(res)
    a_hertz = (3.0 * 75e3 * 450.0 / (4.0 * contact_modulus_mpa())) ** (1.0 / 3.0)
    assert math.sqrt(reading.area_mm2 / math.pi) == pytest.approx(a_hertz, abs=0.005)
    assert reading.mean_gamma == pytest.approx(0.5, abs=0.03)
    assert reading.n_failed == 0 and reading.n_fitted > 100


def test_fitted_outline_removes_the_winkler_tail(solver):
    """With a film the fitted edge lies inside the positive-pressure outline by a few
    hundredths of a millimetre (the linear tail of the film springs), never outside."""
    res = sphere_on_flat_contact(450.0, 75e3, film=FilmLayer(2800.0), solver=solver)
    reading = read_contact_edge(res)
    offsets = np.concatenate(reading.offsets_mm)
    assert 0.02 < offsets.mean() < 0.08
    assert reading.area_mm2 < res.area_mm2
    assert reading.mean_gamma > 0.6


def test_short_chords_are_not_fitted():
    """A window that does not fit twice into any chord leaves the outline unchanged."""
    res = sphere_on_flat_contact(300.0, 25e3)
    reading = read_contact_edge(res, EdgeWindow(outer_mm=6.0, inner_mm=0.2))
    assert reading.n_fitted == 0
    assert reading.area_mm2 == pytest.approx(res.area_mm2, rel=1e-12)


CASES = [(300.0, 25e3), (450.0, 75e3), (600.0, 50e3), (600.0, 100e3)]


@pytest.mark.parametrize("radius_mm, force_n", CASES)
def test_film_springs_match_the_fe_film_within_0_02_mm(solver, radius_mm, force_n):
    """Film tied to the flat, frictionless at the sphere (FE defaults) against the film springs,
    both read with the FE edge-profile fit: radii within 0.02 mm for E = 1000-5000 MPa.
    The positive-pressure radius of the springs is 0.02-0.07 mm larger (the Winkler tail)."""
    model = get_model(radius_mm)
    for modulus in (1000.0, 2800.0, 5000.0):
        fe = model.solve(Film(modulus, 0.33), force_n)
        bem = sphere_on_flat_contact(radius_mm, force_n, film=FilmLayer(modulus, 0.33, 0.09),
                                     solver=solver)
        fitted = math.sqrt(read_contact_edge(bem).area_mm2 / math.pi)
        assert abs(fitted - fe.contact_radius_mm) <= 0.02, (modulus, fitted, fe.contact_radius_mm)
        assert bem.equivalent_radius_mm - fe.contact_radius_mm > 0.015
