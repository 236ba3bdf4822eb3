"""Model comparison on toy radius models whose truth is known (test functions, not physics).

Data are drawn from model A (``toymodels.ToyRadiusModel``) with Gaussian
scatter. Model B has the wrong dependence on R and F (a film excess that
ignores the contact pressure) and must lose all weight. Model A2 scales A's
film excess by 1.1: after calibration it predicts the same radii with an E
1.21 times larger, so the data cannot tell A and A2 apart; they must share
the weight, and the combined posterior of E must span both models' answers.
"""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.calibration.comparison import combine_posteriors, compare_models
from filmcal.calibration.data import RadiusErrorData
from filmcal.calibration.datasets import load_table1
from filmcal.calibration.likelihood import CalibrationProblem
from filmcal.calibration.pipeline import calibrate
from filmcal.calibration.posterior import (load_posterior_netcdf, posterior_inference_data,
                                           save_posterior_netcdf)
from filmcal.calibration.sampling import SamplerSettings
from filmcal.elastic import oedometric_ratio
from filmcal.hertz import hertz_radius_mm
from toymodels import ToyRadiusModel

pytestmark = pytest.mark.slow  # MCMC runs (10-60 s)

E_TRUE, SIGMA_TRUE = 2800.0, 0.03
FAST = SamplerSettings(check_every=200, min_ess=400)


class ScaledExcess:
    """Test function: Hertz radius + `factor` times the film excess of ToyRadiusModel."""

    def __init__(self, factor: float) -> None:
        self.factor = factor

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        E, nu, R, F = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in
                                            (modulus_mpa, poisson, sphere_radius_mm, force_n)))
        mean, std = ToyRadiusModel().predict(E, nu, R, F)
        a = hertz_radius_mm(R, F)
        return a + self.factor * (mean - a), std


class PressureBlind:
    """Test function: Hertz radius + an excess that depends on the film only (wrong in R and F)."""

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        E, nu, R, F = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in
                                            (modulus_mpa, poisson, sphere_radius_mm, force_n)))
        return hertz_radius_mm(R, F) + 2.2 * np.sqrt(60.0 / (E * oedometric_ratio(nu))), np.zeros(E.shape)


def synthetic(seed: int = 1) -> RadiusErrorData:
    cases = load_table1("HS")
    R, F = np.tile(cases.sphere_radius_mm, 2), np.tile(cases.force_n, 2)
    y, _ = ToyRadiusModel().predict(E_TRUE, 0.33, R, F)
    y = y + SIGMA_TRUE * np.random.default_rng(seed).standard_normal(R.size)
    a = hertz_radius_mm(R, F)
    return RadiusErrorData(film=np.full(R.size, "TOY"), sphere_radius_mm=R, force_n=F, radius_error_mm=y - a,
                           hertz_radius_mm=a, measured_radius_mm=y)


@pytest.fixture(scope="module")
def calibrated():
    data = synthetic()
    out = {}
    for name, model in (("A", ToyRadiusModel()), ("B", PressureBlind()), ("A2", ScaledExcess(1.1))):
        result = calibrate(data, model, seed=0, settings=FAST)
        problem = CalibrationProblem(data, model)
        out[name] = (problem, posterior_inference_data(problem, result.samples, name, max_draws=150), result)
    return out


def test_true_model_takes_the_weight_from_a_clearly_worse_one(calibrated):
    comparison = compare_models({k: calibrated[k][:2] for k in ("A", "B")})
    assert comparison.weights["A"] > 0.95
    assert comparison.stacking_weights["A"] > 0.95
    assert comparison.preferred == "A"
    a, b = comparison.assessments["A"], comparison.assessments["B"]
    assert a.elpd_loo - b.elpd_loo > 4.0 * comparison.table[1]["dse"] / 2
    # the true model's residuals are at the scatter the data were drawn with; B's are several times larger
    assert a.rms_residual_mm == pytest.approx(SIGMA_TRUE, rel=0.5)
    assert b.rms_residual_mm > 2.5 * a.rms_residual_mm
    assert a.n_data == 20 and a.n_cases == 10 and a.pareto_k.shape == (10,)
    assert 15 <= a.ppc_inside_90 <= 20
    assert a.modulus_mpa["ci90"][0] < E_TRUE < a.modulus_mpa["ci90"][1]
    assert comparison.table[0]["name"] == "A" and comparison.table[0]["weight"] == comparison.weights["A"]


