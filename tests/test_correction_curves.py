"""Posterior correction curves against direct wheel-rail solves."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.correction import correction_curves
from filmcal.wheelrail import FilmLayer, solve_wheel_rail


def test_bands_match_direct_solves_at_their_quantiles():
    rng = np.random.default_rng(1)
    samples = np.exp(rng.normal(np.log(2800.0), 0.04, 3000))
    c = correction_curves(samples, [-4.0], [50e3])
    a0 = solve_wheel_rail(-4.0, 50e3).area_mm2
    assert c.area_no_film_mm2[0, 0] == pytest.approx(a0, rel=1e-12)
    # the film area is monotone in E: the band's ends are the film areas at the 95 % / 5 % quantiles of E
    for q, k in ((0.05, 1), (0.95, 0)):
        direct = solve_wheel_rail(-4.0, 50e3, film=FilmLayer(float(np.quantile(samples, q)), 0.33, 0.09)).area_mm2
        assert c.delta_area_ci90_mm2[0, 0, k] == pytest.approx(direct - a0, rel=2e-3)
    assert c.ratio_ci90[0, 0, 0] < c.ratio_median[0, 0] < c.ratio_ci90[0, 0, 1] < 1.0
    assert c.interpolation_error_rel[0, 0] < 1e-3


def test_bad_samples():
    with pytest.raises(ValueError, match="modulus_samples_mpa"):
        correction_curves([2800.0, -1.0], [-4.0], [50e3])
