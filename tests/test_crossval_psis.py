"""PSIS leave-one-case-out against exact leave-one-out posteriors computed by quadrature.

The toy problem (test function, not physics: `toymodels.ToyRadiusModel`, E and
sigma unknown, nu fixed) has two parameters, so the posterior without case i
can be computed exactly on a grid in (ln E, ln sigma): the second method. The
corrected area's mean and std follow from that posterior in closed form:
a0 = r_i - delta(E) - eps with eps ~ N(0, sigma^2), so
E[a0] = r_i - E[delta], Var[a0] = Var[delta] + E[sigma^2], E[pi a0^2] = pi (E[a0]^2 + Var[a0]).
"""
from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.special import logsumexp

from filmcal.calibration.comparison import assess_model
from filmcal.calibration.data import RadiusErrorData
from filmcal.calibration.datasets import load_table1
from filmcal.calibration.likelihood import CalibrationProblem
from filmcal.calibration.pipeline import calibrate
from filmcal.calibration.posterior import posterior_inference_data
from filmcal.correction.crossval import CaseCrossValidation, psis_leave_one_case_out
from filmcal.hertz import hertz_radius_mm
from toymodels import ToyRadiusModel

pytestmark = pytest.mark.slow  # MCMC runs (10-60 s)

with warnings.catch_warnings():
    warnings.simplefilter("ignore", FutureWarning)
    import arviz as az

MODEL = ToyRadiusModel()


def toy_data(outlier_mm: float = 0.0, seed: int = 2) -> RadiusErrorData:
    cases = load_table1("HS")
    R, F = cases.sphere_radius_mm, cases.force_n
    y = MODEL.predict(2800.0, 0.33, R, F)[0] + 0.05 * np.random.default_rng(seed).standard_normal(R.size)
    y[3] += outlier_mm
    a = hertz_radius_mm(R, F)
    return RadiusErrorData(film=np.full(R.size, "TOY"), sphere_radius_mm=R, force_n=F, radius_error_mm=y - a,
                           hertz_radius_mm=a, measured_radius_mm=y)


GRID_E = np.linspace(np.log(1200.0), np.log(8000.0), 301)
GRID_S = np.linspace(np.log(0.005), np.log(1.5), 241)


def exact_fold(data: RadiusErrorData, case: int) -> dict:
    """Posterior without `case` on the grid: its log weights, the case's elpd and the corrected-area moments."""
    keep = np.arange(len(data)) != case
    problem = CalibrationProblem(data.select(keep), MODEL)
    theta = np.stack(np.meshgrid(GRID_E, GRID_S, indexing="ij"), axis=-1).reshape(-1, 2)
    log_post = problem.log_posterior(theta)
    log_w = log_post - logsumexp(log_post)
    w = np.exp(log_w)
    E, s = np.exp(theta[:, 0]), np.exp(theta[:, 1])
    R, F, r = data.sphere_radius_mm[case], data.force_n[case], data.measured_radius_mm[case]
    mean = MODEL.predict(E, 0.33, R, F)[0]
    delta = mean - hertz_radius_mm(R, F)
    log_lik = -0.5 * ((r - mean) ** 2 / s**2 + np.log(2 * np.pi * s**2))
    m = r - np.sum(w * delta)
    v = np.sum(w * (delta - np.sum(w * delta)) ** 2) + np.sum(w * s**2)
    return {"elpd": float(logsumexp(log_w + log_lik)), "area_mm2": float(np.pi * (m**2 + v)),
            "area_std_mm2": float(2 * np.pi * m * np.sqrt(v)), "theta": theta, "weights": w}


@pytest.fixture(scope="module")
def clean():
    data = toy_data()
    result = calibrate(data, MODEL, seed=0)
    return data, CalibrationProblem(data, MODEL), result


def test_psis_folds_match_exact_leave_one_out_posteriors(clean):
    data, problem, result = clean
    cv = psis_leave_one_case_out({"toy": (problem, result.samples)}, refit=None, n_draws=4000, random_state=1)
    assert cv.method == "psis" and cv.n_refits == 0
    good = cv.pareto_k <= 0.7
    assert good.sum() >= 8  # R300/50 kN (one of two R300 cases) can be influential: flagged, not refitted
    for case in np.flatnonzero(good):
        exact = exact_fold(data, case)
        # the corrected area's mean and spread (std ~ 2-3 % of the area)
        assert cv.area_mm2[case] == pytest.approx(exact["area_mm2"], abs=0.1 * exact["area_std_mm2"])
        assert cv.area_std_mm2[case] == pytest.approx(exact["area_std_mm2"], rel=0.1)
    # the same importance weights give ArviZ's PSIS-LOO elpd of each case: compare with quadrature
    idata = posterior_inference_data(problem, result.samples, "toy")
    assessment = assess_model(problem, idata)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the high-k case is checked through cv.pareto_k
        loo_i = az.loo(idata, pointwise=True, var_name="case").loo_i.values
    exact_i = np.array([exact_fold(data, c)["elpd"] for c in range(len(data))])
    np.testing.assert_allclose(loo_i[good], exact_i[good], atol=0.05)
    np.testing.assert_allclose(assessment.pareto_k, cv.pareto_k, atol=0.05)
    assert assessment.elpd_loo == pytest.approx(exact_i.sum(), abs=0.3)
    # JSON round trip keeps the PSIS fields
    back = CaseCrossValidation.from_dict(cv.to_dict())
    np.testing.assert_array_equal(back.refit, cv.refit)
    np.testing.assert_allclose(back.pareto_k, cv.pareto_k)
    assert back.method == "psis" and back.hits == cv.hits


