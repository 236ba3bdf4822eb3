"""A measured surface split at the contact grid: micro part for the law, waviness for the macro gap."""
from __future__ import annotations

import math

import numpy as np
import pytest

from filmcal.contact.roughness import RoughSurface, Roughness
from filmcal.contact.waviness import Waviness, gaussian_transmission, split_surface


def _amplitude(z: np.ndarray, spacing_um: float, wavelength_um: float) -> float:
    """Least-squares amplitude of one sine in a profile."""
    x = np.arange(z.size) * spacing_um
    basis = np.column_stack([np.sin(2 * np.pi * x / wavelength_um), np.cos(2 * np.pi * x / wavelength_um)])
    coef, *_ = np.linalg.lstsq(basis, z - z.mean(), rcond=None)
    return float(np.hypot(*coef))


def test_the_split_is_the_iso_gaussian_filter():
    """A turned profile (feed marks 1000 um, amplitude 15 um) with a short wave (25 um, 1 um) across the lay:
    the waviness keeps exp(-pi (alpha lc / lambda)^2) of each wave (ISO 16610-21; 0.895 and 0 at lc = 400
    um), the micro part the rest, and the two add up to the surface."""
    spacing = 5.0
    x = np.arange(800) * spacing  # 4 mm: whole periods of both waves
    z = 15.0 * np.sin(2 * np.pi * x / 1000.0) + 1.0 * np.sin(2 * np.pi * x / 25.0)
    surface = RoughSurface(np.repeat(z[:, None], 8, axis=1), spacing)  # a profile's ridged map, not levelled
    micro, wavy = split_surface(surface, 400.0)
    assert gaussian_transmission(400.0, 400.0) == pytest.approx(0.5)
    kept = gaussian_transmission(1000.0, 400.0)
    assert kept == pytest.approx(math.exp(-math.log(2) * 0.16))
    w, m = wavy.heights_um[:, 0], micro.heights_um[:, 0]
    assert _amplitude(w, spacing, 1000.0) == pytest.approx(15.0 * kept, rel=1e-6)
    assert _amplitude(w, spacing, 25.0) < 1e-6
    assert _amplitude(m, spacing, 1000.0) == pytest.approx(15.0 * (1 - kept), rel=1e-6)
    assert _amplitude(m, spacing, 25.0) == pytest.approx(1.0, rel=1e-6)
    np.testing.assert_allclose(w + m, surface.heights_um[:, 0], atol=1e-9)
    # a map no longer than the cut-off is all micro-roughness (the synthetic surfaces: 200 um)
    small = RoughSurface.synthetic(ra_um=1.5, size_um=200.0, n=64, seed=1)
    assert split_surface(small, 400.0) == (small, None)
    assert Roughness(small).split(400.0).waviness is None



def test_the_draws_of_a_measured_map_share_its_split_which_goes_with_the_map():
    """Every draw splits a measured map alike: the draws share one micro part and one waviness (laid at each
    draw's own phase) instead of holding two more copies of the heights each; another cut-off is its own
    split, and the splits go when the map goes."""
    import gc
    import weakref

    from filmcal.contact.rough_imprint import RoughnessInputs
    from filmcal.correction.roughness import draw_bodies

    rng = np.random.default_rng(4)
    surface = RoughSurface(rng.normal(0.0, 2.0, (256, 256)), 4.0, "map")  # 1 mm square: waviness at 0.4 mm
    draws = [RoughnessInputs(250.0 + 50 * k, 0.5, 0.8, 50.0, 4.0, k) for k in range(3)]
    split = [draw_bodies(d, wheel=surface) for d in draws]
    first, wavy = split[0]
    for bodies, waviness in split[1:]:
        assert np.shares_memory(bodies.wheel.heights_um, first.wheel.heights_um)
        assert np.shares_memory(waviness.heights_um, wavy.heights_um)
        assert bodies.film_hardness_mpa != first.film_hardness_mpa and waviness.offset_mm != wavy.offset_mm
    np.testing.assert_allclose(first.wheel.heights_um + wavy.heights_um, surface.heights_um - surface.heights_um.mean(),
                               atol=1e-9)
    other, _ = split_surface(surface, 200.0)
    assert not np.shares_memory(other.heights_um, first.wheel.heights_um)
    assert np.std(other.heights_um) < np.std(first.wheel.heights_um)
    gone = weakref.ref(first.wheel)
    del split, first, wavy, other, bodies, waviness, surface
    gc.collect()
    assert gone() is None

