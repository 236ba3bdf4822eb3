"""Imprint models and the readings behind them, against analytic pressure fields.

Every expected value comes from a closed form or from scipy quadrature of the
analytic field, never from the reading code itself.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from filmcal.contact import (IMPRINT_MODELS, GridField, get_imprint_model, imprint_key, outline_area_mm2,
                             read_imprints, read_radial_profile, ring_signed_area_mm2)
from filmcal.films import FilmType, get_film

HS = get_film("HS")


def _lognormal_cdf(p, lo, hi, q=0.02):
    """The capsule model's stated law, written out independently: log-normal
    burst strengths with the range ends at the q and 1 - q quantiles."""
    from statistics import NormalDist

    z = NormalDist().inv_cdf(1 - q)
    mu, sigma = 0.5 * math.log(lo * hi), math.log(hi / lo) / (2 * z)
    return NormalDist().cdf((math.log(p) - mu) / sigma) if p > 0 else 0.0


# ---------------------------------------------------------------- stain laws

def test_model_names_and_lookup():
    assert IMPRINT_MODELS == ("edge", "activation", "capsule")
    for name in IMPRINT_MODELS:
        assert get_imprint_model(name).name == name
    with pytest.raises(ValueError, match="imprint model must be one of"):
        get_imprint_model("stacked")
    assert imprint_key("activation", HS) == "radius_activation_HS_mm"
    assert imprint_key("capsule", "MS") == "radius_capsule_MS_mm"
    assert imprint_key("edge", HS) == "contact_radius_mm"


def test_stain_probabilities():
    p = np.array([0.0, 1.0, 49.9, 50.0, 80.0, 130.0, 500.0])
    edge = get_imprint_model("edge").stain_probability(p, HS)
    act = get_imprint_model("activation").stain_probability(p, HS)
    cap = get_imprint_model("capsule").stain_probability(p, HS)
    assert edge.tolist() == [0, 1, 1, 1, 1, 1, 1]
    assert act.tolist() == [0, 0, 0, 1, 1, 1, 1]
    assert np.all((cap >= 0) & (cap <= 1)) and np.all(np.diff(cap) >= 0)
    for value, got in zip(p, cap):
        assert got == pytest.approx(_lognormal_cdf(value, 50.0, 130.0), abs=1e-12)
    # the range ends are the 2 % and 98 % quantiles; the median is the geometric mean
    assert cap[3] == pytest.approx(0.02) and cap[5] == pytest.approx(0.98)
    mid = get_imprint_model("capsule").stain_probability(np.array([math.sqrt(50 * 130)]), HS)
    assert mid[0] == pytest.approx(0.5)


def test_films_without_the_needed_facts_are_refused():
    bare = FilmType("BARE")
    act_only = FilmType("ACT", activation_pressure_mpa=40.0)
    r = np.linspace(0, 5, 51)
    p = np.clip(100 * (1 - r**2 / 16), 0, None)
    assert get_imprint_model("edge").radius_mm(r, p, bare) > 0
    with pytest.raises(ValueError, match="BARE has no activation_pressure_mpa"):
        get_imprint_model("activation").radius_mm(r, p, bare)
    with pytest.raises(ValueError, match="needs a film type"):
        get_imprint_model("activation").stain_probability(p, None)
    with pytest.raises(ValueError, match="ACT has no range_mpa"):
        get_imprint_model("capsule").radius_mm(r, p, act_only)
    # p linear in a^2 - r^2 (a vanishing tip), sampled at points
    got = get_imprint_model("activation").radius_mm(r, p, act_only, tip_mm=1e-3, samples="point")
    assert got == pytest.approx(4 * math.sqrt(1 - 0.4), abs=1e-3)


# ---------------------------------------------------------- 2D fields (areas)

def _hertz_ellipse(a, b, p0, spacing=0.1, centre=(0.37, -0.21)):
    x = np.arange(-1.4 * a, 1.4 * a, spacing) + centre[0] + 0.013
    y = np.arange(-1.4 * b, 1.4 * b, spacing) + centre[1] - 0.029
    X, Y = np.meshgrid(x, y, indexing="ij")
    rho2 = ((X - centre[0]) / a) ** 2 + ((Y - centre[1]) / b) ** 2
    return x, y, p0 * np.sqrt(np.clip(1 - rho2, 0, None))


@pytest.mark.parametrize("a, b, p0", [(6.0, 4.0, 900.0), (3.1, 5.3, 420.0)])
@pytest.mark.parametrize("film", ["MS", "HS", "HHS"])
def test_area_of_a_hertz_ellipse(a, b, p0, film):
    """p = p0 sqrt(1 - x^2/a^2 - y^2/b^2) on a 0.1 mm grid (cell centres): the edge is
    the ellipse pi a b, the contour p = p_act the ellipse pi a b (1 - (p_act/p0)^2), and
    the capsule model's expected area pi a b int_0^1 P(p0 sqrt(1 - s)) ds."""
    ft = get_film(film)
    x, y, p = _hertz_ellipse(a, b, p0)
    exact_edge = math.pi * a * b
    exact_act = exact_edge * (1 - (ft.activation_pressure_mpa / p0) ** 2)
    exact_cap = exact_edge * quad(lambda s: _lognormal_cdf(p0 * math.sqrt(1 - s), *ft.range_mpa),
                                  0, 1, limit=200, points=[1 - (ft.range_mpa[0] / p0) ** 2])[0]
    # tolerance: an error of 0.005 mm all round the outline (half a twentieth of a cell)
    tol = 0.005 * math.pi * (a + b)
    assert get_imprint_model("edge").area_mm2(x, y, p, ft, through_film=False) == pytest.approx(exact_edge, abs=tol)
    assert get_imprint_model("activation").area_mm2(x, y, p, ft, through_film=False) == pytest.approx(exact_act, abs=tol)
    assert get_imprint_model("capsule").area_mm2(x, y, p, ft, through_film=False) == pytest.approx(exact_cap, abs=tol)