def test_indistinguishable_models_share_the_weight_and_the_band_spans_both(calibrated):
    comparison = compare_models({k: calibrated[k][:2] for k in ("A", "A2")})
    assert comparison.weights["A"] == pytest.approx(0.5, abs=0.15)
    assert comparison.weights["A2"] == pytest.approx(0.5, abs=0.15)
    med = {k: float(np.median(calibrated[k][2].samples["modulus_mpa"])) for k in ("A", "A2")}
    # A2 needs E larger by 1.1^2 for the same radii (the excess scales as E^-1/2)
    assert med["A2"] / med["A"] == pytest.approx(1.21, rel=0.02)
    mix = combine_posteriors({k: calibrated[k][1] for k in ("A", "A2")}, comparison.weights, random_state=3)
    lo, hi = np.quantile(mix.samples["modulus_mpa"], [0.05, 0.95])
    assert lo <= med["A"] and hi >= med["A2"]
    assert hi - lo >= med["A2"] - med["A"]
    # each sample carries its model, in proportion to the weights
    assert set(mix.by_model()) == {"A", "A2"}
    share = np.mean(mix.model == "A")
    assert share == pytest.approx(comparison.weights["A"], abs=1.0 / len(mix))
    a_only = mix.by_model()["A"]["modulus_mpa"]
    assert np.all(np.isin(a_only, calibrated["A"][1].posterior["modulus_mpa"].values.ravel()))


def test_combine_is_reproducible_and_follows_the_weights(calibrated):
    posts = {k: calibrated[k][1] for k in ("A", "B")}
    one = combine_posteriors(posts, {"A": 0.25, "B": 0.75}, random_state=7, n_samples=400)
    two = combine_posteriors(posts, {"A": 0.25, "B": 0.75}, random_state=7, n_samples=400)
    np.testing.assert_array_equal(one.samples["modulus_mpa"], two.samples["modulus_mpa"])
    assert one.counts == {"A": 100, "B": 300}
    assert set(one.samples) >= {"modulus_mpa", "poisson", "sigma_mm"}
    only_a = combine_posteriors(posts, {"A": 1.0, "B": 0.0}, random_state=7)
    assert set(only_a.model.tolist()) == {"A"}
    with pytest.raises(ValueError, match="weights"):
        combine_posteriors(posts, {"A": 0.0, "B": 0.0})
    with pytest.raises(ValueError, match="same models"):
        combine_posteriors(posts, {"A": 1.0})


def test_posterior_keeps_pointwise_log_likelihood_and_round_trips_netcdf(calibrated, tmp_path):
    problem, idata, result = calibrated["A"]
    ll = idata.log_likelihood["radius"].values
    assert ll.shape == (result.n_walkers, 150, 20)
    # the terms of a draw add up to the likelihood the sampler used, case by case too
    theta = problem.theta_from_named({k: idata.posterior[k].values[:1, :3] for k in idata.posterior.data_vars
                                      if k != "poisson" or problem.poisson_mode == "free"}).reshape(-1, problem.ndim)
    np.testing.assert_allclose(ll[0, :3].sum(axis=1), problem.log_likelihood(theta), rtol=1e-12)
    np.testing.assert_allclose(idata.log_likelihood["case"].values[0, :3].sum(axis=1),
                               problem.log_likelihood(theta), rtol=1e-12)
    path = save_posterior_netcdf(idata, tmp_path / "post.nc")
    back = load_posterior_netcdf(path)
    np.testing.assert_array_equal(back.log_likelihood["radius"].values, ll)
    np.testing.assert_array_equal(back.posterior["modulus_mpa"].values, idata.posterior["modulus_mpa"].values)
    assert back.posterior.attrs["model"] == "A"
    (tmp_path / "bad.nc").write_bytes(b"not a netcdf file")
    with pytest.raises(ValueError, match="bad.nc"):
        load_posterior_netcdf(tmp_path / "bad.nc")


