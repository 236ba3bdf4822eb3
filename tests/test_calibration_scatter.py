"""A scatter beyond any film's is said, never reported as a confident modulus alone."""
from __future__ import annotations

import warnings

import pytest

from filmcal.calibration.pipeline import SCATTER_BEYOND_FILMS_MM, ScatterWarning, calibrate, scatter_warning
from filmcal.calibration.sampling import SamplerSettings
from test_calibration_mcmc import synthetic
from toymodels import ToyRadiusModel

SHORT = SamplerSettings(check_every=400, max_steps=800)


def test_a_scatter_of_a_millimetre_is_warned_and_noted():
    data = synthetic(2, sigma=1.0, seed=3)  # radii scattered by 1 mm: no film's imprints scatter so
    with pytest.warns(ScatterWarning, match="beyond any film's"):
        result = calibrate(data, ToyRadiusModel(), seed=0, settings=SHORT)
    assert result.sigma_mm["median"] > SCATTER_BEYOND_FILMS_MM  # the sampler found it (the truth is 1 mm)
    assert any("beyond any film's" in note for note in result.notes)  # the report prints the notes


def test_a_film_like_scatter_is_not_warned():
    data = synthetic(2, sigma=0.1, seed=3)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ScatterWarning)
        result = calibrate(data, ToyRadiusModel(), seed=0, settings=SHORT)
    assert result.sigma_mm["median"] < SCATTER_BEYOND_FILMS_MM
    assert not any("beyond any film's" in note for note in result.notes)


def test_the_limit_is_where_the_warning_starts():
    assert scatter_warning(SCATTER_BEYOND_FILMS_MM, 20) is None
    assert "0.6 mm" in scatter_warning(0.6, 20) and "20 measured radii" in scatter_warning(0.6, 20)
