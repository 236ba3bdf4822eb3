"""`filmcal wheelrail`: JSON contract, options and bad input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from filmcal.cli import main
from filmcal.contact.rough_imprint import _shipped
from filmcal.commands._options import rail_inclination as parse_inclination
from filmcal.wheelrail.profiles import get_profile


def _run(capsys, *argv):
    code = main(["wheelrail", *argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_json_has_the_contract_keys(capsys):
    code, out, err = _run(capsys, "--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa",
                          "2800", "--film-poisson", "0.33", "--json")
    assert code == 0, err
    data = json.loads(out)
    for key in ("contact_area_mm2", "max_pressure_mpa", "elapsed_s",
                "centroid_y_mm", "centroid_rail_y_mm", "centroid_wheel_y_mm", "n_patches",
                "approach_mm", "hertz_area_mm2", "hertz_like", "converged"):
        assert key in data, key
    assert data["converged"] is True
    assert data["n_patches"] == 1
    assert data["film"]["modulus_mpa"] == 2800.0
    assert data["contact_area_mm2"] > data["hertz_area_mm2"]  # the film enlarges the patch


def test_options_rail_inclination_radius_roughness_plot(capsys, tmp_path):
    png = tmp_path / "map.png"
    code, out, err = _run(capsys, "--offset-mm=-3", "--force-kn", "50", "--no-film", "--rail", "60E1",
                          "--rail-inclination", "1/30", "--nominal-radius-mm", "430",
                          "--wheel-roughness-ra-um", "1.5", "--rail-roughness-ra-um", "0.8", "--grid-mm", "0.2",
                          "--film", "HS",
                          "--plot", str(png), "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["rail"] == "60E1"
    assert data["rail_inclination"] == pytest.approx(1 / 30)
    assert data["nominal_radius_mm"] == 430.0
    assert data["wheel_roughness_ra_um"] == 1.5 and data["rail_roughness_ra_um"] == 0.8
    assert data["roughness"]["rail_ra_um"] == pytest.approx(0.8, rel=0.05)
    # rough bodies without film: the nominal area lies between the smooth area and the loaded support
    assert data["nominal_area_mm2"] < data["contact_area_mm2"]
    assert data["grid_mm"] == 0.2
    assert 0.0 < data["imprint_area_mm2"] < data["contact_area_mm2"]
    assert png.stat().st_size > 10_000


def test_wheel_from_csv_equals_the_standard_wheel(capsys, tmp_path):
    """A CSV of the S1002 points (smoothing spline) gives nearly the standard result."""
    y, z = get_profile("S1002").points(0.25)
    keep = y > -38.0  # the tread side: a single-valued spline
    path = tmp_path / "wheel.csv"
    np.savetxt(path, np.column_stack([y[keep], z[keep]]), delimiter=",", header="y_mm,z_mm",
               comments="")
    code, out, err = _run(capsys, "--offset-mm=-5", "--force-kn", "50", "--no-film", "--wheel",
                          str(path), "--json")
    assert code == 0, err
    code2, out2, _ = _run(capsys, "--offset-mm=-5", "--force-kn", "50", "--no-film", "--json")
    assert json.loads(out)["contact_area_mm2"] == pytest.approx(
        json.loads(out2)["contact_area_mm2"], rel=0.02)


def test_text_output(capsys):
    code, out, err = _run(capsys, "--offset-mm=-6", "--force-kn", "50", "--no-film")
    assert code == 0, err
    assert "contact area" in out and "local Hertz" in out


@pytest.mark.parametrize("argv", [
    ["--offset-mm=-3", "--force-kn", "-5", "--no-film"],
    ["--offset-mm=-3", "--force-kn", "0", "--no-film"],
    ["--offset-mm=-3", "--force-kn", "abc", "--no-film"],
    ["--offset-mm=60", "--force-kn", "100", "--no-film"],
    ["--offset-mm=-3", "--force-kn", "100", "--rail", "UIC99"],
    ["--offset-mm=-3", "--force-kn", "100", "--wheel", "60E2", "--no-film"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--film-poisson", "0.6"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "-1"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--rail-inclination", "1/0"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--rail-inclination", "steep"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--wheel-roughness-ra-um", "-2"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--grid-mm", "5"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--wheel", "/no/such/wheel.csv"],
    ["--offset-mm=-3", "--force-kn", "100"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--film-modulus-mpa", "2800"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--kinematics", "large"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--film", "XS"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--films-file",
     "/no/such/films.toml", "--film", "HS"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--imprint-model", "halo",
     "--film", "HS"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--wheel-roughness-ra-um",
     "1.5", "--roughness-law", "/no/such/law.csv"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--wheel-roughness-map",
     "/no/such/map.csv", "--roughness-pixel-um", "1"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--wheel-roughness-ra-um",
     "1.5", "--hardness-mpa", "-5"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--wheel-roughness-ra-um",
     "1.5", "--hardness-mpa=1e300"],
    # options that would change nothing are refused, not ignored
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--hardness-mpa", "300"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--roughness-seed", "3"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--wheel-roughness-ra-um", "1.5", "--hardness-mpa", "300"],
    ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--imprint-model", "capsule"],
])
def test_bad_input_exits_2_with_one_line(capsys, argv):
    with pytest.raises(SystemExit) as info:
        raise SystemExit(main(["wheelrail", *argv, "--json"]))
    out, err = capsys.readouterr()
    assert info.value.code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_a_hardness_given_is_used_and_said_to_be_given(capsys):
    """--hardness-mpa caps the asperity pressures of the law the solve uses, and the record names it as given,
    not as the representative draw's."""
    argv = ("--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "2800", "--wheel-roughness-ra-um", "1.5",
            "--json")
    code, out, err = _run(capsys, *argv)
    default = json.loads(out)["roughness"]
    assert code == 0 and "conditioned" in default["hardness_source"]
    code, out, err = _run(capsys, *argv, "--hardness-mpa", str(0.5 * default["hardness_mpa"]))
    given = json.loads(out)["roughness"]
    assert code == 0 and given["hardness_source"] == "given (--hardness-mpa)"
    assert given["hardness_mpa"] == pytest.approx(0.5 * default["hardness_mpa"])
    # a softer coating closes sooner: its law saturates at the lower pressure
    assert given["saturation_pressure_mpa"] < default["saturation_pressure_mpa"]