@pytest.mark.parametrize("film", ["MS", "HS"])
def test_area_of_a_linear_edge_field_at_every_phase_of_the_grid(film):
    """A film-like cone p = k (a - r), its centre moved across a cell: the contour p = p_act is the circle
    a - p_act / k within 1 um at every phase (contouring p**2, as without film, missed it by up to 4 um)."""
    ft = get_film(film)
    a, k = 5.0, 200.0
    x = np.arange(-7, 7, 0.1) + 0.05
    r_act = a - ft.activation_pressure_mpa / k
    for shift in np.linspace(0.0, 0.1, 6):
        X, Y = np.meshgrid(x - shift, x - 0.6 * shift, indexing="ij")
        p = np.clip(k * (a - np.hypot(X, Y)), 0, None)
        area = get_imprint_model("activation").area_mm2(x, x, p, ft)
        assert math.sqrt(area / math.pi) == pytest.approx(r_act, abs=0.001)


@pytest.mark.parametrize("film", ["MS", "HS", "HHS"])
def test_capsule_area_of_a_linear_edge_field_at_every_phase_of_the_grid(film):
    """The capsule model's expected area of a film-like cone p = k (a - r) is 2 pi int P(k (a - r)) r dr
    (scipy quadrature) within 0.0005 mm in radius at every phase of the grid against the cone. The cone is
    steep (MS's range within 1.3 cells of the edge): summed over the cells, MS's reading missed by 0.0010 mm."""
    ft = get_film(film)
    a, k = 5.0, 300.0
    lo = ft.range_mpa[0]
    exact = 2 * math.pi * quad(lambda r: _lognormal_cdf(k * (a - r), *ft.range_mpa) * r, 0, a, limit=400,
                               points=[a - lo / k])[0]
    x = np.arange(-7, 7, 0.1) + 0.05
    radii = []
    for shift in np.linspace(0.0, 0.1, 7):
        X, Y = np.meshgrid(x - shift, x - 0.37 * shift, indexing="ij")
        p = np.clip(k * (a - np.hypot(X, Y)), 0, None)
        radii.append(math.sqrt(get_imprint_model("capsule").area_mm2(x, x, p, ft) / math.pi))
    assert np.abs(np.array(radii) - math.sqrt(exact / math.pi)).max() < 5e-4


def test_the_layered_integral_of_a_function_that_falls_and_rises():
    """`GridField.integral_mm2` of a function that is not monotone in the pressure (it counts the layers where
    it falls negatively): a cone p = k (a - r), fn = (1 - p / 250)^2 + 0.2, against 2 pi int fn(k (a - r)) r dr by
    scipy quadrature, within 0.0005 mm all round the outline."""
    a, k = 5.0, 120.0

    def fn(p):
        return (1.0 - np.asarray(p) / 250.0) ** 2 + 0.2

    exact = 2 * math.pi * quad(lambda r: float(fn(k * (a - r))) * r, 0, a, limit=200)[0]
    x = np.arange(-7, 7, 0.1) + 0.05
    for shift in (0.0, 0.037, 0.061):
        X, Y = np.meshgrid(x - shift, x + 0.5 * shift, indexing="ij")
        p = np.clip(k * (a - np.hypot(X, Y)), 0, None)
        assert GridField(x, x, p, 1).integral_mm2(fn) == pytest.approx(exact, abs=0.0005 * 2 * math.pi * a)


