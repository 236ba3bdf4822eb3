"""GPSurrogate: accuracy, uncertainty calibration, LOO, gradients, determinism, bad input.

The data come from a smooth *test function*, not from physics: it only has the
shape of the quantity the surrogate will emulate (the film-induced excess of the
sphere-on-flat contact radius over Hertz), a made-up thin-layer expression

    excess = a_H * c * g / (1 + b * g),   g = sqrt(t * E* / (M * a_H)),

with the Hertz radius a_H(R, F) of steel on steel, the film's oedometric modulus
M(E, nu), t = 0.09 mm, c = 0.15, b = 0.2. It is smooth and monotone in log E,
depends on (E, nu) only through M, and spans ~0.1-4 mm over the ranges of
interest. Training and held-out values carry noise of 1e-3 mm, the numerical
noise level of the finite-element results.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import qmc
from sklearn.exceptions import NotFittedError
from sklearn.gaussian_process import GaussianProcessRegressor
from threadpoolctl import threadpool_limits

from filmcal.surrogate import GPSurrogate, leave_one_out, validate

NAMES = ("modulus_mpa", "poisson", "sphere_radius_mm", "force_n")
LOWER = np.array([np.log(50.0), 0.0, 200.0, 10e3])
UPPER = np.array([np.log(20000.0), 0.45, 800.0, 150e3])
NOISE_MM = 1e-3


def radius_excess_test_function(X: np.ndarray) -> np.ndarray:
    """Smooth stand-in with the shape of a radius excess (mm); not physics."""
    modulus, poisson, radius, force = X.T
    e_star = 210000.0 / (2.0 * (1.0 - 0.3**2))
    oedometric = modulus * (1 - poisson) / ((1 + poisson) * (1 - 2 * poisson))
    a_hertz = np.cbrt(3 * force * radius / (4 * e_star))
    g = np.sqrt(0.09 * e_star / (oedometric * a_hertz))
    return a_hertz * 0.15 * g / (1 + 0.2 * g)


def lhs_data(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Latin-hypercube design (log-uniform modulus) and noisy test-function values."""
    X = LOWER + qmc.LatinHypercube(4, rng=seed).random(n) * (UPPER - LOWER)
    X[:, 0] = np.exp(X[:, 0])
    y = radius_excess_test_function(X) + NOISE_MM * np.random.default_rng(seed + 1).standard_normal(n)
    return X, y


def make_surrogate(**kwargs) -> GPSurrogate:
    settings = dict(inputs=NAMES, output="radius_excess_mm", log_inputs=("modulus_mpa",),
                    output_transform="log", n_restarts=3, random_state=0)
    settings.update(kwargs)
    return GPSurrogate(**settings)


@pytest.fixture(scope="module")
def train() -> tuple[np.ndarray, np.ndarray]:
    return lhs_data(150, seed=0)


@pytest.fixture(scope="module")
def held_out() -> tuple[np.ndarray, np.ndarray]:
    return lhs_data(400, seed=10)


@pytest.fixture(scope="module")
def fitted(train) -> GPSurrogate:
    return make_surrogate().fit(*train)


def test_held_out_accuracy_and_interval_coverage(fitted, held_out):
    result = validate(fitted, *held_out)
    assert result.n == 400
    assert result.rms_relative_error < 0.02
    assert result.max_relative_error < 0.1
    assert result.q2 > 0.999
    assert 0.8 <= result.coverage90 <= 1.0


def test_standardized_output_is_accurate_too(train, held_out):
    result = validate(make_surrogate(output_transform="standardize", n_restarts=1).fit(*train), *held_out)
    assert result.rms_relative_error < 0.03
    assert 0.8 <= result.coverage90 <= 1.0


def test_small_design_of_60_points_is_usable(held_out):
    result = validate(make_surrogate(n_restarts=1).fit(*lhs_data(60, seed=3)), *held_out)
    assert result.rms_relative_error < 0.05
    assert result.coverage90 >= 0.7


