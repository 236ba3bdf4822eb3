"""A radius model tabulated at the data's cases, against the function it tabulates."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.calibration.tabulated import TabulatedRadiusModel
from toymodels import ToyRadiusModel


def toy(E, nu, R, F):
    return float(ToyRadiusModel().predict(E, nu, R, F)[0])


CASES = [(350.0, 40e3), (500.0, 90e3)]


def test_spline_in_ln_e_reproduces_a_smooth_model_between_its_nodes():
    model = TabulatedRadiusModel.from_function(toy, CASES, np.geomspace(1000, 8000, 7), 0.33, std_mm=0.001)
    E = np.array([1100.0, 2600.0, 7000.0, 2600.0])
    R = np.array([350.0, 350.0, 500.0, 500.0])
    F = np.array([40e3, 40e3, 90e3, 90e3])
    mean, std = model.predict(E, 0.33, R, F)
    exact = ToyRadiusModel().predict(E, 0.33, R, F)[0]
    np.testing.assert_allclose(mean, exact, atol=2e-3)
    assert np.all(std == 0.001)
    assert model.max_error_mm(toy, [1500.0, 3000.0, 6000.0]) < 2e-3
    # the error estimate is honest: a coarser table has a larger one
    coarse = TabulatedRadiusModel.from_function(toy, CASES, np.geomspace(1000, 8000, 4), 0.33)
    assert coarse.max_error_mm(toy, [1500.0, 3000.0, 6000.0]) > model.max_error_mm(toy, [1500.0, 3000.0, 6000.0])
    assert np.isnan(model.predict(12000.0, 0.33, 350.0, 40e3)[0])


def test_refuses_other_cases_other_nu_and_bad_tables():
    model = TabulatedRadiusModel.from_function(toy, CASES, [1000, 2000, 4000, 8000], 0.33)
    with pytest.raises(ValueError, match="no table for sphere_radius_mm=450"):
        model.predict(2000.0, 0.33, 450.0, 40e3)
    with pytest.raises(ValueError, match="poisson must be 0.33"):
        model.predict(2000.0, 0.3, 350.0, 40e3)
    with pytest.raises(ValueError, match="increasing"):
        TabulatedRadiusModel(CASES, [1000, 900, 4000, 8000], np.ones((2, 4)), 0.33)
    with pytest.raises(ValueError, match="non-finite"):
        TabulatedRadiusModel(CASES, [1000, 2000, 4000, 8000], np.full((2, 4), np.nan), 0.33)
