"""`filmcal wheelrail`: JSON contract, options and bad input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from filmcal.cli import main
from filmcal.commands.wheelrail import parse_inclination
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
    for key in ("contact_area_mm2", "max_pressure_mpa", "elapsed_s", "support_area_mm2",
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
                          "--inclination", "1/30", "--wheel-radius-mm", "430",
                          "--roughness-ra-um", "1.5", "--grid-mm", "0.2", "--film-type", "HS",
                          "--plot", str(png), "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["rail"] == "60E1"
    assert data["rail_inclination"] == pytest.approx(1 / 30)
    assert data["nominal_radius_mm"] == 430.0
    assert data["roughness_ra_um"] == 1.5
    assert data["grid_mm"] == 0.2
    assert 0.0 < data["imprint_area_mm2"] < data["support_area_mm2"]
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
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--inclination", "1/0"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--inclination", "steep"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--roughness-ra-um", "-2"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--grid-mm", "5"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--wheel", "/no/such/wheel.csv"],
    ["--offset-mm=-3", "--force-kn", "100"],
    ["--offset-mm=-3", "--force-kn", "100", "--no-film", "--film-modulus-mpa", "2800"],
])
def test_bad_input_exits_2_with_one_line(capsys, argv):
    with pytest.raises(SystemExit) as info:
        raise SystemExit(main(["wheelrail", *argv, "--json"]))
    out, err = capsys.readouterr()
    assert info.value.code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


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
