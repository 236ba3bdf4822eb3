"""Datasets: the CSV format of a lab's own imprints, its validation, and Table 1 as a packaged dataset."""
from __future__ import annotations

import hashlib
import math
from importlib import resources

import numpy as np
import pytest

from filmcal.calibration.datasets import load_table1
from filmcal.calibration.datasets import PACKAGED_DATASETS, load_dataset
from filmcal.films import FilmType

STEEL_E_STAR = 210000.0 / (2.0 * (1.0 - 0.3**2))


def hertz_by_hand(R_mm, F_n, e_star_mpa=STEEL_E_STAR):
    """Johnson, Contact Mechanics, eq. 4.22: a = (3 F R / (4 E*))^(1/3)."""
    return (3.0 * F_n * R_mm / (4.0 * e_star_mpa)) ** (1.0 / 3.0)


def write(tmp_path, text, name="lab.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_table1_is_the_packaged_dataset_with_its_hash():
    ds = load_dataset("table1")
    raw = resources.files("filmcal").joinpath(PACKAGED_DATASETS["table1"]).read_bytes()
    assert ds.sha256 == hashlib.sha256(raw).hexdigest()
    assert ds.source == "package:filmcal/data/table1_radius_errors.csv"
    assert ds.films == ("MS", "HS", "HHS") and len(ds) == 30 and ds.data.n_cases == 30
    assert ds.measured_column == "radius_error_mm"
    hs = ds.select("HS")
    np.testing.assert_array_equal(hs.measured_radius_mm, load_table1("HS").measured_radius_mm)
    # R450, 75 kN: a = 6.031 mm (DESIGN.md), error 1.09 mm (Table 1)
    row = (hs.sphere_radius_mm == 450) & (hs.force_n == 75e3)
    assert hs.hertz_radius_mm[row][0] == pytest.approx(6.031, abs=5e-4)
    assert hs.measured_radius_mm[row][0] == pytest.approx(6.031 + 1.09, abs=5e-4)
    assert ds.to_dict()["n_rows"] == 30


def test_the_three_measured_forms_give_the_same_radius(tmp_path):
    a = hertz_by_hand(350.0, 40e3)
    r = a + 0.8
    forms = {"measured_radius_mm": r, "measured_area_mm2": math.pi * r**2, "radius_error_mm": 0.8}
    for column, value in forms.items():
        ds = load_dataset(write(tmp_path, f"film,sphere_radius_mm,force_kn,{column}\nLOT7,350,40,{value!r}\n"
                                          f"LOT7,350,40,{value!r}\n", f"{column}.csv"))
        assert ds.data.measured_radius_mm[0] == pytest.approx(r, rel=1e-12)
        assert ds.data.radius_error_mm[0] == pytest.approx(0.8, rel=1e-9)
        assert ds.data.hertz_radius_mm[0] == pytest.approx(a, rel=1e-12)
        np.testing.assert_array_equal(ds.data.repeat, [1, 2])
        assert ds.data.n_cases == 1 and ds.films == ("LOT7",)


def test_optional_columns_repeats_uncertainty_roughness_and_materials(tmp_path):
    text = ("# a lab's own tests\n"
            "film,sphere_radius_mm,force_kn,measured_radius_mm,repeat,measurement_std_mm,flat_ra_um,"
            "flat_modulus_mpa,flat_poisson\n"
            "LOT7,500,60,7.5,2,0.02,0.4,,\n"
            "LOT7,500,60,7.6,1,0.03,0.4,,\n"
            "LOT7,500,60,7.4,,,0.4,,\n"
            "LOT7,500,60,7.9,1,,,70000,0.33\n"
            "OTHER,500,60,7.0,,,,,\n")
    ds = load_dataset(write(tmp_path, text))
    d = ds.data
    np.testing.assert_array_equal(d.case_index, [0, 0, 0, 1, 2])
    np.testing.assert_array_equal(d.repeat, [2, 1, 3, 1, 1])
    np.testing.assert_allclose(d.measurement_std_mm, [0.02, 0.03, 0.0, 0.0, 0.0])
    assert math.isnan(d.flat_ra_um[3]) and d.flat_ra_um[0] == 0.4
    # an aluminium flat: 1/E* = (1 - 0.3^2)/210000 + (1 - 0.33^2)/70000
    e_star = 1.0 / ((1 - 0.09) / 210000.0 + (1 - 0.33**2) / 70000.0)
    assert d.hertz_radius_mm[3] == pytest.approx(hertz_by_hand(500.0, 60e3, e_star), rel=1e-12)
    assert d.radius_error_mm[3] == pytest.approx(7.9 - hertz_by_hand(500.0, 60e3, e_star), rel=1e-12)
    # compared with a radius model of steel bodies through the film error measured on these bodies
    assert d.target_radius_mm[3] == pytest.approx(hertz_by_hand(500.0, 60e3) + d.radius_error_mm[3], rel=1e-12)
    assert d.target_radius_mm[0] == pytest.approx(7.5, rel=1e-12)
    assert ds.films == ("LOT7", "OTHER")
    assert len(ds.select(FilmType("LOT7", activation_pressure_mpa=45.0))) == 4
    assert len(ds.select("LOT7", loads="50-70")) == 4 and len(ds.select("LOT7", loads="70-90")) == 0
    with pytest.raises(ValueError, match="'HS' is not in dataset lab .* holds LOT7, OTHER"):
        ds.select("HS")


@pytest.mark.parametrize("text, where, what", [
    ("film,sphere_radius_mm,force_kn\nHS,450,75\n", "line 1", "exactly one of"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,radius_error_mm\nHS,450,75,7,1\n", "line 1",
     "exactly one of"),
    ("film,sphere_radius_mm,measured_radius_mm\nHS,450,7\n", "line 1", "missing required column.*force_kn"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,colour\nHS,450,75,7,red\n", "line 1",
     "unknown column.*'colour'"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,film_thickness_mm\nHS,450,75,7,0.1\n", "line 1",
     "unknown column.*'film_thickness_mm'.*thickness_mm in a --films-file"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,force_kn\nHS,450,75,7,75\n", "line 1",
     "more than once"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,450,75,7\nHS,450,-75,7\n", "line 3, column force_kn",
     "in 0.001-2000 kN"),
    ("film,sphere_radius_mm,force_kn,radius_error_mm\nHS,450,75,1.1\nHS,1e308,75,1.1\n",
     "line 3, column sphere_radius_mm", "in 1-100000 mm"),
    ("film,sphere_radius_mm,force_kn,radius_error_mm\nHS,450,1e308,1.1\n", "line 2, column force_kn",
     "in 0.001-2000 kN"),
    ("film,sphere_radius_mm,force_kn,radius_error_mm,repeat\nHS,450,75,1.1,99999999999999999999\n",
     "line 2, column repeat", "integer in 1-1000000"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\n# note\nHS,abc,75,7\n", "line 3, column sphere_radius_mm",
     "not a number"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,450,75,nan\n", "line 2, column measured_radius_mm",
     "finite"),
    # Python's float and int read 1_0 as 10 and a full-width digit as itself; no lab writes either as a number
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,4_50,75,7\n", "line 2, column sphere_radius_mm",
     "not a number"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,450,75,\uff17\n", "line 2, column measured_radius_mm",
     "not a number"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,repeat\nHS,450,75,7,1_0\n", "line 2, column repeat",
     "integer"),
    ("film,sphere_radius_mm,force_kn,measured_area_mm2\nHS,450,75,0\n", "line 2, column measured_area_mm2",
     "> 0"),
    ("film,sphere_radius_mm,force_kn,radius_error_mm\nHS,450,75,-7\n", "line 2, column radius_error_mm",
     "radius -0.9.* <= 0"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,450,75\n", "line 2", "2 fields|3 fields"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\n,450,75,7\n", "line 2, column film", "empty"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\nA/B,450,75,7\n", "line 2, column film", "slashes"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,repeat\nHS,450,75,7,1\nHS,450,75,7.1,1\n",
     "line 3, column repeat", "repeat 1 .* already appears on line 2"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,repeat\nHS,450,75,7,0\n", "line 2, column repeat",
     "integer in 1-1000000"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,measurement_std_mm\nHS,450,75,7,-0.1\n",
     "line 2, column measurement_std_mm", ">= 0 mm"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm,flat_poisson\nHS,450,75,7,0.5\n",
     "line 2, column flat_poisson", r"\(-1, 0.5\)"),
    ("film,sphere_radius_mm,force_kn,measured_radius_mm\n", None, "no rows"),
    ("# only a comment\n", None, "no header"),
])
def test_invalid_files_name_file_line_and_column(tmp_path, text, where, what):
    path = write(tmp_path, text)
    with pytest.raises(ValueError) as info:
        load_dataset(path)
    message = str(info.value)
    assert str(path) in message
    if where is not None:
        assert where in message
    assert __import__("re").search(what, message), message


