"""Gaussian-process surrogate of one model output over named inputs.

`GPSurrogate` fits ``C * Matern(nu=2.5, anisotropic) + White`` (scikit-learn
kernels) to transformed data: each input optionally log-transformed, then
scaled to the unit cube or to z-scores; the output optionally log-transformed,
then standardised. The hyperparameters maximise the log marginal likelihood
over several L-BFGS starts (the kernel's initial values plus `n_restarts`
random ones; the likelihood and its gradient evaluated for this one kernel,
scikit-learn's numbers five times faster), run through the package's one executor (`filmcal._parallel`) with
BLAS pinned to one thread in each start. Predictions are returned in physical output units; their standard
deviation includes the Jacobian of the output transform.

The white-noise term models the numerical noise of the model being emulated
(finite-element results scatter by ~1e-3 mm): `predict` returns the std of the
smooth latent function by default and adds the noise with ``noise=True``, which
is the right comparison against new noisy model runs.
"""
from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence

import numpy as np
from threadpoolctl import threadpool_limits
from scipy.linalg import cho_solve, cholesky, solve_triangular
from scipy.optimize import minimize
from scipy.stats import norm
from sklearn.base import BaseEstimator
from sklearn.exceptions import ConvergenceWarning
from sklearn.gaussian_process.kernels import Kernel
from sklearn.utils.validation import check_is_fitted

from filmcal.surrogate.kernels import kernel_parts, make_kernel
from filmcal.surrogate.transforms import (
    OUTPUT_TRANSFORMS,
    InputTransform,
    OutputTransform,
    as_input_matrix,
    as_output_vector,
    column_names,
)

__all__ = ["GPSurrogate"]

# Box (natural units, GP coordinates) from which random optimiser starts are drawn
# log-uniformly, intersected with the hyperparameter bounds.
_START_LENGTH_SCALE = (0.1, 3.0)
_START_CONSTANT = (0.1, 10.0)
_START_NOISE = (1e-8, 1e-2)
_MIN_POINTS = 3


def _optimise_task(task: tuple) -> tuple[np.ndarray, float, list[str]]:
    """`_optimise_from` of one ``(kernel, theta0, T, z)`` task (an executor's unit)."""
    return _optimise_from(*task)


def _run_starts(template: Kernel, starts: np.ndarray, T: np.ndarray, z: np.ndarray,
                n_jobs: int | None) -> list[tuple[np.ndarray, float, list[str]]]:
    """Every optimiser start, in the calling process (``n_jobs`` None or 1) or on worker processes.

    The results are in the order of `starts` whatever the order of completion,
    so the fit does not depend on the number of workers.
    """
    from filmcal._parallel import open_executor

    tasks = [(template, theta0, T, z) for theta0 in starts]
    if n_jobs is None or n_jobs == 1:
        return [_optimise_task(t) for t in tasks]
    workers = None if n_jobs == -1 else int(n_jobs)
    results: list = [None] * len(tasks)
    with open_executor(workers, n_tasks=len(tasks)) as executor:
        for outcome in executor.map_unordered(_optimise_task, tasks):
            results[outcome.index] = outcome.result()
    return results


def _squared_differences(T: np.ndarray) -> np.ndarray:
    """Squared coordinate differences ``(T[i, k] - T[j, k])**2`` as an array of shape (d, n, n)."""
    return np.stack([np.subtract.outer(column, column) ** 2 for column in T.T])


