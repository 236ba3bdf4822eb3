"""The likelihood with repeats, stated measurement uncertainty and a case-level scatter.

Checked against a second method: the dense multivariate normal density of
each case (scipy), with covariance diag(sigma^2 + u^2) + (s^2 + tau^2) 1 1^T
written out in full.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from filmcal.calibration.data import RadiusErrorData
from filmcal.calibration.likelihood import CalibrationProblem, Priors
from filmcal.films import FilmType
from filmcal.hertz import hertz_radius_mm
from toymodels import ToyRadiusModel


class NoisyToy:
    """Test function: ToyRadiusModel with a predictive std that depends on the case."""

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        mean, _ = ToyRadiusModel().predict(modulus_mpa, poisson, sphere_radius_mm, force_n)
        return mean, 0.01 + 0.02 * (np.asarray(force_n, dtype=float) / 1e5) * np.ones(mean.shape)


def repeated_data(seed: int = 0) -> RadiusErrorData:
    """Three cases with 3, 1 and 2 imprints, rows interleaved, each with its own measurement std."""
    R = np.array([450.0, 600.0, 450.0, 300.0, 600.0, 450.0])
    F = np.array([75e3, 50e3, 75e3, 25e3, 50e3, 75e3])
    rng = np.random.default_rng(seed)
    y = ToyRadiusModel().predict(2800.0, 0.33, R, F)[0] + 0.05 * rng.standard_normal(R.size)
    a = hertz_radius_mm(R, F)
    return RadiusErrorData(film=np.full(R.size, "LOT7"), sphere_radius_mm=R, force_n=F, radius_error_mm=y - a,
                           hertz_radius_mm=a, measured_radius_mm=y,
                           measurement_std_mm=np.array([0.01, 0.0, 0.03, 0.02, 0.0, 0.05]))


def dense_case_log_likelihood(problem: CalibrationProblem, theta: np.ndarray) -> np.ndarray:
    p = problem.unpack(theta[None])
    mean, std = problem.model.predict(p["modulus_mpa"][0], p["poisson"][0], problem.data.sphere_radius_mm,
                                      problem.data.force_n)
    out = []
    for case in range(problem.n_cases):
        rows = np.flatnonzero(problem.case_index == case)
        shared = std[rows[0]] ** 2 + p["case_sigma_mm"][0] ** 2
        cov = np.diag(p["sigma_mm"][0] ** 2 + problem.data.measurement_std_mm[rows] ** 2) + shared
        out.append(multivariate_normal(mean[rows], cov).logpdf(problem.data.measured_radius_mm[rows]))
    return np.array(out)


def test_cases_and_repeats_are_numbered():
    data = repeated_data()
    np.testing.assert_array_equal(data.case_index, [0, 1, 0, 2, 1, 0])
    np.testing.assert_array_equal(data.repeat, [1, 1, 2, 1, 2, 3])
    assert data.n_cases == 3 and data.has_repeats


@pytest.mark.parametrize("case_scatter", ["case", "none"])
def test_case_likelihood_equals_the_dense_multivariate_normal(case_scatter):
    problem = CalibrationProblem(repeated_data(), NoisyToy(), case_scatter=case_scatter)
    assert problem.case_scatter == (case_scatter == "case")
    rng = np.random.default_rng(4)
    for _ in range(5):
        theta = [np.log(rng.uniform(1500, 5000)), np.log(rng.uniform(0.02, 0.2))]
        if problem.case_scatter:
            theta.append(np.log(rng.uniform(0.01, 0.3)))
        theta = np.array(theta)
        np.testing.assert_allclose(problem.case_log_likelihood(theta[None])[0],
                                   dense_case_log_likelihood(problem, theta), rtol=1e-10)
        np.testing.assert_allclose(problem.log_likelihood(theta[None])[0],
                                   dense_case_log_likelihood(problem, theta).sum(), rtol=1e-10)


def test_case_scatter_is_added_only_when_identified():
    data = repeated_data()
    assert CalibrationProblem(data, ToyRadiusModel()).parameter_names == ["log_modulus", "log_sigma",
                                                                         "log_case_sigma"]
    single = data.select(np.array([True, True, False, True, False, False]))
    assert not single.has_repeats
    assert CalibrationProblem(single, ToyRadiusModel()).parameter_names == ["log_modulus", "log_sigma"]
    with pytest.raises(ValueError, match="case_scatter"):
        CalibrationProblem(data, ToyRadiusModel(), case_scatter="always")


def test_without_repeats_rows_are_independent_with_all_variances_added():
    data = repeated_data().select(np.array([True, True, False, True, False, False]))
    problem = CalibrationProblem(data, NoisyToy())
    theta = np.array([np.log(2500.0), np.log(0.07)])
    mean, std = NoisyToy().predict(2500.0, 0.33, data.sphere_radius_mm, data.force_n)
    var = 0.07**2 + data.measurement_std_mm**2 + std**2
    expected = -0.5 * ((data.measured_radius_mm - mean) ** 2 / var + np.log(2 * np.pi * var))
    np.testing.assert_allclose(problem.pointwise_log_likelihood(theta[None])[0], expected, rtol=1e-12)


def test_theta_round_trips_through_named_samples():
    problem = CalibrationProblem(repeated_data(), ToyRadiusModel(), poisson="free", discrepancy="load")
    theta = np.random.default_rng(0).normal(size=(4, 7, problem.ndim))
    theta[..., problem.parameter_names.index("poisson")] = 0.3
    np.testing.assert_allclose(problem.theta_from_named(problem.named_samples(theta)), theta, rtol=1e-12)


def test_film_type_sets_nu_and_must_match_the_data():
    lot = FilmType("LOT7", activation_pressure_mpa=45.0, thickness_mm=0.1, poisson=0.36)
    problem = CalibrationProblem(repeated_data(), ToyRadiusModel(), film=lot)
    assert problem.priors.poisson == 0.36
    assert Priors.for_film(lot).poisson == 0.36
    with pytest.raises(ValueError, match="besides HS"):
        CalibrationProblem(repeated_data(), ToyRadiusModel(), film=FilmType("HS", activation_pressure_mpa=50.0))


def test_priors_round_trip_and_table1_configuration_is_unchanged():
    priors = Priors(case_scale_mm=0.05, poisson=0.35)
    assert Priors.from_dict(priors.to_dict()) == priors
    old_style = priors.to_dict()
    old_style.pop("case_sigma_mm")  # a result saved before the case-level scatter existed
    assert Priors.from_dict(old_style).case_scale_mm == Priors().case_scale_mm
    # Table 1 (one imprint per case, steel, nothing stated): the stored chain configuration keeps its keys,
    # so chains stored before the dataset extensions still match and resume
    from filmcal.calibration.datasets import load_table1

    described = CalibrationProblem(load_table1("HS"), ToyRadiusModel()).describe()
    assert set(described) == {"film", "sphere_radius_mm", "force_n", "measured_radius_mm", "poisson",
                              "discrepancy", "priors", "parameter_names"}
    assert "case_sigma_mm" not in described["priors"]
    np.testing.assert_array_equal(described["measured_radius_mm"], load_table1("HS").measured_radius_mm)
    with_repeats = CalibrationProblem(repeated_data(), ToyRadiusModel()).describe()
    assert with_repeats["case_index"] == [0, 1, 0, 2, 1, 0]
    assert with_repeats["measurement_std_mm"][2] == 0.03