def test_closed_form_loo_equals_brute_force_refits(fitted):
    """R&W eq. 5.12 against n GP refits without point i (sklearn, same fixed kernel)."""
    loo = leave_one_out(fitted)
    T, out = fitted.X_gp_, fitted.output_transform_
    z = out.transform(fitted.y_train_)
    n = z.size
    mean_bf, std_bf = np.empty(n), np.empty(n)
    with threadpool_limits(limits=1):  # small matrices: threaded BLAS only slows the loop down
        for i in range(n):
            keep = np.arange(n) != i
            gp = GaussianProcessRegressor(kernel=fitted.kernel_, alpha=0.0, optimizer=None).fit(T[keep], z[keep])
            m, s = gp.predict(T[i:i + 1], return_std=True)  # std includes the white noise, as in eq. 5.12
            mean_bf[i], std_bf[i] = m[0], s[0]
    # GP coordinates (standardised log output, values of order 1): agreement to 1e-8
    mean_cf = out.transform(loo.mean)
    np.testing.assert_allclose(mean_cf, mean_bf, rtol=0, atol=1e-8)
    np.testing.assert_allclose(loo.std / out.derivative(mean_cf), std_bf, rtol=0, atol=1e-8)
    np.testing.assert_allclose(loo.std, out.derivative(mean_bf) * std_bf, rtol=1e-6)
    np.testing.assert_allclose(loo.standardized_residual, (z - mean_bf) / std_bf, rtol=0, atol=1e-6)
    y = fitted.y_train_
    press = np.sum((y - out.inverse(mean_bf)) ** 2)
    assert loo.q2 == pytest.approx(1 - press / np.sum((y - y.mean()) ** 2), abs=1e-10)
    assert loo.q2 > 0.999
    assert 0.8 <= loo.coverage90 <= 1.0
    assert 0.7 < np.std(loo.standardized_residual) < 1.4


def test_std_scales_with_output_units(train):
    """Same seed, output in m instead of mm: mean and std scale by exactly 1e-3."""
    X, y = train
    mm = make_surrogate(output_transform="standardize", n_restarts=0).fit(X[:80], y[:80])
    m = make_surrogate(output_transform="standardize", n_restarts=0).fit(X[:80], 1e-3 * y[:80])
    mean_mm, std_mm = mm.predict(X[80:], return_std=True)
    mean_m, std_m = m.predict(X[80:], return_std=True)
    np.testing.assert_allclose(mean_m, 1e-3 * mean_mm, rtol=1e-6)
    np.testing.assert_allclose(std_m, 1e-3 * std_mm, rtol=1e-6)


def test_log_output_matches_standardized_fit_of_log_data(train):
    """A log-output surrogate equals a standardised surrogate of log(y) mapped by exp.

    Median exp(m), delta-method std exp(m) * s, interval exp(m -+ 1.645 s).
    """
    X, y = train
    log_model = make_surrogate(output_transform="log", n_restarts=0).fit(X[:80], y[:80])
    lin_model = make_surrogate(output_transform="standardize", n_restarts=0).fit(X[:80], np.log(y[:80]))
    median, std = log_model.predict(X[80:], return_std=True)
    m, s = lin_model.predict(X[80:], return_std=True)
    np.testing.assert_allclose(median, np.exp(m), rtol=1e-6)
    np.testing.assert_allclose(std, np.exp(m) * s, rtol=1e-5)
    lower, upper = log_model.predict_interval(X[80:], level=0.9)
    np.testing.assert_allclose(lower, np.exp(m - 1.6448536269514722 * s), rtol=1e-5)
    np.testing.assert_allclose(upper, np.exp(m + 1.6448536269514722 * s), rtol=1e-5)


def test_auto_transform_compares_densities_of_the_same_outputs(train):
    """The evidence of each transform is a density of y: in other units (y -> c y) both shift by -n log c.

    Change of variables: p(c y) = p(y) / c^n for any transform. The standardised
    z and the log's standardised z are the same for y and c y, so only the
    Jacobian moves, and the choice cannot depend on the units.
    """
    X, y = train[0][:60], train[1][:60]
    mm = make_surrogate(output_transform="auto", n_restarts=0).fit(X, y)
    m = make_surrogate(output_transform="auto", n_restarts=0).fit(X, 1e-3 * y)
    assert set(mm.log_evidence_) == {"log", "standardize"}
    for kind in mm.log_evidence_:
        assert m.log_evidence_[kind] - mm.log_evidence_[kind] == pytest.approx(-60 * np.log(1e-3), rel=1e-6)
    assert m.output_transform_.kind == mm.output_transform_.kind
    assert mm.log_evidence_[mm.output_transform_.kind] == max(mm.log_evidence_.values())


@pytest.mark.parametrize("kind", ["log", "standardize"])
def test_the_evidence_is_the_gaussian_density_of_the_physical_outputs(train, kind):
    """A second computation with scipy: y (or log y) ~ N(offset, scale^2 K) with the fitted kernel K (noise
    included), so log p(y) = logpdf(h(y)) - sum(log y) for the log (change of variables), logpdf(y) otherwise."""
    from scipy.stats import multivariate_normal

    X, y = train[0][:50], train[1][:50]
    fitted = make_surrogate(output_transform=kind, n_restarts=0).fit(X, y)
    out = fitted.output_transform_
    h = np.log(y) if kind == "log" else y
    K = fitted.kernel_(fitted.X_gp_)
    expected = multivariate_normal(np.full(y.size, out.offset), out.scale**2 * K).logpdf(h)
    if kind == "log":
        expected -= np.sum(np.log(y))
    assert fitted.log_evidence_ == {kind: pytest.approx(expected, rel=1e-9, abs=1e-6)}