def test_malformed_csv_exits_2(capsys, tmp_path):
    path = tmp_path / "rail.csv"
    path.write_text("y_mm,z_mm\n0,0\n1,oops\n")
    code, out, err = _run(capsys, "--offset-mm=-3", "--force-kn", "100", "--no-film", "--rail",
                          str(path), "--json")
    assert code == 2
    assert "not a number" in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("text, value", [("1/40", 0.025), ("0.025", 0.025), ("0", 0.0),
                                         (" 1/20 ", 0.05)])
def test_parse_inclination(text, value):
    assert parse_inclination(text) == pytest.approx(value)


def test_the_inclination_is_printed_once(capsys):
    """`--inclination 1/40` printed the value twice."""
    code, out, err = _run(capsys, "--offset-mm=-3", "--force-kn", "100", "--no-film", "--rail-inclination", "1/40")
    assert code == 0, err
    assert out.count("0.025") == 1 and "inclination" in out


def _json(capsys, *argv) -> dict:
    code, out, err = _run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


#: Each film's calibrated median (MPa), as the shipped roughness conditioning recorded it
#: (filmcal/data/roughness_inputs.json), so that the test follows a recalibration.
CALIBRATED_MPA = {f["film"]: f"{f['modulus_mpa']:g}" for f in _shipped()["films"]}


def test_rough_wheel_grows_the_imprint_in_the_papers_order(capsys):
    """Ra 1.5 um on the wheel, eta = -3 mm, 50 and 100 kN, each film at its calibrated
    modulus: the reported imprint area of MS and HS grows by at least 2 %, that of HHS by
    less than that of HS (the order of the paper's experiments)."""
    growth = {}
    for film, modulus in CALIBRATED_MPA.items():
        for force in ("50", "100"):
            args = ["--offset-mm=-3", "--force-kn", force, "--film-modulus-mpa", modulus,
                    "--film", film]
            smooth = _json(capsys, *args)
            rough = _json(capsys, *args, "--wheel-roughness-ra-um", "1.5")
            assert rough["roughness"]["model"] == "FFT boundary elements"
            assert rough["imprint_model"] == "activation"
            growth[film, force] = rough["imprint_area_mm2"] / smooth["imprint_area_mm2"] - 1.0
            # the coloured spots lie within the rough contact
            assert 0.0 < rough["stained_area_mm2"] < rough["contact_area_mm2"]
    for force in ("50", "100"):
        assert growth["MS", force] >= 0.02
        assert growth["HS", force] >= 0.02
        assert growth["HHS", force] < growth["HS", force]


def test_large_strain_film_stiffens_the_soft_film(capsys):
    args = ["--offset-mm=-3", "--force-kn", "100", "--film-modulus-mpa", "768", "--film", "MS"]
    small = _json(capsys, *args)
    large = _json(capsys, *args, "--kinematics", "large")
    assert small["film"]["kinematics"] == "small" and large["film"]["kinematics"] == "large"
    assert large["converged"]
    # the neo-Hookean film stiffens in compression: a smaller, more loaded patch
    assert large["contact_area_mm2"] < 0.97 * small["contact_area_mm2"]
    assert large["max_pressure_mpa"] > small["max_pressure_mpa"]
    assert large["imprint_area_mm2"] < small["imprint_area_mm2"]
    # linear: p/M at the peak; large strain: less at a higher peak pressure
    assert small["film"]["max_strain"] == pytest.approx(
        small["max_pressure_mpa"] / small["film"]["oedometric_modulus_mpa"])
    assert 0.0 < large["film"]["max_strain"] < small["film"]["max_strain"]


