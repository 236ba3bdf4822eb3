"""Edge reading of grid contacts, and the film springs against the axisymmetric FE model."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import ndimage

from filmcal.contact import get_imprint_model
from filmcal.fem import Film, get_model
from filmcal.films import get_film
from filmcal.hertz import contact_modulus_mpa
from filmcal.wheelrail.edge import (patch_ring_areas_mm2, read_contact_edge, read_fitted_outline,
                                    read_radial_edge_mm)
from filmcal.wheelrail.halfspace import HalfSpaceContactSolver, sphere_on_flat_contact
from filmcal.contact.laws import FilmLayer


@pytest.fixture(scope="module")
def solver():
    return HalfSpaceContactSolver()


def test_radial_reading_recovers_a_hertz_line():
    """Cell pressures exactly p0 sqrt(1 - r^2/a^2) at cell centres: the edge is a."""
    r = np.arange(0.05, 9.0, 0.1)
    a = 7.1234
    p = 900.0 * np.sqrt(np.clip(1 - r * r / (a * a), 0.0, None))
    assert read_radial_edge_mm(r, p) == pytest.approx(a, abs=1e-6)


def test_outline_of_a_hertz_contact_is_the_hertz_circle(solver):
    """Hard contact: the zero-pressure edge is Hertz's circle, and it is the edge imprint model."""
    res = sphere_on_flat_contact(450.0, 75e3, solver=solver)
    reading = read_contact_edge(res)
    a_hertz = (3.0 * 75e3 * 450.0 / (4.0 * contact_modulus_mpa())) ** (1.0 / 3.0)
    assert math.sqrt(reading.area_mm2 / math.pi) == pytest.approx(a_hertz, abs=0.005)
    grid = res.grid
    same = get_imprint_model("edge").area_mm2(grid.x_mm, grid.y_mm, res.pressure_mpa, get_film("HS"))
    assert reading.area_mm2 == pytest.approx(same, rel=1e-12)
    assert reading.patch_areas_mm2(1)[0] == pytest.approx(reading.area_mm2, rel=1e-12)


def test_two_patches_are_labelled():
    """Two Hertz circles on one grid: each patch gets its own area."""
    x = np.arange(0, 20, 0.1) + 0.05
    y = np.arange(0, 8, 0.1) + 0.05
    X, Y = np.meshgrid(x, y, indexing="ij")
    p = np.zeros_like(X)
    for cx, radius in ((5.0, 3.0), (14.0, 2.0)):
        p += 300 * np.sqrt(np.clip(1 - ((X - cx) ** 2 + (Y - 4) ** 2) / radius**2, 0, None))
    labels, n = ndimage.label(p > 0, structure=np.ones((3, 3), dtype=int))
    reading = read_fitted_outline(x, y, p, None, labels)
    areas = reading.patch_areas_mm2(n)
    assert areas == pytest.approx([math.pi * 9, math.pi * 4], rel=3e-3)
    support = patch_ring_areas_mm2(x, y, reading.rings_mm, labels, n)
    assert support == pytest.approx(areas, rel=1e-12)


CASES = [(300.0, 25e3), (450.0, 75e3), (600.0, 50e3), (600.0, 100e3)]


@pytest.mark.parametrize("radius_mm, force_n", CASES)
def test_film_springs_match_the_fe_film_within_0_01_mm(solver, radius_mm, force_n):
    """Film tied to the flat, frictionless at the sphere (FE defaults) against the film springs,
    both read at their zero-pressure edge: radii within 0.01 mm for E = 1000-5000 MPa, and
    the activation contours (HS, 50 MPa) within 0.02 mm. The solver's positive-pressure
    outline (boundary cells) lies 0.02-0.04 mm further out."""
    model = get_model(radius_mm)
    hs = get_film("HS")
    for modulus in (1000.0, 2800.0, 5000.0):
        fe = model.solve(Film(modulus, 0.33), force_n)
        bem = sphere_on_flat_contact(radius_mm, force_n, film=FilmLayer(modulus, 0.33, 0.09),
                                     solver=solver)
        edge = math.sqrt(read_contact_edge(bem).area_mm2 / math.pi)
        assert abs(edge - fe.contact_radius_mm) <= 0.01, (modulus, edge, fe.contact_radius_mm)
        grid = bem.grid
        act = math.sqrt(get_imprint_model("activation").area_mm2(grid.x_mm, grid.y_mm, bem.pressure_mpa, hs)
                        / math.pi)
        assert abs(act - fe.read_imprint("activation", hs)) <= 0.02
        assert bem.equivalent_radius_mm - fe.contact_radius_mm > 0.015
