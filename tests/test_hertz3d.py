"""Elliptic Hertz theory against closed forms and published coefficient tables."""
from __future__ import annotations

import math

import numpy as np
import pytest

from filmcal.hertz import hertz_radius_mm
from filmcal.wheelrail.hertz import hertz_elliptic

STEEL_E_STAR = 210000.0 / (2.0 * (1.0 - 0.3 ** 2))


def test_design_fact_r450_75kn():
    """DESIGN.md: R450, 75 kN, two steel bodies -> a = 6.031 mm, p0 = 984.5 MPa."""
    h = hertz_elliptic(1.0 / 900.0, 1.0 / 900.0, 75e3)
    assert h.semi_axis_x_mm == pytest.approx(6.031, abs=5e-4)
    assert h.max_pressure_mpa == pytest.approx(984.5, abs=0.05)
    assert h.approach_mm == pytest.approx(h.semi_axis_x_mm ** 2 / 450.0, rel=1e-12)
    assert h.semi_axis_x_mm == pytest.approx(hertz_radius_mm(450.0, 75e3), rel=1e-12)


@pytest.mark.parametrize("radius_mm, force_n", [(300.0, 25e3), (450.0, 75e3), (600.0, 100e3)])
def test_elliptic_solution_reduces_to_circular(radius_mm, force_n):
    """Equal curvatures A = B = 1/(2R): a = (3FR/(4E*))**(1/3), delta = a**2/R."""
    coef = 1.0 / (2.0 * radius_mm)
    ell = hertz_elliptic(coef, coef, force_n)
    a = (3.0 * force_n * radius_mm / (4.0 * STEEL_E_STAR)) ** (1.0 / 3.0)
    assert ell.semi_axis_x_mm == pytest.approx(a, rel=1e-12)
    assert ell.semi_axis_y_mm == pytest.approx(a, rel=1e-12)
    assert ell.approach_mm == pytest.approx(a * a / radius_mm, rel=1e-12)
    assert ell.max_pressure_mpa == pytest.approx(3 * force_n / (2 * math.pi * a * a), rel=1e-12)
    # an almost circular ellipse (series branch and root finder) stays continuous
    near = hertz_elliptic(coef, coef * (1 + 1e-7), force_n)
    assert near.semi_axis_x_mm == pytest.approx(a, rel=1e-7)
    assert near.approach_mm == pytest.approx(a * a / radius_mm, rel=1e-7)


# Classic table of the Hertz coefficients m, n with a = m c, b = n c,
# c = (3 F / (4 E* (A + B)))**(1/3), cos(theta) = (B - A)/(A + B)
# (Timoshenko & Goodier, Theory of Elasticity, 3rd ed., sec. 140).
TIMOSHENKO_TABLE = [  # theta (deg), m, n
    (30, 2.731, 0.493), (35, 2.397, 0.530), (40, 2.136, 0.567), (45, 1.926, 0.604),
    (50, 1.754, 0.641), (55, 1.611, 0.678), (60, 1.486, 0.717), (65, 1.378, 0.759),
    (70, 1.284, 0.802), (75, 1.202, 0.846), (80, 1.128, 0.893), (85, 1.061, 0.944),
    (90, 1.000, 1.000),
]

# The same coefficients (xi, eta) against cos(tau) = (B - A)/(A + B), from the
# Schaeffler "Technisches Taschenbuch" (pp. 255-256), down to a/b = 147.
SCHAEFFLER_TABLE = [  # cos tau, xi, eta
    (0.1, 1.07, 0.938), (0.2, 1.15, 0.879), (0.3, 1.24, 0.824), (0.4, 1.35, 0.771),
    (0.5, 1.48, 0.718), (0.6, 1.66, 0.664), (0.7, 1.91, 0.607), (0.8, 2.30, 0.544),
    (0.9, 3.09, 0.461), (0.95, 4.12, 0.396), (0.99, 7.76, 0.287), (0.995, 10.15, 0.251),
    (0.9995, 23.95, 0.163),
]