@pytest.mark.parametrize("shape, expected", [("exponential", "log"), ("linear near zero", "standardize")])
def test_auto_transform_keeps_the_one_that_predicts_better(shape, expected):
    """y = exp(3 x0 + 2 x1) is linear after the log; y = 0.002 + x0 + x1 is linear as it is and
    close to zero, where a log stretches it. The evidence picks the transform under which y is
    linear, and that one also predicts held-out points better (a second, independent measure)."""
    X = qmc.LatinHypercube(2, rng=3).random(60)
    Xt = qmc.LatinHypercube(2, rng=4).random(200)

    def f(x):
        return np.exp(3 * x[:, 0] + 2 * x[:, 1]) if shape == "exponential" else 0.002 + x[:, 0] + x[:, 1]

    def surrogate(transform):
        return GPSurrogate(("a", "b"), "y", output_transform=transform, n_restarts=2, random_state=0)

    auto = surrogate("auto").fit(X, f(X))
    assert auto.output_transform_.kind == expected
    other = surrogate("standardize" if expected == "log" else "log").fit(X, f(X))
    assert np.sqrt(np.mean((auto.predict(Xt) - f(Xt)) ** 2)) < np.sqrt(np.mean((other.predict(Xt) - f(Xt)) ** 2))


def test_auto_transform_standardises_outputs_that_are_not_positive(train):
    X, y = train[0][:40], train[1][:40]
    fitted = make_surrogate(output_transform="auto", n_restarts=0).fit(X, y - np.median(y))
    assert list(fitted.log_evidence_) == ["standardize"] and fitted.output_transform_.kind == "standardize"


def test_noise_widens_the_std(fitted, held_out):
    _, latent = fitted.predict(held_out[0], return_std=True)
    _, noisy = fitted.predict(held_out[0], return_std=True, noise=True)
    assert np.all(noisy >= latent)


def test_gradient_matches_finite_differences(fitted, held_out):
    X = held_out[0][:6]
    grad = fitted.predict_gradient(X)
    assert grad.shape == (6, 4)
    for j in range(4):
        step = 1e-4 * X[:, j]
        up, down = X.copy(), X.copy()
        up[:, j] += step
        down[:, j] -= step
        fd = (fitted.predict(up) - fitted.predict(down)) / (2 * step)
        np.testing.assert_allclose(grad[:, j], fd, rtol=0, atol=1e-5 * np.max(np.abs(grad[:, j])))
    # the test function decreases with the film modulus
    assert np.all(grad[:, 0] < 0)


def test_named_columns_in_any_order_give_the_same_predictions(fitted, held_out):
    X = held_out[0][:20]
    columns = {name: X[:, j] for j, name in reversed(list(enumerate(NAMES)))}
    np.testing.assert_array_equal(fitted.predict(columns), fitted.predict(X))
    structured = np.rec.fromarrays([X[:, j] for j in range(4)], names=list(NAMES))
    np.testing.assert_array_equal(fitted.predict(structured), fitted.predict(X))


def test_input_names_default_to_mapping_keys(train):
    X, y = train
    model = GPSurrogate(n_restarts=0, random_state=0).fit({n: X[:40, j] for j, n in enumerate(NAMES)}, y[:40])
    assert model.input_names_ == list(NAMES)
    assert GPSurrogate(n_restarts=0).fit(X[:40], y[:40]).input_names_ == ["x0", "x1", "x2", "x3"]


def test_same_random_state_same_fit_serial_or_parallel(train):
    X, y = train[0][:60], train[1][:60]
    a = make_surrogate(random_state=7).fit(X, y)
    b = make_surrogate(random_state=7).fit(X, y)
    c = make_surrogate(random_state=7, n_jobs=2).fit(X, y)
    np.testing.assert_array_equal(a.kernel_.theta, b.kernel_.theta)
    np.testing.assert_array_equal(a.kernel_.theta, c.kernel_.theta)
    np.testing.assert_array_equal(a.predict(X), c.predict(X))
    assert a.log_marginal_likelihood_value_ == pytest.approx(np.max(a.restart_log_marginal_likelihoods_), abs=1e-6)


def test_fit_keeps_the_best_restart(train):
    X, y = train[0][:60], train[1][:60]
    model = make_surrogate(n_restarts=4).fit(X, y)
    assert model.restart_log_marginal_likelihoods_.shape == (5,)
    single = make_surrogate(n_restarts=0).fit(X, y)
    assert model.log_marginal_likelihood_value_ >= single.log_marginal_likelihood_value_ - 1e-6