def test_waviness_is_sampled_periodically_from_the_planes_origin():
    """The map repeats from x = s = 0 of the contact plane, so a grid anywhere samples the same stripes; maps on
    two pixel grids add their gaps."""
    h = np.arange(12.0).reshape(4, 3)  # 4 across the lay (s), 3 along it (x), 10 um pixels
    wavy = Waviness(h, 10.0)
    x = np.array([0.0, 0.01, 0.02, 0.03])  # mm: 10 um steps along x
    s = np.array([0.0, 0.01, 0.045])  # 10 um, then half a pixel
    g = 1e3 * wavy.gap_mm(x, s)
    assert g[0, 0] == pytest.approx(h[0, 0]) and g[1, 1] == pytest.approx(h[1, 1])
    assert g[3, 0] == pytest.approx(h[0, 0])  # x wraps after 3 pixels
    # s = 45 um is pixel 4.5 across: pixel 4 wraps to 0, halfway to pixel 1
    assert g[0, 2] == pytest.approx(0.5 * (h[0, 0] + h[1, 0]))
    # a grid starting elsewhere: the same heights at the same plane coordinates (4 and 3 pixels periodic)
    shifted = 1e3 * wavy.gap_mm(x + 0.03, s + 0.04)
    np.testing.assert_allclose(shifted, g, atol=1e-9)
    other = Waviness(np.ones((5, 5)), 7.0)
    both = wavy + other
    np.testing.assert_allclose(both.gap_mm(x, s), wavy.gap_mm(x, s) + other.gap_mm(x, s))
    assert both.rms_um == pytest.approx(np.hypot(wavy.rms_um, other.rms_um))
    # laid at a random phase: the same map read at shifted coordinates, the phase reproducible by its seed
    moved = wavy.shifted(3)
    assert moved.offset_mm == wavy.shifted(3).offset_mm != wavy.shifted(4).offset_mm
    assert 0 <= moved.offset_mm[0] < 0.03 and 0 <= moved.offset_mm[1] < 0.04
    np.testing.assert_allclose(moved.gap_mm(x, s), wavy.gap_mm(x + moved.offset_mm[0], s + moved.offset_mm[1]))


def test_a_lateral_wave_in_full_contact_modulates_the_pressure_as_westergaard_says():
    """A lateral sine of amplitude A and wavelength lambda in the wheel's gap, where the contact is full, adds
    p* cos(2 pi s / lambda) to the pressure, p* = pi E* A / lambda (Westergaard; Johnson, Contact Mechanics,
    13.2): the difference of the wheel-rail pressures with and without the wave, across the patch's centre,
    has that amplitude within 10 % (8 cells per wavelength)."""
    from filmcal.wheelrail import get_wheel_rail_model

    lam_um, a_um = 800.0, 0.5
    n = 400  # 2 um pixels: 800 um, one period
    h = a_um * np.sin(2 * np.pi * np.arange(n) * 2.0 / lam_um)
    wavy = Waviness(np.repeat(h[:, None], 8, axis=1), 2.0)
    model = get_wheel_rail_model()
    smooth = model.solve(-3.0, 100e3)
    wave = model.solve(-3.0, 100e3, waviness=wavy)
    c0, c1 = smooth.contact, wave.contact
    assert c0.grid.x_mm.shape == c1.grid.x_mm.shape and np.allclose(c0.grid.y_mm, c1.grid.y_mm)
    i = int(np.argmax(c0.pressure_mpa.max(axis=1)))  # the row through the peak
    p0, p1 = c0.pressure_mpa[i], c1.pressure_mpa[i]
    e_star = model.solver.contact_modulus_mpa
    p_star = math.pi * e_star * a_um * 1e-3 / (lam_um * 1e-3)
    full = p0 > 2.0 * p_star
    s = c0.grid.y_mm[full] - c0.grid.y_mm[0]
    d = (p1 - p0)[full]
    basis = np.column_stack([np.sin(2 * np.pi * s / 0.8), np.cos(2 * np.pi * s / 0.8), np.ones_like(s), s])
    coef, *_ = np.linalg.lstsq(basis, d, rcond=None)
    assert full.sum() >= 16
    assert float(np.hypot(coef[0], coef[1])) == pytest.approx(p_star, rel=0.10)