def test_compare_refuses_models_of_different_data(calibrated):
    problem, idata, _ = calibrated["A"]
    other = synthetic(seed=5)
    other_problem = CalibrationProblem(other, ToyRadiusModel())
    with pytest.raises(ValueError, match="other data"):
        compare_models({"A": (problem, idata), "X": (other_problem, idata)})
    with pytest.raises(ValueError, match="at least 2"):
        compare_models({"A": (problem, idata)})


def test_three_models_the_tie_shares_and_the_worse_one_stays_out(calibrated):
    comparison = compare_models({k: calibrated[k][:2] for k in ("A", "B", "A2")})
    assert comparison.weights["B"] < 0.05
    assert comparison.weights["A"] == pytest.approx(comparison.weights["A2"], abs=0.3)
    assert sum(comparison.weights.values()) == pytest.approx(1.0)
    assert sum(comparison.pseudo_bma_weights.values()) == pytest.approx(1.0)
    d = comparison.to_dict()
    assert set(d["models"]) == {"A", "B", "A2"} and d["preferred"] in ("A", "A2")


# ArviZ's compare sorts with pandas' inplace keyword, which pandas 3.1 deprecates (its warning, not ours)
@pytest.mark.filterwarnings("ignore:The inplace keyword in DataFrame.sort_values is deprecated")
def test_stacking_and_pseudo_bma_agree_with_arviz(calibrated):
    """The weights computed here from the pointwise terms against ArviZ's own `compare` (a second code)."""
    from filmcal.calibration.comparison import _quiet_arviz

    az = _quiet_arviz()
    idatas = {k: calibrated[k][1] for k in ("A", "B", "A2")}
    comparison = compare_models({k: calibrated[k][:2] for k in ("A", "B", "A2")})
    stack = az.compare(idatas, ic="loo", method="stacking", var_name="case")["weight"]
    bma = az.compare(idatas, ic="loo", method="BB-pseudo-BMA", var_name="case", seed=0)["weight"]
    for k in idatas:
        assert comparison.pseudo_bma_weights[k] == pytest.approx(float(bma[k]), abs=0.05)
        # stacking's objective is flat between A and A2: only their sum and B's weight are determined
    assert comparison.stacking_weights["B"] == pytest.approx(float(stack["B"]), abs=0.05)
    assert comparison.stacking_weights["A"] + comparison.stacking_weights["A2"] == pytest.approx(
        float(stack["A"] + stack["A2"]), abs=0.05)


def test_cases_with_a_high_pareto_k_are_refitted_exactly():
    """An outlying case makes PSIS unreliable there (k > 0.7): the comparison calibrates again without it and
    uses the exact term, log mean_s p(r_case | theta_s) over the refit's draws."""
    data = synthetic(seed=2)
    data.measured_radius_mm[0] += 0.25
    data.radius_error_mm[0] += 0.25
    models, calls = {}, []
    for name, model in (("A", ToyRadiusModel()), ("B", PressureBlind())):
        result = calibrate(data, model, seed=0, settings=FAST)
        problem = CalibrationProblem(data, model)
        models[name] = (problem, posterior_inference_data(problem, result.samples, name, max_draws=150))

    def refit(name, subset):
        calls.append((name, len(subset)))
        return calibrate(subset, models[name][0].model, seed=1, settings=FAST).samples

    comparison = compare_models(models, refit=refit)
    high = sum(a.n_pareto_k_high for a in comparison.assessments.values())
    assert high >= 1 and comparison.n_refit == high == len(calls)
    assert all(n == len(data) - 2 for _, n in calls)  # one case (two repeats) left out each time
    assert sum(row["n_refit"] for row in comparison.table) == high