def test_two_patches_and_no_contact():
    x = np.arange(0, 20, 0.1) + 0.05
    y = np.arange(0, 8, 0.1) + 0.05
    X, Y = np.meshgrid(x, y, indexing="ij")
    p = np.zeros_like(X)
    for cx in (5.0, 14.0):
        p += 300 * np.sqrt(np.clip(1 - ((X - cx) ** 2 + (Y - 4) ** 2) / 9, 0, None))
    edge = get_imprint_model("edge").area_mm2(x, y, p, HS, through_film=False)
    assert edge == pytest.approx(2 * math.pi * 9, rel=2e-3)
    assert get_imprint_model("activation").area_mm2(x, y, np.zeros_like(p), HS) == 0.0
    with pytest.raises(ValueError, match="shape"):
        GridField(x, y, p.T)


def test_polygon_areas():
    square = np.array([[0, 0], [2, 0], [2, 2], [0, 2], [0, 0]], float)
    hole = np.array([[0.5, 0.5], [0.5, 1.5], [1.5, 1.5], [1.5, 0.5]], float)
    assert ring_signed_area_mm2(square) == pytest.approx(4.0)
    assert ring_signed_area_mm2(hole) == pytest.approx(-1.0)
    assert outline_area_mm2([square, hole]) == pytest.approx(3.0)


# ---------------------------------------------- axisymmetric profiles (radii)

def _nodal(r, shape):
    """Nodal pressures of linear elements: int shape phi_i 2 pi r dr / int phi_i 2 pi r dr
    (adaptive quadrature, independent of the reading's Gauss rule)."""
    out = np.zeros(r.size)
    for i in range(r.size):
        lo = r[max(i - 1, 0)]
        hi = r[min(i + 1, r.size - 1)]

        def phi(x):
            if x <= r[i]:
                return 1.0 if i == 0 else (x - lo) / (r[i] - lo)
            return (hi - x) / (hi - r[i])

        num = quad(lambda x: shape(x) * phi(x) * x, lo, hi, limit=200)[0]
        den = quad(lambda x: phi(x) * x, lo, hi, limit=200)[0]
        out[i] = num / den
    return out


@pytest.mark.parametrize("a", [6.0311, 4.1817, 7.08])
def test_radial_hertz_profile(a):
    """Nodal pressures of p0 sqrt(1 - r^2/a^2) at h = 0.1 mm: edge and activation
    contours within 1e-3 mm of the closed forms."""
    p0 = 984.5
    r = np.round(np.arange(0, 9.0, 0.1), 10)
    p = _nodal(r, lambda x: p0 * math.sqrt(max(1 - x * x / a / a, 0.0)))
    prof = read_radial_profile(r, p)
    assert prof.edge_mm == pytest.approx(a, abs=1e-3)
    for film in ("MS", "HS", "HHS"):
        level = get_film(film).activation_pressure_mpa
        exact = a * math.sqrt(1 - (level / p0) ** 2)
        assert get_imprint_model("activation").radius_mm(r, p, get_film(film)) == pytest.approx(exact, abs=1e-3)


def test_radial_capsule_is_the_expected_area():
    """Capsule radius of a Hertz profile: sqrt(A / pi), A = 2 pi int P(p(r)) r dr."""
    a, p0 = 6.0, 700.0
    r = np.round(np.arange(0, 9.0, 0.1), 10)
    p = _nodal(r, lambda x: p0 * math.sqrt(max(1 - x * x / a / a, 0.0)))
    area = 2 * math.pi * quad(lambda x: _lognormal_cdf(p0 * math.sqrt(1 - x * x / a / a), 50, 130) * x,
                              0, a, limit=200)[0]
    got = get_imprint_model("capsule").radius_mm(r, p, HS)
    assert got == pytest.approx(math.sqrt(area / math.pi), abs=2e-3)
    keys = read_imprints(r, p, [("activation", HS), ("capsule", HS), ("edge", HS)])
    assert keys["radius_capsule_HS_mm"] == pytest.approx(got, abs=1e-12)
    assert keys["contact_radius_mm"] == pytest.approx(a, abs=1e-3)