def test_likelihood_and_gradient_are_scikit_learns(fitted):
    """The fit's own likelihood of the filmcal kernel against scikit-learn's generic kernel algebra."""
    from filmcal.surrogate.gp import _log_marginal_likelihood, _squared_differences

    T = fitted.X_gp_
    z = fitted.output_transform_.transform(fitted.y_train_)
    reference = GaussianProcessRegressor(kernel=fitted.kernel_, alpha=0.0, optimizer=None).fit(T, z)
    D2 = _squared_differences(T)
    rng = np.random.default_rng(3)
    bounds = fitted.kernel_.bounds
    thetas = [fitted.kernel_.theta] + [rng.uniform(bounds[:, 0], bounds[:, 1]) for _ in range(5)]
    for theta in thetas:
        with threadpool_limits(limits=1):
            expected, expected_gradient = reference.log_marginal_likelihood(theta, eval_gradient=True)
        value, gradient = _log_marginal_likelihood(theta, D2, z)
        if not np.isfinite(expected):  # not positive definite: both say so
            assert value == -np.inf and not np.any(gradient)
            continue
        # rounding: a random theta can make K ill-conditioned (2.6e-10 relative seen on another numpy/BLAS);
        # near the optimum the gradient is a difference of terms of order |value|
        assert value == pytest.approx(expected, rel=1e-8)
        np.testing.assert_allclose(gradient, expected_gradient, rtol=1e-6, atol=1e-7 * abs(expected))


@pytest.mark.filterwarnings("ignore:The optimal value found:sklearn.exceptions.ConvergenceWarning")
def test_fit_reaches_scikit_learns_own_optimum(train):
    """From the same single start, scikit-learn's optimiser on its own likelihood ends at the same optimum."""
    X, y = train[0][:80], train[1][:80]
    model = make_surrogate(n_restarts=0).fit(X, y)
    T = model.X_gp_
    z = model.output_transform_.transform(model.y_train_)
    with threadpool_limits(limits=1):
        reference = GaussianProcessRegressor(kernel=model._template_kernel(4), alpha=0.0,
                                             n_restarts_optimizer=0).fit(T, z)
    assert model.log_marginal_likelihood_value_ == pytest.approx(reference.log_marginal_likelihood_value_,
                                                                 rel=1e-6)
    np.testing.assert_allclose(model.kernel_.theta, reference.kernel_.theta, atol=1e-3)


@pytest.mark.parametrize("column", [0, 3])
def test_nan_in_X_is_rejected(train, column):
    X, y = train[0][:20].copy(), train[1][:20]
    X[4, column] = np.nan
    with pytest.raises(ValueError, match=NAMES[column]):
        make_surrogate().fit(X, y)


def test_nan_in_y_is_rejected(train):
    X, y = train[0][:20], train[1][:20].copy()
    y[3] = np.inf
    with pytest.raises(ValueError, match="finite"):
        make_surrogate().fit(X, y)


@pytest.mark.parametrize("X_rows, y_rows, X_cols", [(20, 19, 4), (20, 20, 3)])
def test_mismatched_shapes_are_rejected(train, X_rows, y_rows, X_cols):
    with pytest.raises(ValueError):
        make_surrogate().fit(train[0][:X_rows, :X_cols], train[1][:y_rows])


def test_unknown_and_missing_columns_are_rejected(fitted, train):
    X, y = train[0][:20], train[1][:20]
    columns = {name: X[:, j] for j, name in enumerate(NAMES)}
    with pytest.raises(ValueError, match="unknown input column"):
        fitted.predict({**columns, "temperature_c": X[:, 0]})
    with pytest.raises(ValueError, match="missing input column"):
        fitted.predict({k: v for k, v in columns.items() if k != "poisson"})
    with pytest.raises(ValueError, match="unknown input column"):
        make_surrogate().fit({**columns, "E": X[:, 0]}, y)
    with pytest.raises(ValueError, match="output column"):
        make_surrogate().fit(columns, {"contact_area_mm2": y})


@pytest.mark.parametrize("settings", [
    {"log_inputs": ("young",)},
    {"input_scaling": "minmax"},
    {"output_transform": "sqrt"},
    {"n_restarts": -1},
    {"noise_level_bounds": (1e-3, 1e-5)},
    {"input_bounds": {"modulus_mpa": (100.0, 10.0)}},
])
def test_bad_settings_are_rejected(train, settings):
    with pytest.raises(ValueError):
        make_surrogate(**settings).fit(train[0][:20], train[1][:20])


def test_log_transforms_need_positive_values(train):
    X, y = train[0][:20].copy(), train[1][:20]
    with pytest.raises(ValueError, match="> 0"):
        make_surrogate().fit(X, -y)
    X[0, 0] = -5.0
    with pytest.raises(ValueError, match="modulus_mpa"):
        make_surrogate().fit(X, y)


def test_predict_before_fit_raises():
    with pytest.raises(NotFittedError):
        make_surrogate().predict(np.ones((2, 4)))
    assert issubclass(NotFittedError, ValueError)
