"""The film's thin limit: within the thickness range the FE resolves, a thinning film's contact radius
tends to the no-film (Hertz) radius at the rate the film's compliance predicts; below that range the
model and `filmcal fem` refuse the film in one line instead of printing a mesh-dependent number."""
from __future__ import annotations

import math

import pytest

from filmcal import cli
from filmcal.fem import Film, SphereOnFlat, get_model, thin_layer_contact
from filmcal.fem.model import MIN_FILM_THICKNESS_PER_ELEMENT, check_film_thickness, min_film_thickness_mm
from filmcal.hertz import contact_modulus_mpa, hertz_radius_mm

R_MM, F_N = 450.0, 50e3
FILM = Film(2500.0, 0.3)
#: Down to the default mesh's limit, element size 0.1 mm / 10.
THICKNESSES_MM = (0.09, 0.03, 0.01)


@pytest.fixture(scope="module")
def excess_mm() -> dict[float, float]:
    """Radius with film minus the Hertz radius (the no-film closed form), default mesh."""
    a_h = hertz_radius_mm(R_MM, F_N)
    out = {}
    for t in THICKNESSES_MM:
        res = get_model(R_MM, film_thickness_mm=t).solve(FILM, F_N)  # default mesh, h = 0.1 mm
        assert res.converged, res.reason
        out[t] = res.contact_radius_mm - a_h
    return out


def test_the_thin_film_limit_is_the_no_film_answer(excess_mm):
    """A film of thickness t and oedometric modulus M adds the compliance t/M in series with the steel.
    To first order in it the radius grows by (l / 2 pi) ln(C a / l), l = t E*/M (Sneddon's load integral
    of the Hertz contact with the extra displacement (t/M) p(r); it diverges logarithmically at the
    edge, cut off at l): the excess over Hertz falls like t ln(1/t) and vanishes with t, and excess/t
    grows by E*/(2 pi M) per unit of ln(1/t). Measured (R450/50 kN, E 2500 MPa, nu 0.3): 5.07 and 5.00
    at h = 0.1 mm, 5.16 and 5.38 at h = 0.025 mm, against 5.46."""
    ts = sorted(excess_mm, reverse=True)
    ex = [excess_mm[t] for t in ts]
    assert all(e > 0 for e in ex)
    assert all(thick > thin for thick, thin in zip(ex, ex[1:]))  # monotone towards the no-film radius
    slope = contact_modulus_mpa() / (2 * math.pi * FILM.oedometric_modulus_mpa)
    for (t1, e1), (t2, e2) in zip(zip(ts, ex), zip(ts[1:], ex[1:])):
        measured = (e2 / t2 - e1 / t1) / math.log(t1 / t2)
        assert measured == pytest.approx(slope, rel=0.15), (t1, t2, measured, slope)
    # nearly in proportion to t: each third of the thickness keeps between a quarter and a half of the excess
    for e1, e2 in zip(ex, ex[1:]):
        assert 1 / 4 < e2 / e1 < 1 / 2


def test_the_thinnest_resolved_film_agrees_with_the_spring_layer_model(excess_mm):
    """As t -> 0 the film's edge tip (about 0.5 t) vanishes and the film is the spring layer M/t on two
    half-spaces (`thin_layer_contact`, an independent boundary-element model). At the default mesh's
    thinnest film the radius excesses agree within 0.01 mm (rings 0.005 mm wide; measured 0.0053 mm,
    and 0.0056 mm at t = 0.03 mm)."""
    t = THICKNESSES_MM[-1]
    base = thin_layer_contact(R_MM, F_N, None, ring_width_mm=0.005, zone_mm=6.0)
    thin = thin_layer_contact(R_MM, F_N, FILM.modulus_mpa, FILM.poisson, t, ring_width_mm=0.005, zone_mm=6.0)
    assert base.converged and thin.converged
    assert base.contact_radius_mm == pytest.approx(hertz_radius_mm(R_MM, F_N), abs=0.005)
    assert excess_mm[t] == pytest.approx(thin.contact_radius_mm - base.contact_radius_mm, abs=0.01)


def test_a_film_below_the_resolved_thickness_is_refused_not_solved():
    """The reported case: t = 1e-9 mm on the default mesh used to read a radius below the no-film one
    (by the film's edge lead, 0.55 h^2) or fail as "film collapsed" with a film free to slide. The model
    still solves without film (which does not depend on t) and refuses the film."""
    model = SphereOnFlat(R_MM, film_thickness_mm=1e-9)
    no_film = model.solve(None, F_N)
    assert no_film.converged
    assert no_film.contact_radius_mm == pytest.approx(hertz_radius_mm(R_MM, F_N), abs=0.002)
    with pytest.raises(ValueError, match=r"film_thickness_mm 1e-09 is below the 0\.01 mm .*element_size_mm / 10"):
        model.solve(FILM, F_N)


def test_the_resolved_thickness_scales_with_the_element_size():
    assert MIN_FILM_THICKNESS_PER_ELEMENT == 0.1
    assert min_film_thickness_mm(0.1) == pytest.approx(0.01)
    assert check_film_thickness(0.01, 0.1) == 0.01  # the limit itself is valid
    assert check_film_thickness(0.005, 0.05) == 0.005
    with pytest.raises(ValueError, match=r"film_thickness_mm 0\.005 .* 40:1 flat.*element_size_mm <= 0\.05"):
        check_film_thickness(0.005, 0.1)
    with pytest.raises(ValueError, match="film_thickness_mm"):
        check_film_thickness(0.0, 0.1)


@pytest.mark.parametrize("thickness, named", [("1e-9", "--film-thickness-mm"),  # the option's own bounds
                                               ("0.005", "--film-thickness-mm: film_thickness_mm 0.005 is below")])
def test_fem_refuses_a_film_too_thin_in_one_line(capsys, tmp_path, monkeypatch, thickness, named):
    """Exit 2, one line on stderr, nothing on stdout, no file written, and no model built."""
    import filmcal.fem

    def no_build(*args, **kwargs):
        raise AssertionError("the model was built for a film it cannot resolve")

    monkeypatch.setattr(filmcal.fem, "get_model", no_build)
    argv = ["fem", "--sphere-radius-mm", "450", "--force-kn", "50", "--film-modulus-mpa", "2500", "--film-poisson",
            "0.3", "--film-thickness-mm", thickness, "--json", "--pressure-csv", str(tmp_path / "p.csv"),
            "--plot", str(tmp_path / "p.png")]
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse's own bounds exit from inside main
        code = exc.code
    out = capsys.readouterr()
    assert code == 2
    assert out.out == ""
    assert out.err.count("\n") == 1 and named in out.err and "Traceback" not in out.err
    assert list(tmp_path.iterdir()) == []
