"""Checks of a calibration against the data, point by point.

`predictive_check`
    Posterior predictive distribution of each measured radius: a mixture over
    posterior samples of N(model + delta_F, sigma^2 + u^2 + s^2 + tau^2). Its mean, std, 90 %
    interval (exact mixture quantiles), the standardised residual and the PIT
    value ``P(r_rep <= r_measured)`` of each case; cases with a PIT outside
    (0.05, 0.95) fall outside their 90 % interval.

`case_modulus_intervals`
    The analogue of the paper's Fig. 3: for each (R, F) case alone, the range
    of E for which the model reproduces the measured radius within +/- a noise
    level (by default the posterior median of sigma), found by root finding on
    the model in log E, next to the E that reproduces it exactly.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr

from filmcal.calibration.likelihood import CalibrationProblem

__all__ = ["PredictiveCheck", "CaseIntervals", "predictive_check", "case_modulus_intervals", "thin_evenly"]


def thin_evenly(theta: np.ndarray, max_samples: int) -> np.ndarray:
    """At most `max_samples` rows of `theta`, evenly spaced (deterministic)."""
    if theta.shape[0] <= max_samples:
        return theta
    return theta[np.linspace(0, theta.shape[0] - 1, max_samples).round().astype(int)]


def _arrays_to_dict(obj) -> dict:
    out = {}
    for f in fields(obj):
        value = getattr(obj, f.name)
        if isinstance(value, np.ndarray):
            value = [None if isinstance(v, float) and not math.isfinite(v) else v for v in value.tolist()]
        out[f.name] = value
    return out


@dataclass(frozen=True)
class PredictiveCheck:
    """Posterior predictive check of each measured radius.

    Attributes
    ----------
    sphere_radius_mm, force_n, measured_radius_mm, hertz_radius_mm : ndarray of shape (n,)
        The cases (for bodies other than steel, the radius compared with the
        model and the steel Hertz radius: see ``RadiusErrorData.target_radius_mm``).
    mean_mm, std_mm : ndarray of shape (n,)
        Mean and std of the posterior predictive distribution of the radius.
    lower_mm, upper_mm : ndarray of shape (n,)
        Its central `level` interval (sigma, surrogate std and the posterior
        of the parameters included).
    standardized_residual : ndarray of shape (n,)
        ``(measured - mean) / std``.
    pit : ndarray of shape (n,)
        ``P(r_rep <= measured)``: uniform on (0, 1) for a well-calibrated model.
    outside : ndarray of bool, shape (n,)
        Measured radius outside its interval.
    level : float
        Probability content of the interval (0.9).
    n_samples : int
        Posterior samples used.
    """

    sphere_radius_mm: np.ndarray
    force_n: np.ndarray
    measured_radius_mm: np.ndarray
    hertz_radius_mm: np.ndarray
    mean_mm: np.ndarray
    std_mm: np.ndarray
    lower_mm: np.ndarray
    upper_mm: np.ndarray
    standardized_residual: np.ndarray
    pit: np.ndarray
    outside: np.ndarray
    level: float
    n_samples: int

    @property
    def coverage(self) -> float:
        """Fraction of measured radii inside their interval."""
        return float(np.mean(~self.outside))

    def to_dict(self) -> dict:
        """Plain JSON values (arrays as lists)."""
        return _arrays_to_dict(self)

    @classmethod
    def from_dict(cls, d: dict) -> PredictiveCheck:
        """Inverse of `to_dict`."""
        kw = {k: np.asarray(v, dtype=bool if k == "outside" else float) for k, v in d.items()
              if k not in ("level", "n_samples")}
        return cls(**kw, level=float(d["level"]), n_samples=int(d["n_samples"]))


def _mixture_quantile(p: float, mu: np.ndarray, sd: np.ndarray) -> float:
    """Quantile of an equally weighted mixture of normals N(mu_j, sd_j^2)."""
    lo = float(np.min(mu - 8.0 * sd))
    hi = float(np.max(mu + 8.0 * sd))
    return brentq(lambda q: float(np.mean(ndtr((q - mu) / sd))) - p, lo, hi, xtol=1e-10)


def _first_of_equal_columns(*arrays: np.ndarray) -> np.ndarray:
    """For each column i, the first column j <= i whose values in every array equal column i's."""
    stacked = np.ascontiguousarray(np.concatenate(arrays, axis=0).T)
    seen: dict[bytes, int] = {}
    return np.array([seen.setdefault(row.tobytes(), i) for i, row in enumerate(stacked)], dtype=int)