def test_user_film_and_imprint_models(capsys, tmp_path):
    films = tmp_path / "films.toml"
    films.write_text("[LOT7]\nrange_mpa = [30, 110]\nthickness_mm = 0.1\n")
    base = ["--offset-mm=-3", "--force-kn", "50", "--film-modulus-mpa", "2739"]
    hs = _json(capsys, *base, "--film", "HS")
    lot = _json(capsys, *base, "--film", "LOT7", "--films-file", str(films))
    assert lot["film"]["thickness_mm"] == 0.1 and lot["activation_pressure_mpa"] == 30.0
    edge = _json(capsys, *base, "--film", "HS", "--imprint-model", "edge")
    capsule = _json(capsys, *base, "--film", "HS", "--imprint-model", "capsule")
    # a lower activation pressure colours more; the edge colours the most
    assert hs["imprint_area_mm2"] < edge["imprint_area_mm2"]
    assert capsule["imprint_model"] == "capsule"
    assert 0.5 * hs["imprint_area_mm2"] < capsule["imprint_area_mm2"] < edge["imprint_area_mm2"]
    thin = _json(capsys, *base, "--film", "LOT7", "--films-file", str(films),
                 "--film-thickness-mm", "0.09")
    assert lot["imprint_area_mm2"] > thin["imprint_area_mm2"] * 0.99  # thicker film, larger patch


def test_measured_height_map_and_law(capsys, tmp_path):
    """A measured height map (CSV) and a measured law (CSV) both act on the imprint."""
    x = np.arange(64) * 1.0
    heights = 2.0 * np.cos(2 * np.pi * x / 32.0)[:, None] * np.cos(2 * np.pi * x / 16.0)[None, :]
    path = tmp_path / "wheel_heights.csv"
    np.savetxt(path, heights, delimiter=",")
    base = ["--offset-mm=-3", "--force-kn", "50", "--film-modulus-mpa", "2739", "--film", "HS"]
    smooth = _json(capsys, *base)
    mapped = _json(capsys, *base, "--wheel-roughness-map", str(path), "--roughness-pixel-um", "1")
    assert mapped["roughness"]["pixel_um"] == 1.0
    assert mapped["imprint_area_mm2"] > smooth["imprint_area_mm2"]
    law = tmp_path / "law.csv"
    law.write_text("closure_um,pressure_mpa\n0,0\n1,5\n2,40\n3,300\n")
    measured = _json(capsys, *base, "--roughness-law", str(law))
    assert measured["imprint_area_mm2"] > smooth["imprint_area_mm2"]
    code, out, err = _run(capsys, *base, "--wheel-roughness-map", str(path), "--json")
    assert code == 2 and "roughness-pixel-um" in err


def test_a_named_film_reports_its_transfer_term(capsys):
    """With a film type, the imprint the calibrated (continuum FE) film would record is printed beside the
    springs' own reading: the term moves it inwards and carries a standard deviation."""
    data = _json(capsys, "--offset-mm=-3", "--force-kn", "100", "--film", "HS", "--film-modulus-mpa", "2800",
                 "--imprint-model", "edge")
    assert data["transfer_shift_mm2"] < 0.0 < data["transfer_std_mm2"] < -data["transfer_shift_mm2"]
    assert data["calibrated_imprint_area_mm2"] == pytest.approx(data["imprint_area_mm2"] + data["transfer_shift_mm2"])
    code, out, err = _run(capsys, "--offset-mm=-3", "--force-kn", "100", "--film", "HS", "--film-modulus-mpa", "2800")
    assert code == 0, err
    assert "as calibrated" in out and "transfer term" in out


def test_the_wheelrail_command_warns_beyond_the_elastic_limit_as_fem_and_correct_do():
    """At 2000 kN S1002/60E2 peaks at about 3000 MPa without film and `filmcal wheelrail` said nothing, where
    `fem`, `correct` and `curves` warn above 1250 MPa; at 100 kN, eta -3 mm (about 1100 MPa) it still says
    nothing."""
    import subprocess
    import sys

    base = [sys.executable, "-m", "filmcal.cli", "wheelrail", "--offset-mm=-3", "--no-film", "--json", "--force-kn"]
    hot = subprocess.run(base + ["2000"], capture_output=True, text=True, timeout=300)
    cool = subprocess.run(base + ["100"], capture_output=True, text=True, timeout=300)
    assert hot.returncode == 0 and cool.returncode == 0, hot.stderr + cool.stderr
    hot_out, cool_out = json.loads(hot.stdout), json.loads(cool.stdout)
    assert hot_out["max_pressure_mpa"] > 2500 and "elastic limit" in hot_out["warnings"][0]
    assert "ElasticLimitWarning" in hot.stderr
    assert cool_out["max_pressure_mpa"] < 1250 and "warnings" not in cool_out and "Warning" not in cool.stderr
