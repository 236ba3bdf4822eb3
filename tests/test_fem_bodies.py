"""A lab's bodies of another material than steel: the FE models them, and a study follows its dataset's."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal._errors import InputError
from filmcal.calibration.data import RadiusErrorData
from filmcal.fem import Film, evaluate_point, solve_sphere_on_flat
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm
from filmcal.study.core import CalibrationSpec, FESettings, _bodies_spec


@pytest.mark.parametrize("modulus, poisson", [(70000.0, 0.33), (120000.0, 0.34), (STEEL_MODULUS_MPA, STEEL_POISSON)])
def test_fe_without_film_reads_hertz_of_the_bodies(modulus, poisson):
    """Aluminium, titanium and steel spheres on flats of the same material, R 450 mm / 50 kN, no film: the
    FE's contact radius is Hertz's for those bodies within 0.05 %."""
    res = solve_sphere_on_flat(450.0, 50e3, None, body_modulus_mpa=modulus, body_poisson=poisson)
    assert res.contact_radius_mm == pytest.approx(hertz_radius_mm(450.0, 50e3, modulus, poisson), rel=5e-4)
    assert res.hertz_radius_mm == pytest.approx(hertz_radius_mm(450.0, 50e3, modulus, poisson), rel=1e-12)


def test_a_design_point_carries_its_bodies():
    """The campaign's model reads the bodies' columns; softer bodies print a larger imprint."""
    point = {"sphere_radius_mm": 450.0, "force_kn": 50.0, "modulus_mpa": 2800.0, "poisson": 0.33}
    soft = evaluate_point({**point, "body_modulus_mpa": 70000.0, "body_poisson": 0.33})
    direct = solve_sphere_on_flat(450.0, 50e3, Film(2800.0, 0.33), body_modulus_mpa=70000.0, body_poisson=0.33)
    assert soft["contact_radius_mm"] == direct.contact_radius_mm
    assert soft["contact_radius_mm"] > evaluate_point(point)["contact_radius_mm"] + 1.0


def _data(sphere, flat):
    n = len(sphere)
    return RadiusErrorData(film=np.full(n, "HS"), sphere_radius_mm=np.full(n, 450.0), force_n=np.full(n, 50e3),
                           radius_error_mm=np.ones(n), hertz_radius_mm=np.full(n, 6.0),
                           measured_radius_mm=np.full(n, 7.0),
                           sphere_modulus_mpa=[e for e, _ in sphere], sphere_poisson=[nu for _, nu in sphere],
                           flat_modulus_mpa=[e for e, _ in flat], flat_poisson=[nu for _, nu in flat])


def test_a_study_takes_its_datasets_bodies_or_refuses_them_in_one_line():
    spec = CalibrationSpec("HS", fe=FESettings(n_train=24, n_test=8))
    steel = (STEEL_MODULUS_MPA, STEEL_POISSON)
    assert _bodies_spec(spec, _data([steel] * 3, [steel] * 3)) is spec  # as before: the spec is unchanged
    assert "body_modulus_mpa" not in spec.fe.as_spec()
    al = (70000.0, 0.33)
    fe = _bodies_spec(spec, _data([al] * 3, [al] * 3)).fe
    assert (fe.body_modulus_mpa, fe.body_poisson) == al and fe.as_spec()["body_modulus_mpa"] == 70000.0
    for sphere, flat in (([al] * 2, [steel] * 2), ([al, steel], [al, steel])):
        with pytest.raises(InputError, match="bodies of film HS's rows differ") as info:
            _bodies_spec(spec, _data(sphere, flat))
        assert "\n" not in str(info.value)
