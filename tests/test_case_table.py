"""`CaseTable`: a radius model at the data's cases, splined in ln E, against the model itself."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.calibration import Priors, RadiusErrorData, calibrate
from filmcal.calibration.likelihood import CalibrationProblem
from filmcal.calibration.sampling import SamplerSettings
from filmcal.hertz import hertz_radius_mm
from filmcal.surrogate.radius import CaseTable
from toymodels import ToyRadiusModel

CASES = [(300.0, 25e3), (450.0, 50e3), (600.0, 100e3)]


class ToyWithStd(ToyRadiusModel):
    """The toy radius with a smooth std that varies with E, counting the points it is asked for."""

    def __init__(self):
        self.calls = 0

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        mean, _ = super().predict(modulus_mpa, poisson, sphere_radius_mm, force_n)
        self.calls += np.size(mean)
        return mean, 0.01 + 0.002 * np.log(np.asarray(modulus_mpa, dtype=float) / 100.0)

    def restricted_to(self, cases, poisson, modulus_range_mpa):
        return CaseTable(self, cases, poisson, modulus_range_mpa)


def test_table_matches_the_model_between_its_nodes():
    model = ToyWithStd()
    table = CaseTable(model, CASES, 0.33, (400.0, 20000.0), tol_mm=1e-6)
    assert table.max_error_mm <= 1e-6
    rng = np.random.default_rng(1)
    E = np.exp(rng.uniform(np.log(400.0), np.log(20000.0), 500))
    R, F = (np.array([CASES[i][k] for i in rng.integers(0, 3, 500)]) for k in (0, 1))
    got = table.predict(E, 0.33, R, F)
    want = model.predict(E, 0.33, R, F)
    np.testing.assert_allclose(got[0], want[0], atol=2e-6)
    np.testing.assert_allclose(got[1], want[1], atol=2e-6)


def test_points_off_the_table_go_to_the_model():
    model = ToyWithStd()
    table = CaseTable(model, CASES, 0.33, (400.0, 20000.0))
    E = np.array([1000.0, 1000.0, 100.0, 1000.0])
    nu = np.array([0.33, 0.30, 0.33, 0.33])
    R = np.array([450.0, 450.0, 450.0, 500.0])  # another nu, below the table, another sphere
    F = np.array([50e3, 50e3, 50e3, 50e3])
    calls = model.calls
    got = table.predict(E, nu, R, F)
    assert model.calls - calls == 3  # only the three off-table points reach the model
    np.testing.assert_allclose(got[0], model.predict(E, nu, R, F)[0], rtol=1e-9, atol=1e-7)


def test_bad_range_is_refused():
    with pytest.raises(ValueError):
        CaseTable(ToyWithStd(), CASES, 0.33, (2000.0, 400.0))


def test_calibration_samples_the_table_and_agrees_with_the_model():
    """Same data and seed: the posterior through the table equals the one through the model itself."""
    model = ToyWithStd()
    R = np.array([c[0] for c in CASES] * 3)
    F = np.array([c[1] for c in CASES] * 3)
    truth, _ = model.predict(2800.0, 0.33, R, F)
    noise = np.random.default_rng(3).normal(0.0, 0.05, R.size)
    y = truth + noise
    a = hertz_radius_mm(R, F)
    data = RadiusErrorData(film=np.full(R.size, "SYN"), sphere_radius_mm=R, force_n=F, radius_error_mm=y - a,
                           hertz_radius_mm=a, measured_radius_mm=y)
    priors = Priors(modulus_range_mpa=(400.0, 20000.0))
    assert isinstance(CalibrationProblem(data, model, priors)._predictor, CaseTable)
    settings = SamplerSettings(max_steps=1000, check_every=500, min_ess=100)
    fast = calibrate(data, model, priors=priors, seed=4, settings=settings)
    direct = calibrate(data, _NoTable(model), priors=priors, seed=4, settings=settings)
    assert fast.modulus_mpa["median"] == pytest.approx(direct.modulus_mpa["median"], rel=2e-3)
    assert fast.modulus_mpa["ci90"] == pytest.approx(direct.modulus_mpa["ci90"], rel=5e-3)


class _NoTable:
    """A model without ``restricted_to``: the calibration calls it directly."""

    def __init__(self, model):
        self.model = model

    def predict(self, *args):
        return self.model.predict(*args)


def test_predict_cases_is_predict_at_the_data_rows():
    """The sampler's path (splines evaluated once per modulus) gives predict's numbers exactly, also where the
    table passes points to the model (a modulus off the table, another nu)."""
    model = ToyWithStd()
    table = CaseTable(model, CASES, 0.33, (400.0, 20000.0))
    rows = np.array([2, 0, 0, 1, 2])  # the data's rows as table cases, repeats included
    R, F = (np.array([CASES[i][j] for i in rows]) for j in (0, 1))
    np.testing.assert_array_equal(table.case_index(R, F), rows)
    assert table.case_index(np.array([451.0]), np.array([50e3])).tolist() == [-1]
    for E, nu in [(np.array([450.0, 2800.0, 19000.0]), 0.33), (np.array([300.0, 2800.0]), 0.33),
                  (np.array([2800.0, 5000.0]), 0.30)]:
        k, n = E.size, rows.size
        want = table.predict(np.repeat(E, n), np.full(k * n, nu), np.tile(R, k), np.tile(F, k))
        got = table.predict_cases(E, np.full(k, nu), rows)
        np.testing.assert_array_equal(got[0], want[0].reshape(k, n))
        np.testing.assert_array_equal(got[1], want[1].reshape(k, n))
    with pytest.raises(ValueError, match="case indices"):
        table.predict_cases(np.array([2800.0]), np.array([0.33]), np.array([0, -1]))