def _log_marginal_likelihood(theta: np.ndarray, D2: np.ndarray, z: np.ndarray) -> tuple[float, np.ndarray]:
    """Log marginal likelihood of ``C * Matern(nu=2.5, anisotropic) + White`` and its gradient.

    `theta` is scikit-learn's vector of log-hyperparameters of that kernel,
    ``[log C, log l_1 .. log l_d, log noise]``; `D2` the squared differences
    of the training inputs (`_squared_differences`), which stay fixed while the
    optimiser moves `theta`. With ``s = sqrt(5 sum_k D2_k / l_k**2)`` the kernel is
    ``C (1 + s + s**2/3) exp(-s)`` (Rasmussen & Williams, eq. 4.17) and its
    derivative in ``log l_k`` is ``C (5/3) (1 + s) exp(-s) D2_k / l_k**2``; the
    gradient is ``0.5 tr((a a^T - K^-1) dK)`` with ``a = K^-1 z`` (eq. 5.9).
    The same numbers as scikit-learn's ``log_marginal_likelihood(theta,
    eval_gradient=True)`` for that kernel (to rounding), without its generic
    kernel algebra: about 5x faster at 320 points, which is most of a fit.
    Returns ``(-inf, zeros)`` where the kernel matrix is not positive definite,
    as scikit-learn does.
    """
    constant, noise = np.exp(theta[0]), np.exp(theta[-1])
    inv_sq = np.exp(-2.0 * theta[1:-1])
    s = np.sqrt(5.0 * np.tensordot(inv_sq, D2, axes=1))
    decay = np.exp(-s)
    K = constant * (1.0 + s + s * s / 3.0) * decay
    K[np.diag_indices_from(K)] += noise
    try:
        L = cholesky(K, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return -np.inf, np.zeros_like(theta)
    alpha = cho_solve((L, True), z, check_finite=False)
    value = -0.5 * z @ alpha - np.log(np.diag(L)).sum() - 0.5 * z.size * np.log(2.0 * np.pi)
    W = np.outer(alpha, alpha) - cho_solve((L, True), np.eye(z.size), check_finite=False)
    trace_w = np.trace(W)
    d_constant = 0.5 * (np.vdot(W, K) - noise * trace_w)  # dK/dlog C = K - noise I
    slope = (constant * 5.0 / 3.0) * (1.0 + s) * decay
    d_lengths = 0.5 * inv_sq * (D2.reshape(D2.shape[0], -1) @ (W * slope).ravel())
    return float(value), np.concatenate([[d_constant], d_lengths, [0.5 * noise * trace_w]])


def _optimise_from(kernel: Kernel, theta0: np.ndarray, T: np.ndarray, z: np.ndarray
                   ) -> tuple[np.ndarray, float, list[str]]:
    """One L-BFGS maximisation of the log marginal likelihood from `theta0`.

    The optimiser is scikit-learn's (``scipy.optimize.minimize``, L-BFGS-B,
    within the kernel's bounds) on `_log_marginal_likelihood`. Runs with BLAS
    pinned to one thread. Returns the optimal log-hyperparameters, the log
    marginal likelihood there (-inf if the kernel matrix was not positive
    definite) and the optimiser's complaint, if any.
    """
    if kernel.n_dims != T.shape[1] + 2:
        raise ValueError(f"the kernel has {kernel.n_dims} hyperparameters for {T.shape[1]} inputs")
    D2 = _squared_differences(T)

    def objective(theta: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = _log_marginal_likelihood(theta, D2, z)
        return -value, -gradient

    with threadpool_limits(limits=1):
        result = minimize(objective, np.asarray(theta0, dtype=float), method="L-BFGS-B", jac=True,
                          bounds=kernel.bounds)
    if not np.isfinite(result.fun):
        return np.asarray(theta0, dtype=float), -np.inf, ["kernel matrix not positive definite"]
    messages = [] if result.status == 0 else [f"lbfgs failed to converge (status={result.status}): {result.message}"]
    return result.x, float(-result.fun), messages


class GPSurrogate(BaseEstimator):
    """Gaussian-process surrogate ``y = f(x)`` of one output over named inputs.

    Parameters
    ----------
    inputs : sequence of str, optional
        Input names in column order. Default: the column names of the `X`
        given to `fit` (mapping, DataFrame or structured array), else
        ``x0, x1, ...``.
    output : str, default "y"
        Output name (selects the column when `y` is a mapping or DataFrame).
    log_inputs : sequence of str, default ()
        Inputs modelled in log scale (e.g. the film modulus); they must be > 0.
    input_scaling : {"unit", "zscore"}, default "unit"
        ``"unit"`` maps each (log-)input onto [0, 1], ``"zscore"`` standardises it.
    input_bounds : mapping of str -> (low, high), optional
        Physical domain used by ``"unit"`` scaling; inputs not listed use the
        range of the training data.
    output_transform : {"standardize", "log", "auto"}, default "standardize"
        ``"log"`` models ``log(y)`` (y > 0) and is then standardised. ``"auto"``
        fits both when every y > 0 (else only the standardised y) and keeps the
        one with the larger evidence of the physical outputs (`log_evidence_`):
        a log suits an output spanning decades, but stretches one that comes
        close to zero.
    length_scale_bounds, constant_value_bounds, noise_level_bounds : (float, float)
        Bounds of the Matern length scales (scaled inputs), of the signal
        variance and of the white-noise variance (standardised output).
    noise_level : float, default 1e-4
        Initial white-noise variance of the first optimiser start.
    n_restarts : int, default 8
        Random optimiser starts in addition to the first one.
    n_jobs : int, optional
        Parallel optimiser starts (worker processes of `filmcal._parallel`); None means 1,
        -1 all CPUs. Every start runs with BLAS pinned to one thread, which is
        what matters most for these small matrices; processes help only when
        cores are idle (about 1.6x on 2 idle cores for 8 starts, slower than
        serial on a loaded machine).
    random_state : int, numpy.random.Generator or None
        Seed of the random starts: the same seed gives the same fit.

    Attributes
    ----------
    input_names_ : list of str
        Input names, the column order of `X_train_`.
    n_features_in_ : int
        Number of inputs.
    X_train_ : ndarray of shape (n, d)
        Training inputs in physical units.
    y_train_ : ndarray of shape (n,)
        Training outputs in physical units.
    input_transform_ : InputTransform
    output_transform_ : OutputTransform
    kernel_ : sklearn Kernel
        Kernel with the fitted hyperparameters (GP coordinates).
    log_marginal_likelihood_value_ : float
        Log marginal likelihood of the transformed data at `kernel_`.
    restart_log_marginal_likelihoods_ : ndarray
        Optimum reached from each start (-inf where the fit failed), in start order.
    log_evidence_ : dict of str -> float
        Log marginal likelihood of the physical outputs y (the Jacobian of the
        output transform included) at the optimum of each transform tried; only
        after `fit`, not after loading.
    at_bounds_ : list of str
        Hyperparameters that ended at a bound (a white noise at its lower bound
        is normal for noise-free data).
    X_gp_ : ndarray of shape (n, d)
        Training inputs in GP coordinates.
    cholesky_ : ndarray of shape (n, n)
        Lower Cholesky factor of the training covariance (noise included).
    dual_coef_ : ndarray of shape (n,)
        ``K^-1 z`` for the standardised training outputs z.
    """

    def __init__(self, inputs: Sequence[str] | None = None, output: str = "y", *,
                 log_inputs: Sequence[str] = (), input_scaling: str = "unit",
                 input_bounds: Mapping[str, Sequence[float]] | None = None,
                 output_transform: str = "standardize",
                 length_scale_bounds: Sequence[float] = (1e-2, 1e3),
                 constant_value_bounds: Sequence[float] = (1e-3, 1e4),
                 noise_level: float = 1e-4,
                 noise_level_bounds: Sequence[float] = (1e-8, 1e-1),
                 n_restarts: int = 8, n_jobs: int | None = None,
                 random_state: int | np.random.Generator | None = None) -> None:
        self.inputs = inputs
        self.output = output
        self.log_inputs = log_inputs
        self.input_scaling = input_scaling
        self.input_bounds = input_bounds
        self.output_transform = output_transform
        self.length_scale_bounds = length_scale_bounds
        self.constant_value_bounds = constant_value_bounds
        self.noise_level = noise_level
        self.noise_level_bounds = noise_level_bounds
        self.n_restarts = n_restarts
        self.n_jobs = n_jobs
        self.random_state = random_state

    # ------------------------------------------------------------------ fitting
    def _input_names(self, X: object) -> list[str]:
        if self.inputs is not None:
            names = [str(n) for n in self.inputs]
        else:
            names = column_names(X)
            if names is None:
                shape = np.shape(X)
                if len(shape) != 2:
                    raise ValueError(f"X must be 2-D (n_points, n_inputs), got shape {shape}")
                names = [f"x{j}" for j in range(shape[1])]
        if not names or len(set(names)) != len(names):
            raise ValueError(f"input names must be non-empty and unique, got {names}")
        return names

    def _template_kernel(self, n_inputs: int) -> Kernel:
        for name in ("length_scale_bounds", "constant_value_bounds", "noise_level_bounds"):
            lo_hi = np.asarray(getattr(self, name), dtype=float)
            if lo_hi.shape != (2,) or not np.all(np.isfinite(lo_hi)) or not 0 < lo_hi[0] < lo_hi[1]:
                raise ValueError(f"{name} must be (low, high) with 0 < low < high, got {getattr(self, name)!r}")
        noise = float(np.clip(self.noise_level, *self.noise_level_bounds))
        return make_kernel(n_inputs, length_scale_bounds=self.length_scale_bounds,
                           constant_value_bounds=self.constant_value_bounds,
                           noise_level=noise, noise_level_bounds=self.noise_level_bounds)

    def _starts(self, kernel: Kernel, rng: np.random.Generator) -> np.ndarray:
        """Log-hyperparameters of the optimiser starts: the kernel's own, then random ones."""
        d = kernel.n_dims - 2
        lows = np.log([_START_CONSTANT[0]] + [_START_LENGTH_SCALE[0]] * d + [_START_NOISE[0]])
        highs = np.log([_START_CONSTANT[1]] + [_START_LENGTH_SCALE[1]] * d + [_START_NOISE[1]])
        bounds = kernel.bounds
        lows = np.clip(lows, bounds[:, 0], bounds[:, 1])
        highs = np.clip(highs, bounds[:, 0], bounds[:, 1])
        random = rng.uniform(lows, highs, size=(self.n_restarts, kernel.n_dims))
        return np.vstack([kernel.theta[None, :], random])

    def fit(self, X: object, y: object) -> GPSurrogate:
        """Fit the hyperparameters and condition the GP on the data.

        Parameters
        ----------
        X : mapping, DataFrame, structured array or array_like of shape (n, d)
            Training inputs in physical units.
        y : array_like of shape (n,), or a mapping / DataFrame with column `output`
            Training outputs in physical units.

        Returns
        -------
        self

        Raises
        ------
        ValueError
            For NaN/inf values, mismatched shapes, unknown or missing columns,
            invalid settings, or fewer than 3 points.
        """
        if not isinstance(self.n_restarts, (int, np.integer)) or self.n_restarts < 0:
            raise ValueError(f"n_restarts must be an integer >= 0, got {self.n_restarts!r}")
        names = self._input_names(X)
        X = as_input_matrix(X, names)
        y = as_output_vector(y, self.output, X.shape[0])
        if X.shape[0] < _MIN_POINTS:
            raise ValueError(f"need at least {_MIN_POINTS} training points, got {X.shape[0]}")
        if self.output_transform != "auto" and self.output_transform not in OUTPUT_TRANSFORMS:
            raise ValueError(f"output_transform must be 'auto' or one of {', '.join(OUTPUT_TRANSFORMS)}; "
                             f"got {self.output_transform!r}")
        input_transform = InputTransform.fit(names, X, self.log_inputs, self.input_scaling, self.input_bounds)
        T = input_transform.transform(X)
        template = self._template_kernel(len(names))
        if self.output_transform != "auto":
            kinds = [self.output_transform]
        else:
            kinds = ["log", "standardize"] if np.all(y > 0) else ["standardize"]
        starts = self._starts(template, np.random.default_rng(self.random_state))  # the same for every transform
        fits = {}
        for kind in kinds:
            try:
                fits[kind] = self._fit_output(template, T, y, kind, starts)
            except ValueError:
                if kind == kinds[-1] and not fits:
                    raise
        kinds = list(fits)
        self.log_evidence_ = {kind: fit[4] for kind, fit in fits.items()}
        kind = max(kinds, key=lambda k: self.log_evidence_[k])  # the first of equals: log
        output_transform, theta, lml, messages, _ = fits[kind]
        for message in dict.fromkeys(messages):
            warnings.warn(f"GP hyperparameter optimisation: {message}", ConvergenceWarning, stacklevel=2)
        self._set_state(X, y, input_transform, output_transform, template.clone_with_theta(theta))
        self.restart_log_marginal_likelihoods_ = lml
        return self

    def _fit_output(self, template: Kernel, T: np.ndarray, y: np.ndarray, kind: str, starts: np.ndarray
                    ) -> tuple[OutputTransform, np.ndarray, np.ndarray, list[str], float]:
        """Hyperparameters for the outputs `y` under the output transform `kind`.

        Returns the output transform, the best log-hyperparameters, the optimum
        of every start, the best start's warnings and the log evidence of the
        physical outputs: the log marginal likelihood of ``z = (h(y) - offset) /
        scale`` plus the log Jacobian ``log|dz/dy|`` summed over the points,
        ``-n log(scale)`` and, for the log, ``-sum(log y)``. The evidences of two
        transforms are then densities of the same y and can be compared (the
        warped-GP argument of Snelson, Rasmussen & Ghahramani, NIPS 2003).
        """
        output_transform = OutputTransform.fit(y, kind)
        z = output_transform.transform(y)
        results = _run_starts(template, starts, T, z, self.n_jobs)
        lml = np.array([r[1] for r in results])
        if not np.any(np.isfinite(lml)):
            raise ValueError("the GP fit failed from every start (kernel matrix not positive definite); "
                             "raise noise_level_bounds[0]")
        best = int(np.argmax(lml))
        if results[best][2]:  # stopped short: once more from there
            theta, value, messages = _optimise_from(template, results[best][0], T, z)
            if value > lml[best] + 1e-9:
                results[best], lml[best] = (theta, value, messages), value
            elif np.isfinite(value):
                # no line search ascends from it: a maximum to the likelihood's own rounding, not a failure
                results[best] = (results[best][0], lml[best],
                                 [m for m in results[best][2] if not m.startswith("lbfgs failed to converge")])
        jacobian = -y.size * np.log(output_transform.scale) - (np.sum(np.log(y)) if kind == "log" else 0.0)
        return output_transform, results[best][0], lml, results[best][2], float(lml[best] + jacobian)

    def _set_state(self, X: np.ndarray, y: np.ndarray, input_transform: InputTransform,
                   output_transform: OutputTransform, kernel: Kernel) -> None:
        """Condition the GP with fixed hyperparameters (used by `fit` and by loading)."""
        _, matern, _ = kernel_parts(kernel)
        if np.size(matern.length_scale) not in (1, X.shape[1]):
            raise ValueError(f"kernel has {np.size(matern.length_scale)} length scales for {X.shape[1]} inputs")
        T, z = input_transform.transform(X), output_transform.transform(y)
        K = kernel(T)
        # One BLAS thread: a nearly singular K factorises differently with another thread count, and the
        # saved log marginal likelihood must reproduce wherever the files are read (a worker fits, the
        # parent loads).
        with threadpool_limits(limits=1):
            try:
                L = cholesky(K, lower=True, check_finite=False)
            except np.linalg.LinAlgError:
                raise ValueError("the kernel matrix is not positive definite; raise noise_level_bounds[0]") from None
            dual = cho_solve((L, True), z, check_finite=False)
        self.input_names_ = list(input_transform.names)
        self.n_features_in_ = len(self.input_names_)
        self.X_train_, self.y_train_ = X, y
        self.input_transform_, self.output_transform_ = input_transform, output_transform
        self.kernel_ = kernel
        self.X_gp_, self.cholesky_, self.dual_coef_ = T, L, dual
        self.log_marginal_likelihood_value_ = float(
            -0.5 * z @ dual - np.log(np.diag(L)).sum() - 0.5 * z.size * np.log(2.0 * np.pi))
        self.at_bounds_ = self._hyperparameters_at_bounds()

    def _hyperparameters_at_bounds(self) -> list[str]:
        isotropic = np.size(kernel_parts(self.kernel_)[1].length_scale) == 1
        lengths = ["length_scale"] if isotropic else [f"length_scale[{n}]" for n in self.input_names_]
        labels = ["constant_value"] + lengths + ["noise_level"]
        theta, bounds = self.kernel_.theta, self.kernel_.bounds
        near = (np.abs(theta - bounds[:, 0]) < 1e-3) | (np.abs(theta - bounds[:, 1]) < 1e-3)
        return [label for label, flag in zip(labels, near) if flag]

    # -------------------------------------------------------------- prediction
    @property
    def length_scales_(self) -> dict[str, float]:
        """Fitted Matern length scale of each input (GP coordinates)."""
        check_is_fitted(self)
        scales = np.broadcast_to(kernel_parts(self.kernel_)[1].length_scale, (self.n_features_in_,))
        return {name: float(s) for name, s in zip(self.input_names_, scales)}

    @property
    def noise_variance_(self) -> float:
        """Fitted white-noise variance (GP coordinates: standardised output)."""
        check_is_fitted(self)
        return float(kernel_parts(self.kernel_)[2].noise_level)

    def _gp_inputs(self, X: object) -> tuple[np.ndarray, np.ndarray]:
        """Physical and GP coordinates of the query points."""
        check_is_fitted(self)
        X = as_input_matrix(X, self.input_names_)
        return X, self.input_transform_.transform(X)

    def predict_gp(self, T: np.ndarray, noise: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Posterior mean and std in GP coordinates at GP-coordinate points `T`.

        Parameters
        ----------
        T : ndarray of shape (m, d)
            Points in GP coordinates (``input_transform_.transform(X)``).
        noise : bool, default False
            Add the white-noise variance (predict a new noisy observation).
        """
        check_is_fitted(self)
        Ks = self.kernel_(T, self.X_gp_)
        mean = Ks @ self.dual_coef_
        v = solve_triangular(self.cholesky_, Ks.T, lower=True, check_finite=False)
        var = self.kernel_.k1.diag(T) - np.einsum("ij,ij->j", v, v)
        var = np.maximum(var, 0.0)
        if noise:
            var = var + self.noise_variance_
        return mean, np.sqrt(var)

    def predict(self, X: object, return_std: bool = False, noise: bool = False
                ) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
        """Predict the output in physical units.

        Parameters
        ----------
        X : mapping, DataFrame, structured array or array_like of shape (m, d)
            Query points in physical units.
        return_std : bool, default False
            Also return the predictive standard deviation.
        noise : bool, default False
            Include the fitted white noise in the std (for comparison with new
            noisy model runs); by default the std of the smooth function.

        Returns
        -------
        mean : ndarray of shape (m,)
            Posterior mean; with ``output_transform="log"`` the posterior median
            ``exp(m)``.
        std : ndarray of shape (m,)
            Only with `return_std`: the GP std times ``|dy/dz|``, the Jacobian
            of the output transform.
        """
        _, T = self._gp_inputs(X)
        if not return_std:
            return self.output_transform_.inverse(self.kernel_(T, self.X_gp_) @ self.dual_coef_)
        mean, std = self.predict_gp(T, noise=noise)
        return self.output_transform_.inverse(mean), self.output_transform_.derivative(mean) * std

    def predict_interval(self, X: object, level: float = 0.9, noise: bool = False
                         ) -> tuple[np.ndarray, np.ndarray]:
        """Central predictive interval in physical units.

        The Gaussian interval of the GP coordinate is mapped through the
        (monotone) output transform, so it is exact for the log transform too.

        Parameters
        ----------
        X : as in `predict`
        level : float, default 0.9
            Probability content, in (0, 1).
        noise : bool, default False
            Include the fitted white noise.

        Returns
        -------
        lower, upper : ndarray of shape (m,)
        """
        if not 0.0 < level < 1.0:
            raise ValueError(f"level must lie in (0, 1), got {level!r}")
        _, T = self._gp_inputs(X)
        mean, std = self.predict_gp(T, noise=noise)
        q = norm.ppf(0.5 + 0.5 * level)
        return self.output_transform_.inverse(mean - q * std), self.output_transform_.inverse(mean + q * std)

    def predict_gradient(self, X: object) -> np.ndarray:
        """Gradient of the predicted output with respect to the physical inputs.

        Analytic derivative of the Matern 5/2 posterior mean,
        ``dk/dt_d = -c (5/3) (1 + sqrt5 r) exp(-sqrt5 r) (t_d - t'_d) / l_d^2``,
        chained with the input and output transforms.

        Parameters
        ----------
        X : as in `predict`

        Returns
        -------
        ndarray of shape (m, d)
            ``d mean / d x`` in output units per input unit, columns in
            `input_names_` order.
        """
        X, T = self._gp_inputs(X)
        constant, matern, _ = kernel_parts(self.kernel_)
        length = np.broadcast_to(np.asarray(matern.length_scale, dtype=float), (self.n_features_in_,))
        diff = T[:, None, :] - self.X_gp_[None, :, :]
        r = np.sqrt(np.sum((diff / length) ** 2, axis=2))
        s5r = np.sqrt(5.0) * r
        factor = -constant.constant_value * (5.0 / 3.0) * (1.0 + s5r) * np.exp(-s5r)
        dmean_dt = np.einsum("mn,mnd,n->md", factor, diff / length**2, self.dual_coef_)
        mean = self.kernel_(T, self.X_gp_) @ self.dual_coef_
        dmean_dx = dmean_dt * self.input_transform_.derivative(X)
        return self.output_transform_.derivative(mean)[:, None] * dmean_dx