def test_missing_file_binary_file_and_folder(tmp_path):
    with pytest.raises(ValueError, match="no such file.*packaged: table1"):
        load_dataset(tmp_path / "nope.csv")
    with pytest.raises(ValueError, match="is a folder"):
        load_dataset(tmp_path)
    path = tmp_path / "bin.csv"
    path.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match="not UTF-8"):
        load_dataset(path)


def test_hash_follows_the_bytes(tmp_path):
    text = "film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,450,75,7\n"
    one = load_dataset(write(tmp_path, text, "a.csv"))
    two = load_dataset(write(tmp_path, text.replace("7\n", "7.01\n"), "b.csv"))
    assert one.sha256 == hashlib.sha256(text.encode()).hexdigest()
    assert one.sha256 != two.sha256
    assert one.name == "a" and one.source.endswith("a.csv")


@pytest.mark.parametrize("fields, words", [
    ({"activation_pressure_mpa": 500.0, "range_mpa": (45.0, 120.0)}, "outside its range_mpa"),
    ({"activation_pressure_mpa": 1e9}, "activation_pressure_mpa must be in"),
    ({"range_mpa": (45.0, 5e4)}, "range_mpa must be"),
])
def test_a_film_type_outside_the_physics_is_refused(fields, words):
    """Accepted before: activation 500 MPa beside a 45-120 MPa range, and 1e9 MPa (an imprint of 0.0, exit 0)."""
    with pytest.raises(ValueError, match=words):
        FilmType("LOT7", **fields)
    # the packaged films themselves are within the rules (Prescale's own data sheet ranges)
    assert FilmType("OK", activation_pressure_mpa=45.0, range_mpa=(45.0, 120.0)).activation_pressure_mpa == 45.0


def test_a_dataset_radius_no_film_could_print_is_refused(tmp_path):
    """`HS,450,75,1000` (a radius error of 1000 mm) was accepted and gave sigma = 627 mm."""
    path = tmp_path / "lab.csv"
    path.write_text("film,sphere_radius_mm,force_kn,radius_error_mm\nHS,450,75,1.1\nHS,450,75,1000\n")
    with pytest.raises(ValueError, match="check the units"):
        load_dataset(path)
    path.write_text("film,sphere_radius_mm,force_kn,radius_error_mm\nHS,450,75,1.1\nHS,450,75,1.2\n")
    assert len(load_dataset(path)) == 2
