"""The second FE formulation (biquadratic elements, closing-load edge) against
closed forms: Hertz without film, and Hertz again with a steel film."""
import math

import pytest

from filmcal.fem.reference import QuadraticSphereOnFlat
from filmcal.hertz import hertz_max_pressure_mpa, hertz_radius_mm


@pytest.fixture(scope="module")
def spheres():
    return {h: QuadraticSphereOnFlat(250.0, element_size_mm=h, contact_zone_mm=6.0) for h in (0.1, 0.05)}


def test_reference_reads_hertz_after_extrapolation(spheres):
    """Without film: the closing-load edge converges at first order in h, and
    its extrapolation to h -> 0 is Hertz's radius within 0.03 % (50 mm bodies
    are not half-spaces); the axis pressure is Hertz's within 0.1 %."""
    F = 15e3
    a = {h: m.solve(F).contact_radius_mm for h, m in spheres.items()}
    a_h = hertz_radius_mm(250.0, F)
    assert a[0.1] > a[0.05] > a_h  # the reading's bias is outward and halves with h
    assert (a[0.1] - a_h) == pytest.approx(2 * (a[0.05] - a_h), rel=0.15)
    assert 2 * a[0.05] - a[0.1] == pytest.approx(a_h, rel=3e-4)
    assert spheres[0.05].solve(F).max_pressure_mpa == pytest.approx(hertz_max_pressure_mpa(250.0, F), rel=1e-3)


def test_steel_film_is_steel(spheres):
    """A film with steel's constants, tied to the flat, makes the flat 0.09 mm
    thicker and nothing else: Hertz again."""
    F = 20e3
    a = {h: m.solve(F, 210000.0, 0.3).contact_radius_mm for h, m in spheres.items()}
    plain = {h: m.solve(F).contact_radius_mm for h, m in spheres.items()}
    for h in a:
        assert a[h] == pytest.approx(plain[h], abs=2e-4)
    assert 2 * a[0.05] - a[0.1] == pytest.approx(hertz_radius_mm(250.0, F), rel=3e-4)


def test_soft_film_enlarges_and_bad_input_is_refused(spheres):
    m = spheres[0.1]
    assert m.solve(20e3, 1000.0, 0.33).contact_radius_mm > m.solve(20e3).contact_radius_mm + 0.2
    with pytest.raises(ValueError, match="force_n"):
        m.solve(-1.0)
    with pytest.raises(ValueError, match="film_poisson"):
        m.solve(1e4, 1000.0, 0.5)
    with pytest.raises(ValueError, match="refined zone"):
        m.solve(2e6)
    with pytest.raises(ValueError, match="film_layers"):
        QuadraticSphereOnFlat(250.0, film_layers=0)
    assert math.isfinite(m.solve(5e3).contact_radius_mm)


@pytest.mark.parametrize("modulus_mpa, poisson", [(1500.0, 0.30), (4000.0, 0.43)])
def test_production_fe_reads_the_second_formulations_edge(modulus_mpa, poisson):
    """The production FE (bilinear, closing-load edge) at its default mesh
    reads the film contact's edge within 0.002 mm of the second formulation
    extrapolated to h -> 0 (the target is 0.005 mm), at films outside the fit
    of its film lead (nu 0.43 is where fully integrated film elements locked)."""
    from filmcal.fem import Film, get_model

    R, F = 450.0, 60e3
    a = [QuadraticSphereOnFlat(R, element_size_mm=h, contact_zone_mm=9.0).solve(F, modulus_mpa, poisson)
         for h in (0.1, 0.05)]
    reference = 2 * a[1].contact_radius_mm - a[0].contact_radius_mm
    assert abs(a[1].contact_radius_mm - reference) < 0.003  # the reference's own step is small
    production = get_model(R).solve(Film(modulus_mpa, poisson), F).contact_radius_mm
    assert production == pytest.approx(reference, abs=0.002)


def test_a_study_ignores_posteriors_of_an_older_fe_revision(tmp_path):
    """A folder run again after the FE changed keeps the old posteriors on disk; only the current
    revision's are read (otherwise `correct` would find two posteriors and refuse)."""
    from filmcal.contact.names import FE_MODEL_REVISION
    from filmcal.study import Study

    study = Study(tmp_path / "s", create=True)
    spec = {"film": {"name": "HS"}, "fe": {"kinematics": "small"}, "imprint": "edge"}
    with study.writing("test"):
        for revision in (None, FE_MODEL_REVISION):
            fe = dict(spec["fe"], **({} if revision is None else {"fe_model_revision": revision}))
            path = study.root / f"p{revision}.json"
            path.write_text("{}")
            study.record(path, "posterior", dict(spec, fe=fe))
    found = study.posteriors("HS")
    assert [p.name for p, _ in found] == [f"p{FE_MODEL_REVISION}.json"]
