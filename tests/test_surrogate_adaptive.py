"""Adaptive refinement: candidate sampling, kriging-believer batches, the refine loop.

Data come from a smooth positive *test function* of two inputs (not physics).
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.distance import pdist
from sklearn.gaussian_process import GaussianProcessRegressor

from filmcal.surrogate import GPSurrogate, refine, sample_candidates, select_batch, validate, weighted_std

BOUNDS = {"modulus_mpa": (50.0, 20000.0), "force_n": (1e4, 1.5e5)}
LOG = ("modulus_mpa",)


def smooth_test_function(points: dict[str, np.ndarray]) -> np.ndarray:
    """Smooth, positive, decreasing in log modulus (a test function, not physics)."""
    u = np.log(points["modulus_mpa"] / 50.0) / np.log(400.0)
    v = points["force_n"] / 1.5e5
    return (1.0 + 2.0 * np.exp(-2.5 * u)) * (1.0 + 0.5 * np.sin(2.0 * v))


def surrogate() -> GPSurrogate:
    return GPSurrogate(("modulus_mpa", "force_n"), "excess_mm", log_inputs=LOG, output_transform="log",
                       input_bounds=BOUNDS, n_restarts=1, random_state=0)


def fitted_on_left_half(n: int = 12) -> GPSurrogate:
    """A surrogate trained only on moduli below ~1000 MPa (log-centre of the domain)."""
    points = sample_candidates({"modulus_mpa": (50.0, 1000.0), "force_n": BOUNDS["force_n"]}, n,
                               log_inputs=LOG, random_state=1)
    return surrogate().fit(points, smooth_test_function(points))


def test_sample_candidates_cover_the_box_in_log_scale():
    points = sample_candidates(BOUNDS, 1000, log_inputs=LOG, random_state=0)
    E, F = points["modulus_mpa"], points["force_n"]
    assert E.min() >= 50 and E.max() <= 20000 and F.min() >= 1e4 and F.max() <= 1.5e5
    # log-uniform: half of the points below the geometric mean (1000 MPa)
    assert np.mean(E < 1000.0) == pytest.approx(0.5, abs=0.01)
    again = sample_candidates(BOUNDS, 1000, log_inputs=LOG, random_state=0)
    np.testing.assert_array_equal(again["force_n"], F)


@pytest.mark.parametrize("bounds", [{"a": (1.0, 0.0)}, {"a": (0.0, np.inf)}, {"a": (-1.0, 1.0)}])
def test_sample_candidates_rejects_bad_bounds(bounds):
    with pytest.raises(ValueError):
        sample_candidates(bounds, 10, log_inputs=("a",))


def test_batch_goes_where_there_are_no_data():
    model = fitted_on_left_half()
    candidates = sample_candidates(BOUNDS, 800, log_inputs=LOG, random_state=2)
    batch = select_batch(model, candidates, 5)
    assert batch.indices.size == 5 and len(set(batch.indices.tolist())) == 5
    assert np.all(batch.points["modulus_mpa"] > 1000.0)
    assert batch.max_score == pytest.approx(np.max(weighted_std(model, candidates)))
    assert np.all(np.diff(batch.scores) <= 1e-12)  # each pick lowers the remaining uncertainty


def test_believer_update_equals_refit_with_the_picked_point():
    """The rank-one variance update equals a GP conditioned on the data plus the first pick."""
    model = fitted_on_left_half()
    candidates = sample_candidates(BOUNDS, 400, log_inputs=LOG, random_state=3)
    batch = select_batch(model, candidates, 2, relative=False)
    X = np.column_stack([candidates[n] for n in model.input_names_])
    T = model.input_transform_.transform(X)
    first = batch.indices[0]
    T_aug = np.vstack([model.X_gp_, T[first]])
    gp = GaussianProcessRegressor(kernel=model.kernel_, alpha=0.0, optimizer=None).fit(T_aug, np.zeros(len(T_aug)))
    _, noisy_std = gp.predict(T, return_std=True)
    latent_std = np.sqrt(np.maximum(noisy_std**2 - model.noise_variance_, 0.0))
    mean = model.predict_gp(T)[0]
    score = model.output_transform_.derivative(mean) * latent_std
    score[first] = -np.inf
    assert batch.indices[1] == np.argmax(score)
    assert batch.scores[1] == pytest.approx(np.max(score), rel=1e-6)


def test_believer_batch_is_more_spread_than_the_top_stds():
    model = fitted_on_left_half()
    candidates = sample_candidates(BOUNDS, 800, log_inputs=LOG, random_state=4)
    batch = select_batch(model, candidates, 6)
    top = np.argsort(weighted_std(model, candidates))[-6:]
    T = model.input_transform_.transform(np.column_stack([candidates[n] for n in model.input_names_]))
    assert pdist(T[batch.indices]).min() > 2.0 * pdist(T[top]).min()


def test_weight_keeps_the_batch_in_the_region_that_matters():
    model = fitted_on_left_half()
    candidates = sample_candidates(BOUNDS, 800, log_inputs=LOG, random_state=5)

    def low_forces_only(points):
        return (points["force_n"] < 5e4).astype(float)

    batch = select_batch(model, candidates, 4, weight=low_forces_only)
    assert np.all(batch.points["force_n"] < 5e4)
    none = select_batch(model, candidates, 4, weight=lambda p: np.zeros_like(p["force_n"]))
    assert none.indices.size == 0
    with pytest.raises(ValueError, match="weight"):
        select_batch(model, candidates, 4, weight=lambda p: -np.ones_like(p["force_n"]))


def test_refine_reaches_the_target_and_improves_accuracy():
    start = sample_candidates(BOUNDS, 10, log_inputs=LOG, random_state=6)
    calls = []

    def evaluate(points):
        calls.append(len(points["force_n"]))
        return smooth_test_function(points)

    result = refine(surrogate(), start, smooth_test_function(start), evaluate, BOUNDS, target=0.002,
                    max_evaluations=60, batch_size=6, n_candidates=500, random_state=0)
    assert result.converged
    assert result.steps[-1].max_score <= 0.002 < result.steps[0].max_score
    assert result.n_evaluations == sum(calls) <= 60
    assert result.surrogate.y_train_.size == 10 + result.n_evaluations
    test = sample_candidates(BOUNDS, 300, log_inputs=LOG, random_state=7)
    before = validate(surrogate().fit(start, smooth_test_function(start)), test, smooth_test_function(test))
    after = validate(result.surrogate, test, smooth_test_function(test))
    assert after.max_relative_error < 0.01 < before.max_relative_error


def test_refine_stops_at_the_budget_and_drops_failed_runs():
    start = sample_candidates(BOUNDS, 8, log_inputs=LOG, random_state=8)
    steps = []

    def flaky(points):
        y = smooth_test_function(points)
        y[::3] = np.nan  # a failed model run is a recorded outcome, not a crash
        return y

    result = refine(surrogate(), start, smooth_test_function(start), flaky, BOUNDS, target=1e-9,
                    max_evaluations=10, batch_size=4, n_candidates=300, random_state=0, callback=steps.append)
    assert not result.converged
    assert result.n_evaluations == 10 and [s.n_new for s in result.steps] == [4, 4, 2, 0]
    assert result.n_failed == sum(s.n_failed for s in result.steps) == 2 + 2 + 1
    assert result.y.size == 8 + 10 - 5 and np.all(np.isfinite(result.y))
    assert steps == list(result.steps)


def test_refine_rejects_bad_evaluate_and_domain():
    start = sample_candidates(BOUNDS, 8, log_inputs=LOG, random_state=9)
    y = smooth_test_function(start)
    with pytest.raises(ValueError, match="shape"):
        refine(surrogate(), start, y, lambda p: np.ones(2), BOUNDS, max_evaluations=4, n_candidates=50)
    with pytest.raises(ValueError, match="domain"):
        refine(surrogate(), start, y, smooth_test_function, {"modulus_mpa": (50.0, 2e4)}, n_candidates=50)
    with pytest.raises(ValueError, match="target"):
        refine(surrogate(), start, y, smooth_test_function, BOUNDS, target=0.0)
