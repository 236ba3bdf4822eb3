"""Bad input to the FE model and its command: clear errors, exit status 2."""
from __future__ import annotations

import math
import subprocess
import sys

import pytest

from filmcal.fem import ContactOptions, Film, MeshSettings, evaluate_point, get_model


@pytest.mark.parametrize("kwargs,name", [
    (dict(modulus_mpa=-1.0), "film_modulus_mpa"),
    (dict(modulus_mpa=0.0), "film_modulus_mpa"),
    (dict(modulus_mpa=math.nan), "film_modulus_mpa"),
    (dict(modulus_mpa="stiff"), "film_modulus_mpa"),
    (dict(modulus_mpa=2800.0, poisson=0.5), "film_poisson"),
    (dict(modulus_mpa=2800.0, poisson=-1.0), "film_poisson"),
    (dict(modulus_mpa=2800.0, poisson=0.7), "film_poisson"),
])
def test_bad_film(kwargs, name):
    with pytest.raises(ValueError, match=name):
        Film(**kwargs)


def test_bad_force_and_radius(model450):
    for f in (0.0, -5.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="force_n"):
            model450.solve(None, f)
    with pytest.raises(ValueError, match="sphere_radius_mm"):
        get_model(-450.0)


def test_bad_mesh_and_thickness():
    with pytest.raises(ValueError, match="element_size_mm"):
        MeshSettings(element_size_mm=0.0)
    with pytest.raises(ValueError, match="film_thickness_mm"):
        get_model(450.0, film_thickness_mm=0.0)
    with pytest.raises(ValueError, match="film_thickness_mm"):
        get_model(450.0, film_thickness_mm=-0.09)


def test_element_size_that_cannot_resolve_contact():
    model = get_model(300.0, MeshSettings(element_size_mm=1.0))
    with pytest.raises(ValueError, match="element_size_mm"):
        model.solve(None, 10e3)


def test_bad_contact_options():
    with pytest.raises(ValueError, match="sphere_contact"):
        ContactOptions(sphere_contact="glued")
    with pytest.raises(ValueError, match="friction_coefficient"):
        ContactOptions(friction_coefficient=-0.1)


def test_evaluate_point_names_the_bad_key():
    with pytest.raises(ValueError, match="force_kn"):
        evaluate_point(dict(modulus_mpa=2800, poisson=0.33, sphere_radius_mm=450, force_kn="x"))
    with pytest.raises(ValueError, match="sphere_contact"):
        evaluate_point(dict(modulus_mpa=2800, poisson=0.33, sphere_radius_mm=450, force_kn=75, sphere_contact="glue"))


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "filmcal.cli", "fem", *args], capture_output=True, text=True)


@pytest.mark.parametrize("args", [
    ["--sphere-radius-mm", "450", "--force-kn", "75", "--film-modulus-mpa", "2800", "--film-poisson", "0.7"],
    ["--sphere-radius-mm", "450", "--force-kn", "-75", "--no-film"],
    ["--sphere-radius-mm", "-450", "--force-kn", "75", "--no-film"],
    ["--sphere-radius-mm", "450", "--force-kn", "nan", "--no-film"],
    ["--sphere-radius-mm", "450", "--force-kn", "abc", "--no-film"],
    ["--sphere-radius-mm", "450", "--force-kn", "75", "--film-modulus-mpa", "0"],
    ["--sphere-radius-mm", "450", "--force-kn", "75", "--no-film", "--sphere-contact", "glued"],
])
def test_cli_bad_input_exits_2_with_one_line(args):
    p = _cli(*args, "--json")
    assert p.returncode == 2
    lines = [ln for ln in p.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in p.stderr
    assert p.stdout == ""


def test_cli_json_contract():
    import json
    p = _cli("--sphere-radius-mm", "450", "--force-kn", "75", "--film-modulus-mpa", "2800", "--film-poisson", "0.33",
             "--json")
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    for key in ("contact_radius_mm", "contact_area_mm2", "max_pressure_mpa", "hertz_radius_mm", "converged",
                "elapsed_s"):
        assert key in out
    assert out["converged"] is True
    assert out["contact_area_mm2"] == pytest.approx(math.pi * out["contact_radius_mm"] ** 2)
