"""`filmcal fem` with film types and imprint models (in-process, through `filmcal.cli.main`)."""
from __future__ import annotations

import json
import math

import pytest

from filmcal import cli
from filmcal.hertz import hertz_max_pressure_mpa, hertz_radius_mm

BASE = ["fem", "--sphere-radius-mm", "450", "--force-kn", "75", "--json"]


def _run(capsys, *args) -> tuple[int, dict | None, str]:
    code = cli.main([*BASE, *args])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if out.out.strip() else None), out.err


def test_film_type_reports_the_activation_imprint(capsys):
    code, out, _ = _run(capsys, "--film-modulus-mpa", "2800", "--film", "HS")
    assert code == 0
    assert out["imprint_model"] == "activation" and out["film"] == "HS"
    assert out["activation_pressure_mpa"] == 50.0
    assert 0 < out["imprint_radius_mm"] < out["contact_radius_mm"]
    assert out["imprint_area_mm2"] == pytest.approx(math.pi * out["imprint_radius_mm"] ** 2)


def test_no_film_imprint_is_the_hertz_contour(capsys):
    code, out, _ = _run(capsys, "--no-film", "--film", "HHS")
    a = hertz_radius_mm(450.0, 75e3)
    p0 = hertz_max_pressure_mpa(450.0, 75e3)
    assert code == 0
    assert out["contact_radius_mm"] == pytest.approx(a, abs=0.01)
    assert out["imprint_radius_mm"] == pytest.approx(a * math.sqrt(1 - (130.0 / p0) ** 2), abs=0.01)


def test_imprint_models_and_user_films(capsys, tmp_path):
    films = tmp_path / "films.toml"
    films.write_text('[LOT7]\nactivation_pressure_mpa = 45\n\n[WIDE]\nrange_mpa = [40, 160]\n')
    radii = {}
    for model in ("edge", "activation", "capsule"):
        code, out, _ = _run(capsys, "--film-modulus-mpa", "2800", "--films-file", str(films),
                            "--film", "WIDE", "--imprint-model", model)
        assert code == 0 and out["imprint_model"] == model
        radii[model] = out["imprint_radius_mm"]
    assert radii["edge"] == pytest.approx(out["contact_radius_mm"])
    assert radii["edge"] > radii["activation"] > radii["capsule"]
    code, out, _ = _run(capsys, "--film-modulus-mpa", "2800", "--films-file", str(films), "--film", "LOT7")
    assert code == 0 and out["activation_pressure_mpa"] == 45.0
    code, legacy, _ = _run(capsys, "--film-modulus-mpa", "2800", "--activation-pressure-mpa", "45")
    assert code == 0 and legacy["imprint_radius_mm"] == pytest.approx(out["imprint_radius_mm"], abs=1e-12)


@pytest.mark.parametrize("args, message", [
    (["--film", "NOPE"], "unknown film 'NOPE'"),
    (["--imprint-model", "capsule"], "--imprint-model needs --film"),
    (["--activation-pressure-mpa", "-5"], "--activation-pressure-mpa must be > 0"),
])
def test_bad_input_is_one_line_and_status_2(capsys, args, message):
    code, out, err = _run(capsys, "--film-modulus-mpa", "2800", *args)
    assert code == 2 and out is None
    assert message in err and err.count("\n") == 1 and "Traceback" not in err


def test_capsule_needs_a_range(capsys, tmp_path):
    films = tmp_path / "films.toml"
    films.write_text('[LOT7]\nactivation_pressure_mpa = 45\n')
    code, _, err = _run(capsys, "--film-modulus-mpa", "2800", "--films-file", str(films), "--film", "LOT7",
                        "--imprint-model", "capsule")
    assert code == 2 and "LOT7 has no range_mpa" in err


def test_a_solution_outside_its_models_validity_says_so(capsys):
    """R450 at 2000 kN was printed as 'converged' with a 73 % small-strain film and 3360 MPa on the steel, and
    nothing else. Hertz's peak pressure (3.2 GPa here, 1.08 GPa at 100 kN) places the elastic limit between."""
    code = cli.main(["fem", "--sphere-radius-mm", "450", "--force-kn", "2000", "--film-modulus-mpa", "2500", "--json"])
    out = capsys.readouterr()
    answer = json.loads(out.out)
    assert code == 0 and hertz_max_pressure_mpa(450.0, 2000e3) > 1250.0 > hertz_max_pressure_mpa(450.0, 100e3)
    assert len(answer["warnings"]) == 2 and "--kinematics large" in answer["warnings"][0]
    assert "elastic limit" in answer["warnings"][1]
    lines = out.err.strip().splitlines()
    assert len(lines) == 2 and all(line.startswith("filmcal fem: warning: FEValidityWarning: ") for line in lines)
    code, out, err = _run(capsys, "--film-modulus-mpa", "2800")  # Table 1's HS case: within both
    assert code == 0 and out["warnings"] == [] and err == ""


def test_a_collapsed_film_prints_no_numbers_and_a_plain_warning(capsys):
    """E = 1 MPa at 60 kN collapses the small-strain film: the command printed a contact radius, area and
    pressure of no solution and 'film strain 11406.1 %'; now the reason alone, exit 1, and a warning in words."""
    code = cli.main(["fem", "--sphere-radius-mm", "300", "--force-kn", "60", "--film-modulus-mpa", "1"])
    out, err = capsys.readouterr()
    assert code == 1 and "NOT converged" in out and "contact radius  " not in out and "film strain" not in out
    assert "collapses" in err and "%," not in err
