"""Table 1 of the reference paper as package data, its filters, and the Hertz helpers."""
from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from filmcal.calibration.data import FILM_TYPES, parse_load_range
from filmcal.calibration.datasets import load_table1
from filmcal.hertz import contact_modulus_mpa, hertz_max_pressure_mpa, hertz_radius_mm


def test_table_has_ten_cases_per_film():
    data = load_table1()
    assert len(data) == 30
    assert FILM_TYPES == ("MS", "HS", "HHS")
    for film in FILM_TYPES:
        assert np.sum(data.film == film) == 10
    # 3 radii at 25 and 50 kN, R450 and R600 only at 75 and 100 kN (paper, section 1)
    assert sorted(set(data.sphere_radius_mm[data.force_kn == 25])) == [300, 450, 600]
    assert sorted(set(data.sphere_radius_mm[data.force_kn == 100])) == [450, 600]


def test_published_values_and_their_trend():
    data = load_table1()

    def cell(film, radius, force_kn):
        row = (data.film == film) & (data.sphere_radius_mm == radius) & (data.force_kn == force_kn)
        assert row.sum() == 1
        return float(data.radius_error_mm[row][0])

    # Table 1 of the paper
    assert cell("MS", 300, 25) == 2.01
    assert cell("HS", 450, 75) == 1.09
    assert cell("HHS", 600, 100) == 0.64
    # "all three types overestimated the radius", and the softer the film the larger the error
    assert np.all(data.radius_error_mm > 0)
    means = [data.radius_error_mm[data.film == f].mean() for f in FILM_TYPES]
    assert means[0] > means[1] > means[2]


def test_measured_radius_is_hertz_plus_error():
    data = load_table1()
    np.testing.assert_allclose(data.measured_radius_mm, data.hertz_radius_mm + data.radius_error_mm, rtol=1e-15)
    np.testing.assert_allclose(data.force_n, 1000.0 * data.force_kn)
    # Hertz radius depends on F*R only: R300/50 kN and R600/25 kN share it
    a1 = data.hertz_radius_mm[(data.sphere_radius_mm == 300) & (data.force_kn == 50)]
    a2 = data.hertz_radius_mm[(data.sphere_radius_mm == 600) & (data.force_kn == 25)]
    np.testing.assert_allclose(a1, a2, rtol=1e-14)


def test_hertz_facts_of_the_design():
    # DESIGN.md: R450, 75 kN, steel on steel -> a = 6.031 mm, p0 = 984.5 MPa
    assert hertz_radius_mm(450.0, 75e3) == pytest.approx(6.031, abs=5e-4)
    assert hertz_max_pressure_mpa(450.0, 75e3) == pytest.approx(984.5, abs=0.05)
    data = load_table1("HS", "75")
    assert data.hertz_radius_mm[data.sphere_radius_mm == 450] == pytest.approx(6.031, abs=5e-4)


def test_hertz_for_general_pairs():
    steel = contact_modulus_mpa()
    assert steel == pytest.approx(210000.0 / (2 * (1 - 0.09)))
    # a rigid flat doubles E* of two equal bodies, so a shrinks by 2^(-1/3)
    assert contact_modulus_mpa(modulus2_mpa=np.inf) == pytest.approx(2 * steel)
    ratio = hertz_radius_mm(450.0, 75e3, modulus2_mpa=np.inf) / hertz_radius_mm(450.0, 75e3)
    assert ratio == pytest.approx(2 ** (-1 / 3))
    # explicitly equal bodies match the default
    assert hertz_radius_mm(450.0, 75e3, 210000.0, 0.3, 210000.0, 0.3) == pytest.approx(hertz_radius_mm(450.0, 75e3))
    # the force balance: the Hertz pressure 2/3 p0 averaged over pi a^2 carries F
    a, p0 = hertz_radius_mm(300.0, 25e3, 2e5, 0.25, 7e4, 0.33), hertz_max_pressure_mpa(300.0, 25e3, 2e5, 0.25, 7e4, 0.33)
    assert 2.0 / 3.0 * p0 * np.pi * a**2 == pytest.approx(25e3)


def test_hertz_broadcasts_over_arrays():
    a = hertz_radius_mm(np.array([300.0, 450.0]), np.array([[25e3], [100e3]]))
    assert a.shape == (2, 2)
    np.testing.assert_allclose(a[1] / a[0], 4.0 ** (1 / 3))


@pytest.mark.parametrize("kwargs, name", [
    ({"sphere_radius_mm": -1.0, "force_n": 1e3}, "sphere_radius_mm"),
    ({"sphere_radius_mm": 300.0, "force_n": np.nan}, "force_n"),
    ({"sphere_radius_mm": 300.0, "force_n": 1e3, "poisson": 0.5}, "poisson"),
    ({"sphere_radius_mm": 300.0, "force_n": 1e3, "modulus_mpa": 0.0}, "modulus_mpa"),
    ({"sphere_radius_mm": 300.0, "force_n": 1e3, "modulus2_mpa": -2.0}, "modulus2_mpa"),
])
def test_hertz_rejects_bad_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        hertz_radius_mm(**kwargs)


@pytest.mark.parametrize("film", ["HS", "hs", " Hs "])
def test_film_filter_is_case_insensitive(film):
    data = load_table1(film)
    assert len(data) == 10 and set(data.film) == {"HS"}


def test_unknown_film_lists_the_known_ones():
    with pytest.raises(ValueError, match="MS, HS, HHS"):
        load_table1("LW")


@pytest.mark.parametrize("loads, n_rows, forces", [
    ("50-100", 7, {50, 75, 100}),
    ("25", 3, {25}),
    ("25-50", 6, {25, 50}),
    (" 60 - 100 ", 4, {75, 100}),
    ((75, 100), 4, {75, 100}),
    ("30-40", 0, set()),
])
def test_load_filter_is_inclusive_in_kn(loads, n_rows, forces):
    data = load_table1("HHS", loads)
    assert len(data) == n_rows
    assert set(data.force_kn.tolist()) == forces


@pytest.mark.parametrize("loads", ["abc", "50-", "-50", "100-50", "50..100", "", "50-100-150", (100, 50), ("a", 1)])
def test_bad_load_ranges_are_rejected(loads):
    with pytest.raises(ValueError, match="loads"):
        load_table1(loads=loads)


def test_parse_load_range():
    assert parse_load_range("50-100") == (50.0, 100.0)
    assert parse_load_range("75") == (75.0, 75.0)
    assert parse_load_range("12.5-25") == (12.5, 25.0)


def test_csv_ships_with_the_package_and_names_its_source():
    text = resources.files("filmcal").joinpath("data/table1_radius_errors.csv").read_text(encoding="utf-8")
    header = [line for line in text.splitlines() if line.startswith("#")]
    assert any("Calibration of a finite element model of Prescale film" in line for line in header)
    assert any("Table 1" in line for line in header)
    assert len([line for line in text.splitlines() if line and not line.startswith("#")]) == 31


def test_select_checks_the_mask():
    data = load_table1()
    with pytest.raises(ValueError, match="mask"):
        data.select(np.ones(3, dtype=bool))