def test_weighted_models_pool_their_corrections(clean):
    data, problem, result = clean
    single = psis_leave_one_case_out({"A": (problem, result.samples)}, random_state=5, n_draws=1000)
    # a model of weight 0 contributes nothing: the same draws, the same answer
    pinned = psis_leave_one_case_out({"A": (problem, result.samples), "B": (problem, result.samples)},
                                     {"A": 1.0, "B": 0.0}, random_state=5, n_draws=1000)
    np.testing.assert_array_equal(pinned.area_mm2, single.area_mm2)
    np.testing.assert_array_equal(pinned.area_ci90_mm2, single.area_ci90_mm2)
    # two copies of one posterior, half each: the same distribution within Monte Carlo error
    halves = psis_leave_one_case_out({"A": (problem, result.samples), "B": (problem, result.samples)},
                                     {"A": 0.5, "B": 0.5}, random_state=6, n_draws=1000)
    # (two independent runs of 1000 draws: the means differ by ~0.045 std; allow 0.2 std per case)
    assert np.all(np.abs(halves.area_mm2 - single.area_mm2) < 0.2 * single.area_std_mm2)
    with pytest.raises(ValueError, match="same models"):
        psis_leave_one_case_out({"A": (problem, result.samples)}, {"B": 1.0})


def test_only_high_k_folds_are_refitted_exactly():
    data = toy_data(outlier_mm=1.0)
    problem = CalibrationProblem(data, MODEL)
    result = calibrate(data, MODEL, seed=0)
    calls = []

    def refit(name, fold_data):
        # exact refit by quadrature: draw from the grid posterior of the other cases
        left_out = int(np.flatnonzero(~np.isin(data.measured_radius_mm, fold_data.measured_radius_mm))[0])
        calls.append(left_out)
        exact = exact_fold(data, left_out)
        take = np.random.default_rng(left_out).choice(exact["theta"].shape[0], 4000, p=exact["weights"])
        return exact["theta"][take][None]

    cv = psis_leave_one_case_out({"toy": (problem, result.samples)}, refit=refit, n_draws=4000, random_state=1)
    high = np.flatnonzero(cv.pareto_k > 0.7)
    assert 3 in high  # the outlier case
    assert sorted(calls) == sorted(high.tolist()) and cv.n_refits == high.size < len(data)
    np.testing.assert_array_equal(np.flatnonzero(cv.refit), high)
    exact = exact_fold(data, 3)
    assert cv.area_mm2[3] == pytest.approx(exact["area_mm2"], abs=0.1 * exact["area_std_mm2"])
    # the outlier's Hertz area is far outside the band; the refit does not hide it
    assert not cv.inside[3]


def _grid_refit(data: RadiusErrorData, name: str, fold_data: RadiusErrorData) -> np.ndarray:
    """The exact refit of `test_only_high_k_folds_are_refitted_exactly`, picklable (for worker processes)."""
    left_out = int(np.flatnonzero(~np.isin(data.measured_radius_mm, fold_data.measured_radius_mm))[0])
    exact = exact_fold(data, left_out)
    take = np.random.default_rng(left_out).choice(exact["theta"].shape[0], 4000, p=exact["weights"])
    return exact["theta"][take][None]


def test_refits_run_in_worker_processes_give_the_folds_of_refits_run_here():
    from functools import partial

    data = toy_data(outlier_mm=1.0)
    problem = CalibrationProblem(data, MODEL)
    result = calibrate(data, MODEL, seed=0)
    refit = partial(_grid_refit, data)
    here = psis_leave_one_case_out({"toy": (problem, result.samples)}, refit=refit, n_draws=2000, random_state=1)
    pooled = psis_leave_one_case_out({"toy": (problem, result.samples)}, refit=refit, n_draws=2000, random_state=1,
                                     workers=2)
    assert here.n_refits >= 1
    for name in ("area_mm2", "area_std_mm2", "area_ci90_mm2", "pareto_k", "refit", "modulus_median_mpa"):
        np.testing.assert_array_equal(getattr(pooled, name), getattr(here, name))
