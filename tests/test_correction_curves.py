"""Posterior correction curves against direct wheel-rail solves."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.contact.film import FilmModel
from filmcal.correction import correction_curves
from filmcal.films import get_film
from filmcal.wheelrail import FilmLayer, solve_wheel_rail

HS_EDGE = FilmModel(get_film("HS"), "edge", "small")


def test_bands_match_direct_solves_at_their_quantiles():
    rng = np.random.default_rng(1)
    samples = np.exp(rng.normal(np.log(2800.0), 0.04, 3000))
    c = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3])
    a0 = solve_wheel_rail(-4.0, 50e3).area_mm2
    assert c.area_no_film_mm2[0, 0] == pytest.approx(a0, rel=1e-6)  # the sweep solves to a tolerance of 1e-6
    # the film area is monotone in E: the band's ends are the film areas at the 95 % / 5 % quantiles of E, the
    # area the calibrated film records (the solve's plus the transfer term's shift; its spread, about 1e-3 of
    # the area, moves these quantiles by far less than the tolerance)
    for q, k in ((0.05, 1), (0.95, 0)):
        e = float(np.quantile(samples, q))
        result = solve_wheel_rail(-4.0, 50e3, film=FilmLayer(e, 0.33, 0.09))
        direct = result.area_mm2 + HS_EDGE.transfer_term(e, result).shift_mm2
        # within twice the noise of one solve's area: counted cells scatter by up to 1e-3 of the area from
        # modulus to modulus (residuals of a least-squares quadratic through 25 solves over this range)
        assert a0 + c.delta_area_ci90_mm2[0, 0, k] == pytest.approx(direct, rel=2e-3)
    assert c.ratio_ci90[0, 0, 0] < c.ratio_median[0, 0] < c.ratio_ci90[0, 0, 1] < 1.0
    assert c.interpolation_error_rel[0, 0] < 2e-3


def test_bad_samples():
    with pytest.raises(ValueError, match="modulus_samples_mpa"):
        correction_curves([(HS_EDGE, [2800.0, -1.0], 1.0)], [-4.0], [50e3])
    with pytest.raises(ValueError, match="weights"):
        correction_curves([(HS_EDGE, [2800.0], -1.0)], [-4.0], [50e3])


def test_a_mixture_band_spans_the_models_it_pools():
    """Two models that read the same contact differently (edge, activation contour), equal weights: the
    pooled 90 % band reaches from one model's median to the other's (a property of a 50/50 mixture of two
    well-separated, narrow components)."""
    rng = np.random.default_rng(2)
    samples = np.exp(rng.normal(np.log(2800.0), 0.02, 2000))
    activation = FilmModel(get_film("HS"), "activation", "small")
    edge_only = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3])
    act_only = correction_curves([(activation, samples, 1.0)], [-4.0], [50e3])
    mixed = correction_curves([(HS_EDGE, samples, 1.0), (activation, samples, 1.0)], [-4.0], [50e3])
    # the activation contour lies inside the contact edge: a smaller recorded area
    assert act_only.area_film_median_mm2[0, 0] < edge_only.area_film_median_mm2[0, 0]
    lo, hi = mixed.delta_area_ci90_mm2[0, 0]
    assert lo <= act_only.delta_area_median_mm2[0, 0] and edge_only.delta_area_median_mm2[0, 0] <= hi
    assert hi - lo > edge_only.delta_area_ci90_mm2[0, 0, 1] - edge_only.delta_area_ci90_mm2[0, 0, 0]


def test_rough_bodies_give_their_nominal_area_without_film():
    """With the rough bodies' law the area without film is their nominal area: larger than the smooth one,
    and the correction factor A0 / A grows with it (the film's areas are the smooth film's here)."""
    from filmcal.contact.roughness import WHEEL_SURFACE_DEFAULTS, RoughSurface, steel_contact_law

    d = WHEEL_SURFACE_DEFAULTS
    surface = RoughSurface.synthetic(ra_um=1.5, hurst=d["hurst"], rolloff_wavelength_um=d["rolloff_wavelength_um"],
                                     size_um=d["size_um"], n=d["n"], seed=0)
    samples = np.full(50, 2800.0)
    smooth = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3])
    rough = correction_curves([(HS_EDGE, samples, 1.0)], [-4.0], [50e3], no_film_law=steel_contact_law(surface))
    assert 1.03 < rough.area_no_film_mm2[0, 0] / smooth.area_no_film_mm2[0, 0] < 1.3
    assert rough.area_film_median_mm2[0, 0] == pytest.approx(smooth.area_film_median_mm2[0, 0], rel=1e-9)
    assert rough.ratio_median[0, 0] > smooth.ratio_median[0, 0]


def test_curve_rows_label_rough_bodies_by_their_measured_ra():
    from filmcal.contact.rough_imprint import representative_roughness_inputs
    from filmcal.correction.curves import wheel_label

    bodies = representative_roughness_inputs().bodies(None, 1.5)
    assert wheel_label(bodies) == f"rough rail Ra {bodies.rail.ra_um:.3g} um"
    assert wheel_label(1.5) == "rough Ra 1.5 um" and wheel_label(None) == "smooth"


def test_curves_refuses_an_ra_and_a_map_for_one_body(tmp_path):
    import subprocess
    import sys

    (tmp_path / "st").mkdir()
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "curves", "--film", "HS", "--study-dir",
                        str(tmp_path / "st"), "--rail-roughness-ra-um", "1.5", "--rail-roughness-map",
                        str(tmp_path / "none.x3p")], capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