def predictive_check(problem: CalibrationProblem, theta: np.ndarray, level: float = 0.9,
                     max_samples: int = 2000) -> PredictiveCheck:
    """Posterior predictive distribution of every measured radius.

    Parameters
    ----------
    problem : CalibrationProblem
    theta : ndarray of shape (m, ndim)
        Posterior samples (sampled coordinates).
    level : float, default 0.9
        Probability content of the intervals.
    max_samples : int, default 2000
        At most this many samples, evenly spaced, are pushed through the model.

    Returns
    -------
    PredictiveCheck
    """
    if not 0.0 < level < 1.0:
        raise ValueError(f"level must lie in (0, 1), got {level!r}")
    theta = thin_evenly(np.asarray(theta, dtype=float).reshape(-1, problem.ndim), max_samples)
    mu, sd = problem.predictive_moments(theta)
    y = problem.target_radius_mm
    mean = mu.mean(axis=0)
    std = np.sqrt(np.mean(sd**2 + mu**2, axis=0) - mean**2)
    pit = np.mean(ndtr((y[None, :] - mu) / sd), axis=0)
    tail = 0.5 * (1.0 - level)
    # rows whose predictive samples are equal (repeats of a case, same measurement uncertainty) share their
    # interval: each distinct one is solved once, so a case of many repeats costs one root-find, not one per row
    first = _first_of_equal_columns(mu, sd)
    lower = np.array([_mixture_quantile(tail, mu[:, i], sd[:, i]) if first[i] == i else np.nan
                      for i in range(y.size)])[first]
    upper = np.array([_mixture_quantile(1.0 - tail, mu[:, i], sd[:, i]) if first[i] == i else np.nan
                      for i in range(y.size)])[first]
    return PredictiveCheck(
        sphere_radius_mm=problem.data.sphere_radius_mm.copy(), force_n=problem.data.force_n.copy(),
        measured_radius_mm=y.copy(), hertz_radius_mm=problem.data.steel_hertz_radius_mm.copy(),
        mean_mm=mean, std_mm=std, lower_mm=lower, upper_mm=upper,
        standardized_residual=(y - mean) / std, pit=pit, outside=(y < lower) | (y > upper),
        level=float(level), n_samples=int(theta.shape[0]))


@dataclass(frozen=True)
class CaseIntervals:
    """Per-case ranges of E that reproduce one measured radius (the paper's Fig. 3).

    Bounds are never NaN: ``lower_mpa = 0`` means the range extends below the
    prior's lowest E, ``upper_mpa = inf`` above its highest; a case the model
    cannot reach at all gets ``[0, E_min]`` or ``[E_max, inf]``.

    Attributes
    ----------
    sphere_radius_mm, force_n, measured_radius_mm : ndarray of shape (n,)
    modulus_mpa : ndarray of shape (n,)
        E at which the model radius equals the measured one (0 or inf when
        outside the prior range).
    lower_mpa, upper_mpa : ndarray of shape (n,)
        Range of E with ``|model radius - measured| <= tolerance_mm``.
    tolerance_mm : float
        The noise level used (posterior median of sigma by default).
    poisson : float
        nu at which the model was inverted.
    modulus_range_mpa : (float, float)
        The prior range searched.
    status : list of str
        ``"inside"``, ``"extends below prior"``, ``"extends above prior"``,
        ``"extends beyond both ends"``, ``"below prior"`` or ``"above prior"``.
    """

    sphere_radius_mm: np.ndarray
    force_n: np.ndarray
    measured_radius_mm: np.ndarray
    modulus_mpa: np.ndarray
    lower_mpa: np.ndarray
    upper_mpa: np.ndarray
    tolerance_mm: float
    poisson: float
    modulus_range_mpa: tuple[float, float]
    status: list[str]

    def to_dict(self) -> dict:
        """Plain JSON values (arrays as lists, inf as None)."""
        d = _arrays_to_dict(self)
        d["modulus_range_mpa"] = list(self.modulus_range_mpa)
        return d

    @classmethod
    def from_dict(cls, d: dict) -> CaseIntervals:
        """Inverse of `to_dict` (None read back as inf)."""
        def arr(values, missing):
            return np.array([missing if v is None else v for v in values], dtype=float)

        return cls(sphere_radius_mm=arr(d["sphere_radius_mm"], np.nan), force_n=arr(d["force_n"], np.nan),
                   measured_radius_mm=arr(d["measured_radius_mm"], np.nan),
                   modulus_mpa=arr(d["modulus_mpa"], math.inf), lower_mpa=arr(d["lower_mpa"], math.inf),
                   upper_mpa=arr(d["upper_mpa"], math.inf), tolerance_mm=float(d["tolerance_mm"]),
                   poisson=float(d["poisson"]), modulus_range_mpa=tuple(d["modulus_range_mpa"]),
                   status=list(d["status"]))


def _root(fun, a: float, b: float) -> float:
    """Brent's root of `fun` in [a, b]; the endpoint nearer to 0 if a single evaluation there
    disagrees in sign with the tabulated (vectorised) one by rounding."""
    fa, fb = fun(a), fun(b)
    if fa * fb > 0.0:
        return a if abs(fa) < abs(fb) else b
    return brentq(fun, a, b, xtol=1e-12)


