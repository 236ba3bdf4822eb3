"""The library refuses, as the command line does, values no film, scan or body can have: a number in the wrong
unit gave a confident answer through the Python API (a film of 2.8e9 MPa, pixels of 100 mm, a coating of
3e5 MPa, a measured radius ten times too small) where the command refused it. Each refusal names its parameter."""
from __future__ import annotations

import numpy as np
import pytest


def _bad(call, *words):
    with pytest.raises(ValueError) as info:
        call()
    for word in words:
        assert word in str(info.value), str(info.value)


def test_films_and_their_laws_take_the_command_lines_bounds():
    from filmcal import ContactOptions, Film, oedometric_modulus_mpa
    from filmcal.contact.laws import FilmLayer

    _bad(lambda: Film(2.8e9), "film_modulus_mpa", "1e+06")  # Pa for MPa
    _bad(lambda: FilmLayer(2.8e9), "modulus_mpa")
    _bad(lambda: FilmLayer(2800.0, 0.33, 90.0), "thickness_mm")  # um for mm
    _bad(lambda: oedometric_modulus_mpa(2800.0, 0.5), "poisson")  # was inf
    _bad(lambda: oedometric_modulus_mpa(2800.0, 0.7), "poisson")  # was -1235 MPa
    _bad(lambda: oedometric_modulus_mpa(np.nan, 0.33), "modulus_mpa")
    _bad(lambda: ContactOptions(max_iterations=0), "max_iterations")  # was an UnboundLocalError in the solve
    # the bounds themselves are taken; M = E (1 - nu) / ((1 + nu)(1 - 2 nu)) = (2/3) / (4/9) E = 1.5 E at nu 1/3
    assert oedometric_modulus_mpa(1.0, 1 / 3) == pytest.approx(1.5, rel=1e-12)
    assert FilmLayer(1e6, 0.33, 5.0).thickness_mm == 5.0


def test_a_scans_pixel_and_a_coatings_hardness_take_the_command_lines_bounds():
    from filmcal import measure_imprint
    from filmcal.contact.roughness import Roughness

    image = np.full((60, 60), 0.1)
    image[20:30, 20:30] = 0.8
    _bad(lambda: measure_imprint(image, 100.0), "pixel_size_mm")  # um per pixel given as mm: 995424 mm2
    assert measure_imprint(image, 0.1).area_mm2 == pytest.approx(1.0, rel=0.05)  # 10 x 10 pixels of 0.1 mm
    _bad(lambda: Roughness(film_hardness_mpa=3e5), "film_hardness_mpa")  # kPa for MPa
    _bad(lambda: Roughness(film_hardness_mpa=-1.0), "film_hardness_mpa")


class _Offset:
    """A radius model: the Hertz radius plus 1 mm, known to 0.01 mm."""

    def predict(self, E, nu, R, F):
        from filmcal import hertz_radius_mm

        E, R, F = np.broadcast_arrays(E, R, F)
        return hertz_radius_mm(R, F) + 1.0, 0.0 * E + 0.01


def test_a_sphere_corrector_called_directly_refuses_what_the_command_refuses():
    """`correct` meets `check_plausible` itself (it was met only by the command): a radius ten times too small or
    too large is refused with the command's words, and one in range is answered (its Hertz radius back)."""
    from filmcal import SphereCorrector, hertz_radius_mm

    c = SphereCorrector(_Offset(), {"modulus_mpa": np.full(500, 2500.0), "sigma_mm": np.full(500, 0.01)})
    a = float(hertz_radius_mm(450.0, 75e3))
    for r in (0.1 * (a + 1.0), 10.0 * (a + 1.0)):
        _bad(lambda r=r: c.correct(r, 450.0, 75e3), "measured_radius_mm", "implausible")
    _bad(lambda: c.correct([a + 1.0, 0.7], [450.0, 450.0], 75e3), "measured_radius_mm 0.7", "implausible")
    assert float(c.correct(a + 1.0, 450.0, 75e3).radius_mm) == pytest.approx(a, abs=0.005)