def _coefficients(cos_angle: float) -> tuple[float, float]:
    a_coef, b_coef = 1.0, (1.0 + cos_angle) / (1.0 - cos_angle)
    force, e_star = 1000.0, STEEL_E_STAR
    sol = hertz_elliptic(a_coef, b_coef, force, e_star)
    scale = (3.0 * force / (4.0 * e_star * (a_coef + b_coef))) ** (1.0 / 3.0)
    return sol.semi_axis_x_mm / scale, sol.semi_axis_y_mm / scale


@pytest.mark.parametrize("theta, m, n", TIMOSHENKO_TABLE)
def test_classic_m_n_table(theta, m, n):
    """Printed to 3-4 digits: agreement within 0.3 %."""
    m_calc, n_calc = _coefficients(math.cos(math.radians(theta)))
    assert m_calc == pytest.approx(m, rel=3e-3)
    assert n_calc == pytest.approx(n, rel=3e-3)


@pytest.mark.parametrize("cos_tau, xi, eta", SCHAEFFLER_TABLE)
def test_schaeffler_xi_eta_table(cos_tau, xi, eta):
    """Printed to 3-4 digits: agreement within 0.5 %."""
    xi_calc, eta_calc = _coefficients(cos_tau)
    assert xi_calc == pytest.approx(xi, rel=5e-3)
    assert eta_calc == pytest.approx(eta, rel=5e-3)


def test_force_equals_integral_of_pressure_and_axes_follow_curvatures():
    sol = hertz_elliptic(1.0 / 2000.0, 1.0 / 200.0, 75e3)
    # the longer axis lies along the smaller curvature
    assert sol.semi_axis_x_mm > sol.semi_axis_y_mm
    # F = int p dA, integrated numerically on a fine grid
    x = np.linspace(-sol.semi_axis_x_mm, sol.semi_axis_x_mm, 2001)
    y = np.linspace(-sol.semi_axis_y_mm, sol.semi_axis_y_mm, 2001)
    xx, yy = np.meshgrid(x, y, indexing="ij")
    force = np.trapezoid(np.trapezoid(sol.pressure_mpa(xx, yy), y, axis=1), x)
    assert force == pytest.approx(75e3, rel=2e-3)
    assert sol.area_mm2 == pytest.approx(math.pi * sol.semi_axis_x_mm * sol.semi_axis_y_mm)
    swapped = hertz_elliptic(1.0 / 200.0, 1.0 / 2000.0, 75e3)
    assert swapped.semi_axis_x_mm == pytest.approx(sol.semi_axis_y_mm, rel=1e-12)
    assert swapped.semi_axis_y_mm == pytest.approx(sol.semi_axis_x_mm, rel=1e-12)
    assert swapped.approach_mm == pytest.approx(sol.approach_mm, rel=1e-12)


def test_scaling_with_force():
    """a, b ~ F**(1/3), delta ~ F**(2/3) at fixed curvatures."""
    low = hertz_elliptic(1e-3, 4e-3, 25e3)
    high = hertz_elliptic(1e-3, 4e-3, 200e3)
    assert high.semi_axis_x_mm / low.semi_axis_x_mm == pytest.approx(2.0, rel=1e-10)
    assert high.approach_mm / low.approach_mm == pytest.approx(4.0, rel=1e-10)


@pytest.mark.parametrize("kwargs, name", [
    (dict(gap_coefficient_x_per_mm=0.0), "gap_coefficient_x_per_mm"),
    (dict(gap_coefficient_y_per_mm=-1e-3), "gap_coefficient_y_per_mm"),
    (dict(force_n=0.0), "force_n"),
    (dict(force_n=float("nan")), "force_n"),
    (dict(contact_modulus=-5.0), "contact_modulus"),
])
def test_bad_input_names_the_parameter(kwargs, name):
    args = dict(gap_coefficient_x_per_mm=1e-3, gap_coefficient_y_per_mm=2e-3, force_n=1e4)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        hertz_elliptic(**args)
