"""Least-squares inversion of the film modulus against an exactly invertible test model."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.calibration import load_table1
from filmcal.calibration.inversion import least_squares_modulus


class PowerLawModel:
    """Test function (not physics): radius = a_H + c (E0/E)^0.5, so the E that fits one case is analytic."""

    def __init__(self, c_mm: float = 1.0, e0_mpa: float = 2800.0) -> None:
        self.c, self.e0 = c_mm, e0_mpa

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        from filmcal.fem import hertz_radius_mm
        e, r, f = np.broadcast_arrays(np.asarray(modulus_mpa, float), sphere_radius_mm, force_n)
        return hertz_radius_mm(r, f) + self.c * np.sqrt(self.e0 / e), np.zeros(e.shape)


def test_recovers_the_least_squares_modulus():
    data = load_table1("HS", "50-100")
    fit = least_squares_modulus("HS", PowerLawModel(), "50-100")
    # all cases share a_H + c sqrt(E0/E): least squares matches the mean error exactly
    mean_error = np.mean(data.radius_error_mm)
    expected = 2800.0 / mean_error**2
    assert fit.modulus_mpa == pytest.approx(expected, rel=1e-3)
    assert fit.rms_residual_mm == pytest.approx(np.std(data.radius_error_mm), rel=1e-3)


def test_bad_film_is_a_value_error():
    with pytest.raises(ValueError):
        least_squares_modulus("XYZ", PowerLawModel())