def _sign_change_roots(fun, x: np.ndarray, g: np.ndarray) -> list[float]:
    """Roots of ``fun`` (with values g on the grid x) in every bracket where g changes sign."""
    roots = []
    for k in range(x.size - 1):
        if g[k] == 0.0:
            roots.append(float(x[k]))
        elif g[k] * g[k + 1] < 0.0:
            roots.append(_root(fun, x[k], x[k + 1]))
    if g[-1] == 0.0:
        roots.append(float(x[-1]))
    return roots


def _invert_case(radius_at, x: np.ndarray, f: np.ndarray, y: float, tol: float
                 ) -> tuple[float, float, float, str]:
    """E reproducing y, and the range of E within y +/- tol, for one case (x = log E grid)."""
    e_min, e_max = math.exp(x[0]), math.exp(x[-1])
    exact = _sign_change_roots(lambda t: radius_at(t) - y, x, f - y)
    nearer_low_end = abs(f[0] - y) <= abs(f[-1] - y)
    point = math.exp(exact[0]) if exact else (0.0 if nearer_low_end else math.inf)
    # The band |f - y| <= tol contains the exact roots: add them so that no band is missed between grid points.
    xs = np.concatenate([x, exact])
    band = np.concatenate([np.abs(f - y) - tol, np.full(len(exact), -tol)])
    order = np.argsort(xs, kind="stable")
    xs, band = xs[order], band[order]
    inside = np.flatnonzero(band <= 0.0)
    if inside.size == 0:
        if nearer_low_end:
            return point, 0.0, e_min, "below prior"
        return point, e_max, math.inf, "above prior"
    i0, i1 = inside[0], inside[-1]

    def h(t: float) -> float:
        return abs(radius_at(t) - y) - tol

    lower = 0.0 if i0 == 0 else math.exp(_root(h, xs[i0 - 1], xs[i0]))
    upper = math.inf if i1 == xs.size - 1 else math.exp(_root(h, xs[i1], xs[i1 + 1]))
    status = {(False, False): "inside", (True, False): "extends below prior",
              (False, True): "extends above prior", (True, True): "extends beyond both ends"}
    return point, lower, upper, status[(lower == 0.0, upper == math.inf)]


def case_modulus_intervals(problem: CalibrationProblem, tolerance_mm: float, poisson: float | None = None,
                           grid_points: int = 129) -> CaseIntervals:
    """Range of E reproducing each measured radius on its own (the paper's Fig. 3).

    For each case the model radius (mean, no discrepancy) is tabulated on
    `grid_points` values of log E over the prior range, and the crossings of
    ``measured`` and ``measured +/- tolerance_mm`` are refined with Brent's
    method on the model itself. The grid only has to bracket the crossings: a
    model monotone in E (as the film radius is) needs few points.

    Parameters
    ----------
    problem : CalibrationProblem
    tolerance_mm : float
        Half-width of the band of radii that counts as reproducing the
        measurement (e.g. the posterior median of sigma), > 0.
    poisson : float, optional
        nu for the model; default the fixed nu of the priors.
    grid_points : int, default 129
        Values of log E tabulated per case (>= 2).

    Returns
    -------
    CaseIntervals
    """
    tolerance_mm = float(tolerance_mm)
    if not (math.isfinite(tolerance_mm) and tolerance_mm > 0.0):
        raise ValueError(f"tolerance_mm must be finite and > 0, got {tolerance_mm!r}")
    if isinstance(grid_points, bool) or not isinstance(grid_points, (int, np.integer)) or grid_points < 2:
        raise ValueError(f"grid_points must be an integer >= 2, got {grid_points!r}")
    nu = float(problem.priors.poisson if poisson is None else poisson)
    lo, hi = problem.log_modulus_bounds
    x = np.linspace(lo, hi, int(grid_points))
    data = problem.data
    table, _ = problem.model_radius(np.exp(x), np.full(x.size, nu))
    out = []
    solved: dict[tuple[float, float, float], tuple] = {}  # repeats that read alike are inverted once
    for i in range(len(data)):
        R, F = data.sphere_radius_mm[i:i + 1], data.force_n[i:i + 1]
        key = (float(R[0]), float(F[0]), float(problem.target_radius_mm[i]))
        if key not in solved:
            def radius_at(t: float, R=R, F=F) -> float:
                return float(problem.model_radius(np.array([math.exp(t)]), np.array([nu]), R, F)[0][0, 0])

            solved[key] = _invert_case(radius_at, x, table[:, i], key[2], tolerance_mm)
        out.append(solved[key])
    point, lower, upper, status = zip(*out)
    return CaseIntervals(sphere_radius_mm=data.sphere_radius_mm.copy(), force_n=data.force_n.copy(),
                         measured_radius_mm=problem.target_radius_mm.copy(), modulus_mpa=np.array(point),
                         lower_mpa=np.array(lower), upper_mpa=np.array(upper), tolerance_mm=tolerance_mm,
                         poisson=nu, modulus_range_mpa=(math.exp(lo), math.exp(hi)), status=list(status))