def test_corrections_put_a_measured_profiles_feed_marks_into_the_gap():
    """`draw_laws` (what `filmcal correct` and `filmcal curves` solve with) splits a measured turned profile at
    4 cells of the 0.1 mm grid: the law is built on the micro part, the feed marks (0.8 mm) are the waviness of
    the solves, with the Gaussian filter's share of their amplitude."""
    from filmcal.contact.rough_imprint import load_roughness_inputs, representative_roughness_inputs
    from filmcal.contact.surface_files import profile_surface
    from filmcal.correction.roughness import draw_laws
    from filmcal.films import get_film

    spacing = 2.0
    x = np.arange(2000) * spacing
    z = 15.0 * np.sin(2 * np.pi * x / 800.0) + 0.8 * np.sin(2 * np.pi * x / 20.0)
    turned = profile_surface(z, spacing, "turned wheel")
    laws = draw_laws(representative_roughness_inputs(), {"HS": (get_film("HS"), 2600.0)}, wheel=turned)
    kept = gaussian_transmission(800.0, 400.0)
    assert laws["waviness"].rms_um == pytest.approx(15.0 / math.sqrt(2) * kept, rel=0.02)
    assert "wavelengths under 400 um" in laws["HS"].surface.description
    # each draw lays the marks at its own phase (where the crests fall on the patch is not known)
    other = draw_laws(load_roughness_inputs()[3], {"HS": (get_film("HS"), 2600.0)}, wheel=turned)
    assert laws["waviness"].offset_mm != other["waviness"].offset_mm
    assert laws["HS"].surface.rms_um < 0.3 * turned.rms_um


def test_the_crests_of_a_turned_profile_carry_more_than_the_elastic_limit(tmp_path):
    """A turned wheel's measured profile (feed marks 0.8 mm, 15 um) read from its CSV: its waviness stripes the
    contact without film, whose crests carry several GPa elastically (what `filmcal correct` then warns of:
    the crests flatten, the corrected area is a lower bound); a synthetic Ra has no waviness to warn of."""
    x = np.arange(2000) * 2.0
    z = 15.0 * np.sin(2 * np.pi * x / 800.0) + 0.8 * np.sin(2 * np.pi * x / 20.0)
    (tmp_path / "turned.csv").write_text("x_um,z_um\n" + "".join(f"{a:g},{b:.5f}\n" for a, b in zip(x, z)))
    from filmcal.correction.roughness import waviness_peak_mpa
    from filmcal.contact.rough_imprint import load_roughness_inputs
    from filmcal.contact.surface_files import read_surface_file

    turned = read_surface_file(tmp_path / "turned.csv")
    peak = waviness_peak_mpa(load_roughness_inputs()[0], -3.0, 100e3, {}, wheel=turned)
    assert peak > 2500.0  # elastic crests far above the steel's limit
    assert waviness_peak_mpa(load_roughness_inputs()[0], -3.0, 100e3, {}, wheel=1.5) is None


def test_curves_say_when_a_measured_surface_stripes_the_contact():
    from filmcal.commands.curves import _waviness_note
    from filmcal.contact.rough_imprint import load_roughness_inputs
    from filmcal.contact.surface_files import profile_surface
    from filmcal.correction import RoughConfiguration

    x = np.arange(2000) * 2.0
    turned = profile_surface(15.0 * np.sin(2 * np.pi * x / 800.0) + 0.8 * np.sin(2 * np.pi * x / 20.0), 2.0)
    draws = tuple(load_roughness_inputs()[:2])
    assert "lower bound" in _waviness_note(RoughConfiguration(turned, None, draws))
    assert _waviness_note(RoughConfiguration(1.5, None, draws)) is None