def test_a_wheel_rail_corrector_called_directly_refuses_an_area_no_film_prints():
    """An area a tenth or ten times the contact without film (mm2 read as cm2, a wrong load) was corrected to
    2.3 or 21315 mm2; refused as `filmcal correct` refuses it."""
    from filmcal import FilmModel, WheelRailCorrector, get_film

    c = WheelRailCorrector({"modulus_mpa": np.array([2500.0, 3000.0]), "sigma_mm": np.array([0.1, 0.1])},
                           FilmModel(get_film("HS")), grid_mm=0.2)
    a0 = c.supports(0.0, 50e3)["area_no_film_mm2"]
    for area in (0.1 * a0, 10.0 * a0):
        _bad(lambda area=area: c.correct(area, 0.0, 50e3), "measured_area_mm2", "implausible")


def test_the_thin_layer_reference_refuses_a_truncated_contact_and_a_film_it_cannot_be():
    """A zone smaller than the contact was answered with the zone's edge, converged; nu 0.5 silently as no
    film; a film of 90 mm as the zone's edge."""
    from filmcal import hertz_radius_mm, thin_layer_contact

    _bad(lambda: thin_layer_contact(450.0, 75e3, 2800.0, zone_mm=2.0), "edge of the zone", "zone_mm")
    _bad(lambda: thin_layer_contact(450.0, 75e3, 2800.0, film_poisson=0.5), "film_poisson")
    _bad(lambda: thin_layer_contact(450.0, 75e3, 2800.0, film_thickness_mm=90.0), "film_thickness_mm")
    _bad(lambda: thin_layer_contact(450.0, 75e3, 2800.0, ring_width_mm=0.0), "ring_width_mm")
    # a zone just wide enough is solved: without film Hertz's radius within a ring
    bare = thin_layer_contact(450.0, 75e3, None, zone_mm=1.2 * float(hertz_radius_mm(450.0, 75e3)))
    assert bare.contact_radius_mm == pytest.approx(float(hertz_radius_mm(450.0, 75e3)), abs=0.02)


def test_the_fe_in_the_loop_names_only_readings_the_fe_returns():
    """A reading the FE does not return (a typo, or an imprint reading without its film) answered NaN after
    every FE solve; refused at once, naming the readings it has."""
    from filmcal import FERadiusModel, get_film

    _bad(lambda: FERadiusModel(output="radius_activation_HS_mm"), "radius_activation_HS_mm", "contact_radius_mm")
    assert FERadiusModel(output="radius_activation_HS_mm", films=[get_film("HS")]).output == "radius_activation_HS_mm"


@pytest.mark.parametrize("posterior, max_samples, words", [
    ({"modulus_mpa": [2500.0, np.nan], "sigma_mm": [0.1, 0.1]}, 2000, ["modulus_mpa", "finite"]),
    ({"modulus_mpa": [2500.0, 2600.0], "sigma_mm": [0.1, -5.0]}, 2000, ["sigma_mm", ">= 0"]),  # acted as 5
    ({"modulus_mpa": [2500.0, 2600.0], "sigma_mm": [0.1, 0.1], "poisson": 0.6}, 2000, ["poisson"]),
    ({"modulus_mpa": [2500.0, 2600.0, 2700.0], "sigma_mm": [0.1, 0.1]}, 2000, ["one size"]),  # was an IndexError
    ({"modulus_mpa": [2500.0, 2600.0]}, 2000, ["sigma_mm"]),  # was a KeyError
    ({"modulus_mpa": [2500.0, 2600.0], "sigma_mm": [0.1, 0.1]}, 1, ["max_samples"]),  # a spread of nan
])
def test_a_correctors_posterior_is_checked_before_it_is_used(posterior, max_samples, words):
    from filmcal import FilmModel, SphereCorrector, WheelRailCorrector, get_film

    _bad(lambda: SphereCorrector(_Offset(), posterior, max_samples=max_samples), *words)
    _bad(lambda: WheelRailCorrector(posterior, FilmModel(get_film("HS")), max_samples=max_samples), *words)