@pytest.mark.parametrize("tip_mm", [0.09, 0.14])
def test_radial_two_scale_profile_is_recovered(tip_mm):
    """A film-like profile c sqrt(q (1 + q / (2 a l))): the fit returns a to 1e-4 mm."""
    a, c = 7.163, 20.0
    r = np.round(np.arange(0, 9.0, 0.1), 10)

    def shape(x):
        q = max(a * a - x * x, 0.0)
        return c * math.sqrt(q * (1 + q / (2 * a * tip_mm)))

    prof = read_radial_profile(r, _nodal(r, shape), tip_mm)
    assert prof.fitted and prof.edge_mm == pytest.approx(a, abs=1e-4)


def test_radial_reading_input_checks():
    r = np.linspace(0, 1, 11)
    with pytest.raises(ValueError, match="ascending"):
        read_radial_profile(r[::-1], r)
    with pytest.raises(ValueError, match="tip_mm"):
        read_radial_profile(r, r, tip_mm=0.0)
    with pytest.raises(ValueError, match="samples"):
        read_radial_profile(r, r, samples="cells")
    assert read_radial_profile(r, np.zeros_like(r)).edge_mm == 0.0


def test_tip_length():
    """No film: a Hertzian edge (infinite tip); a film: a fraction of its
    thickness that shrinks towards incompressibility and grows with M / E*."""
    from filmcal.contact import film_tip_length_mm
    from filmcal.contact.reading import TIP_SCALE, TIP_STIFFNESS_FACTOR
    from filmcal.hertz import contact_modulus_mpa

    assert math.isinf(film_tip_length_mm(None))
    assert film_tip_length_mm(0.09, poisson=0.0) == pytest.approx(TIP_SCALE * 0.09)
    assert film_tip_length_mm(0.09, poisson=0.25) == pytest.approx(0.5 * TIP_SCALE * 0.09)
    e_star = float(contact_modulus_mpa())
    assert film_tip_length_mm(0.09, e_star / TIP_STIFFNESS_FACTOR, 0.0) == pytest.approx(2 * TIP_SCALE * 0.09)
    assert film_tip_length_mm(0.09, 1000.0) < film_tip_length_mm(0.09, 5000.0) < film_tip_length_mm(0.18, 5000.0)
    assert film_tip_length_mm(0.09, 3000.0, 0.45) < film_tip_length_mm(0.09, 3000.0, 0.3)
    with pytest.raises(ValueError, match="thickness_mm"):
        film_tip_length_mm(-0.1)
    with pytest.raises(ValueError, match="oedometric_modulus_mpa"):
        film_tip_length_mm(0.09, 0.0)
    with pytest.raises(ValueError, match="poisson"):
        film_tip_length_mm(0.09, 1000.0, 0.5)


def test_level_reading_is_continuous_across_the_fit_window():
    """Levels from the bulk (interpolated p^2) and from the fitted tail meet without a jump."""
    a, p0 = 6.0, 900.0
    r = np.round(np.arange(0, 9.0, 0.1), 10)
    p = _nodal(r, lambda x: p0 * math.sqrt(max(1 - x * x / a / a, 0.0)))
    prof = read_radial_profile(r, p)
    levels = np.linspace(5.0, 600.0, 120)
    radii = np.array([prof.level_radius_mm(v) for v in levels])
    exact = a * np.sqrt(1 - (levels / p0) ** 2)
    assert np.all(np.diff(radii) < 0)
    assert np.max(np.abs(radii - exact)) < 2e-3
    with pytest.raises(ValueError, match="level_mpa"):
        prof.level_radius_mm(-1.0)
    assert prof.level_radius_mm(2 * p0) == 0.0


def test_single_cell_wide_contact_is_read():
    """A loaded strip one cell wide (no inner neighbour to extrapolate from) still has an area."""
    x = np.arange(0, 3, 0.1) + 0.05
    y = np.arange(0, 3, 0.1) + 0.05
    p = np.zeros((x.size, y.size))
    p[10:20, 15] = 100.0
    area = get_imprint_model("edge").area_mm2(x, y, p, HS)
    assert 0.5 * 1.0 * 0.1 < area < 1.5 * 1.0 * 0.1
