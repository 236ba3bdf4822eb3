"""Validation of a fitted surrogate: closed-form leave-one-out and held-out checks.

Leave-one-out (LOO) uses the closed form of Rasmussen & Williams, *Gaussian
Processes for Machine Learning* (2006), eq. 5.12, with the hyperparameters and
transforms fixed at their fitted values::

    mu_i - z_i = -[K^-1 z]_i / [K^-1]_ii,      var_i = 1 / [K^-1]_ii

(K includes the white noise, so var_i is the variance of a new noisy
observation). Q2 = 1 - PRESS / SS compares the LOO residuals with the spread of
the data. `validate` checks a surrogate against held-out model runs: errors,
Q2 and the coverage of the 90 % predictive intervals.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_solve
from scipy.stats import norm
from sklearn.utils.validation import check_is_fitted

from filmcal.surrogate.gp import GPSurrogate
from filmcal.surrogate.transforms import as_input_matrix, as_output_vector

__all__ = ["LeaveOneOut", "ValidationResult", "leave_one_out", "validate"]

_Z90 = norm.ppf(0.95)


@dataclass(frozen=True)
class LeaveOneOut:
    """Closed-form leave-one-out predictions at the training points.

    Attributes
    ----------
    mean, std : ndarray of shape (n,)
        LOO predictive mean and std in physical output units (std through the
        Jacobian of the output transform; noise included).
    residual : ndarray of shape (n,)
        ``y_i - mean_i`` in physical units.
    standardized_residual : ndarray of shape (n,)
        ``(z_i - mu_i) / sd_i`` in GP coordinates, where it is exactly
        Gaussian under the model: about N(0, 1) for a well-calibrated surrogate.
    q2 : float
        ``1 - PRESS / SS`` with ``PRESS = sum(residual^2)`` and
        ``SS = sum((y - mean(y))^2)`` (physical units).
    coverage90 : float
        Fraction of training points inside their LOO 90 % interval.
    """

    mean: np.ndarray
    std: np.ndarray
    residual: np.ndarray
    standardized_residual: np.ndarray
    q2: float
    coverage90: float


def leave_one_out(surrogate: GPSurrogate) -> LeaveOneOut:
    """Leave-one-out predictions of a fitted surrogate (R&W eq. 5.12).

    Parameters
    ----------
    surrogate : GPSurrogate
        A fitted surrogate; its hyperparameters and transforms stay fixed.

    Returns
    -------
    LeaveOneOut
    """
    check_is_fitted(surrogate)
    n = surrogate.dual_coef_.size
    k_inv = cho_solve((surrogate.cholesky_, True), np.eye(n), check_finite=False)
    k_inv_diag = np.diag(k_inv)
    z = surrogate.output_transform_.transform(surrogate.y_train_)
    mu = z - surrogate.dual_coef_ / k_inv_diag
    sd = 1.0 / np.sqrt(k_inv_diag)
    out = surrogate.output_transform_
    mean, std = out.inverse(mu), out.derivative(mu) * sd
    y = surrogate.y_train_
    residual = y - mean
    standardized = (z - mu) / sd
    return LeaveOneOut(mean=mean, std=std, residual=residual, standardized_residual=standardized,
                       q2=_q2(y, residual), coverage90=float(np.mean(np.abs(standardized) <= _Z90)))


def _q2(y: np.ndarray, residual: np.ndarray) -> float:
    spread = float(np.sum((y - y.mean()) ** 2))
    return 1.0 - float(np.sum(residual**2)) / spread if spread > 0 else float("nan")


@dataclass(frozen=True)
class ValidationResult:
    """Accuracy of a surrogate on held-out points.

    Attributes
    ----------
    n : int
        Number of held-out points.
    rms_error, max_abs_error : float
        RMS and largest absolute error of the predicted mean (output units).
    rms_relative_error, max_relative_error : float
        The same for ``(mean - y) / |y|``.
    q2 : float
        ``1 - sum((y - mean)^2) / sum((y - mean(y))^2)``.
    coverage90 : float
        Fraction of the points inside their 90 % predictive interval.
    """

    n: int
    rms_error: float
    max_abs_error: float
    rms_relative_error: float
    max_relative_error: float
    q2: float
    coverage90: float


def validate(surrogate: GPSurrogate, X_test: object, y_test: object, noise: bool = True) -> ValidationResult:
    """Compare a surrogate with held-out model runs.

    Parameters
    ----------
    surrogate : GPSurrogate
        A fitted surrogate.
    X_test : as `GPSurrogate.predict`
        Held-out inputs in physical units.
    y_test : array_like of shape (m,) or mapping with the output column
        Held-out outputs (physical units, all != 0 for the relative errors).
    noise : bool, default True
        Include the fitted white noise in the intervals: the held-out values
        are noisy model runs themselves.

    Returns
    -------
    ValidationResult
    """
    check_is_fitted(surrogate)
    X = as_input_matrix(X_test, surrogate.input_names_)
    y = as_output_vector(y_test, surrogate.output, X.shape[0])
    if np.any(y == 0):
        raise ValueError("y_test must be != 0 for relative errors")
    mean = surrogate.predict(X)
    lower, upper = surrogate.predict_interval(X, level=0.9, noise=noise)
    error = mean - y
    relative = error / np.abs(y)
    return ValidationResult(
        n=int(y.size),
        rms_error=float(np.sqrt(np.mean(error**2))),
        max_abs_error=float(np.max(np.abs(error))),
        rms_relative_error=float(np.sqrt(np.mean(relative**2))),
        max_relative_error=float(np.max(np.abs(relative))),
        q2=_q2(y, -error),
        coverage90=float(np.mean((y >= lower) & (y <= upper))),
    )
