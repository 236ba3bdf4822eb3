"""Statistical model of the film calibration: priors, likelihood, posterior density.

For one film type, the radius of the patch printed on the film in case i
(sphere radius R_i, force F_i) is modelled as::

    r_i = model_radius(E, nu, R_i, F_i) + delta_{F_i} + eps_i,
    eps_i ~ N(0, sigma^2 + s_i^2)

where ``s_i`` is the predictive std of the model (a Gaussian-process surrogate's
own uncertainty; 0 for an exact model), ``sigma`` is the scatter of the
experiments (inferred, never fixed to 0: Table 1 repeats disagree by 0.1-0.3 mm)
and ``delta_F`` an optional model-discrepancy offset per load level.

Priors (stated in `Priors`):

- E: log-uniform over 50-20000 MPa; the sampler works in ``log E``.
- nu: fixed at 0.33 as in the paper (section 2.1), or uniform over 0.29-0.37,
  the range measured on thin PET films that the paper cites.
- sigma: half-Cauchy with scale 0.2 mm (default; weakly informative, puts its
  mass at the scatter seen between Table 1 repeats while letting the data
  decide larger values, as recommended for scale parameters estimated from few
  groups by Gelman, Bayesian Analysis 1(3), 2006), or log-uniform over
  0.001-2 mm. The sampler works in ``log sigma``.
- delta_F (discrepancy option ``"load"``): independent N(0, 0.2 mm) per load
  level. A Kennedy-O'Hagan Gaussian-process discrepancy over (R, F) is not
  implemented.

Identifiability: a thin film held laterally is compressed oedometrically, so in
a small-strain model the radius depends on (E, nu) only through the oedometric
modulus ``M = E (1 - nu) / ((1 + nu)(1 - 2 nu))``. With nu free, the data
constrain M; the marginal of E then mostly reflects the nu prior and is not a
finding about the film.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from filmcal.elastic import oedometric_ratio
from filmcal._validation import check_choice, check_positive
from filmcal.calibration.data import RadiusErrorData

__all__ = [
    "RadiusModel",
    "Priors",
    "CalibrationProblem",
    "POISSON_MODES",
    "SIGMA_PRIORS",
    "DISCREPANCY_MODES",
    "oedometric_ratio",
]

POISSON_MODES = ("fixed", "free")
SIGMA_PRIORS = ("half-cauchy", "log-uniform")
DISCREPANCY_MODES = ("none", "load")


@runtime_checkable
class RadiusModel(Protocol):
    """What the calibration needs from a model of the printed contact radius.

    ``predict`` is vectorised over broadcastable arrays (the calibration passes
    1-D arrays of equal length) and returns the mean radius (mm) and its
    predictive std (mm; 0 for an exact model such as the FE model itself).
    """

    def predict(self, modulus_mpa: np.ndarray, poisson: np.ndarray, sphere_radius_mm: np.ndarray,
                force_n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ...


@dataclass(frozen=True)
class Priors:
    """Prior distributions of the calibration parameters.

    Parameters
    ----------
    modulus_range_mpa : (float, float), default (50, 20000)
        Support of the log-uniform prior of Young's modulus E (MPa).
    poisson : float, default 0.33
        Poisson's ratio when it is fixed (the paper's value).
    poisson_range : (float, float), default (0.29, 0.37)
        Support of the uniform prior of nu when it is free (thin PET films).
    sigma_prior : {"half-cauchy", "log-uniform"}, default "half-cauchy"
        Prior of the experimental scatter sigma.
    sigma_scale_mm : float, default 0.2
        Scale of the half-Cauchy prior (mm).
    sigma_range_mm : (float, float), default (0.001, 2.0)
        Support of the log-uniform prior (mm).
    discrepancy_scale_mm : float, default 0.2
        Std of the normal prior of each per-load offset delta_F (mm).
    """

    modulus_range_mpa: tuple[float, float] = (50.0, 20000.0)
    poisson: float = 0.33
    poisson_range: tuple[float, float] = (0.29, 0.37)
    sigma_prior: str = "half-cauchy"
    sigma_scale_mm: float = 0.2
    sigma_range_mm: tuple[float, float] = (0.001, 2.0)
    discrepancy_scale_mm: float = 0.2

    def __post_init__(self) -> None:
        _check_interval("modulus_range_mpa", self.modulus_range_mpa, 0.0, math.inf)
        _check_interval("poisson_range", self.poisson_range, -1.0, 0.5)
        _check_interval("sigma_range_mm", self.sigma_range_mm, 0.0, math.inf)
        if not -1.0 < float(self.poisson) < 0.5:
            raise ValueError(f"poisson must lie in (-1, 0.5), got {self.poisson!r}")
        check_choice("sigma_prior", self.sigma_prior, SIGMA_PRIORS)
        check_positive("sigma_scale_mm", self.sigma_scale_mm)
        check_positive("discrepancy_scale_mm", self.discrepancy_scale_mm)

    def to_dict(self) -> dict:
        """The priors as plain JSON values."""
        return {
            "modulus_mpa": {"distribution": "log-uniform", "range": list(self.modulus_range_mpa)},
            "poisson": {"fixed_value": self.poisson, "free_distribution": "uniform",
                        "free_range": list(self.poisson_range)},
            "sigma_mm": ({"distribution": "half-cauchy", "scale": self.sigma_scale_mm}
                         if self.sigma_prior == "half-cauchy" else
                         {"distribution": "log-uniform", "range": list(self.sigma_range_mm)}),
            "delta_mm": {"distribution": "normal", "scale": self.discrepancy_scale_mm},
        }

    @classmethod
    def from_dict(cls, d: dict) -> Priors:
        """Inverse of `to_dict`."""
        sigma = d["sigma_mm"]
        half_cauchy = sigma["distribution"] == "half-cauchy"
        return cls(modulus_range_mpa=tuple(d["modulus_mpa"]["range"]),
                   poisson=d["poisson"]["fixed_value"],
                   poisson_range=tuple(d["poisson"]["free_range"]),
                   sigma_prior=sigma["distribution"],
                   sigma_scale_mm=sigma["scale"] if half_cauchy else cls.sigma_scale_mm,
                   sigma_range_mm=cls.sigma_range_mm if half_cauchy else tuple(sigma["range"]),
                   discrepancy_scale_mm=d["delta_mm"]["scale"])


def _check_interval(name: str, value: object, low: float, high: float) -> None:
    try:
        lo, hi = (float(v) for v in value)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not (low < lo < hi < high) or not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{name} must satisfy {low:g} < low < high < {high:g}, got {value!r}")


class CalibrationProblem:
    """Posterior density of the film parameters given the radii of one film type.

    Sampled coordinates, in this order: ``log_modulus`` (ln E, E in MPa) when
    nu is fixed, or ``log_oedometric_modulus`` (ln M) and ``poisson`` when nu
    is free; then ``log_sigma`` (ln sigma, mm) and, with
    ``discrepancy="load"``, one ``delta_<F>kn`` (mm) per load level present in
    the data. See the module docstring for the model and priors.

    With nu free the sampler works in (ln M, nu): the data constrain M, so the
    posterior is close to a product of an M factor and the nu prior, whereas
    in (ln E, nu) it is a narrow curved ridge ``ln E = ln M - ln(M/E)(nu)``
    that the ensemble moves explore slowly. The prior is the same in both
    coordinates (log-uniform E, uniform nu; the map has unit Jacobian).

    Parameters
    ----------
    data : RadiusErrorData
        Rows of Table 1 for one film type (at least 2).
    model : RadiusModel
        Model of the printed radius.
    priors : Priors, optional
    poisson : {"fixed", "free"}, default "fixed"
        Fix nu at ``priors.poisson`` or sample it. With nu free, only M is
        identified by sphere-on-flat radii (module docstring).
    discrepancy : {"none", "load"}, default "none"
        ``"load"`` adds an offset delta_F per load level.
    """

    def __init__(self, data: RadiusErrorData, model: RadiusModel, priors: Priors | None = None,
                 poisson: str = "fixed", discrepancy: str = "none") -> None:
        if len(data) < 2:
            raise ValueError(f"the calibration needs at least 2 measured radii, got {len(data)}")
        if not callable(getattr(model, "predict", None)):
            raise ValueError("model must have a method predict(modulus_mpa, poisson, sphere_radius_mm, force_n)")
        self.data = data
        self.model = model
        self.priors = Priors() if priors is None else priors
        self.poisson_mode = check_choice("poisson", poisson, POISSON_MODES)
        self.discrepancy = check_choice("discrepancy", discrepancy, DISCREPANCY_MODES)
        self.load_levels_n = np.unique(data.force_n)
        self.level_index = np.searchsorted(self.load_levels_n, data.force_n)
        self.parameter_names = self._names()
        self.ndim = len(self.parameter_names)

    # ----------------------------------------------------------- parameters
    @property
    def delta_names(self) -> list[str]:
        """Names of the per-load offsets (empty without discrepancy)."""
        if self.discrepancy != "load":
            return []
        return [f"delta_{f / 1000.0:g}kn" for f in self.load_levels_n]

    def _names(self) -> list[str]:
        names = ["log_oedometric_modulus", "poisson"] if self.poisson_mode == "free" else ["log_modulus"]
        names.append("log_sigma")
        return names + self.delta_names

    @property
    def log_modulus_bounds(self) -> tuple[float, float]:
        """ln E at the ends of the prior range."""
        lo, hi = self.priors.modulus_range_mpa
        return math.log(lo), math.log(hi)

    def unpack(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Physical parameters of sampled coordinates.

        Parameters
        ----------
        theta : ndarray of shape (..., ndim)

        Returns
        -------
        dict
            ``modulus_mpa``, ``poisson``, ``oedometric_modulus_mpa``,
            ``sigma_mm`` (each of shape ``theta.shape[:-1]``) and ``delta_mm``
            of shape ``theta.shape[:-1] + (n_levels,)`` (zeros without discrepancy).
        """
        theta = np.asarray(theta, dtype=float)
        if theta.shape[-1] != self.ndim:
            raise ValueError(f"theta must have {self.ndim} columns {self.parameter_names}, got {theta.shape}")
        col = {name: k for k, name in enumerate(self.parameter_names)}
        if "poisson" in col:
            nu = theta[..., col["poisson"]]
            oedometric = np.exp(theta[..., col["log_oedometric_modulus"]])
            modulus = oedometric / oedometric_ratio(nu)
        else:
            modulus = np.exp(theta[..., col["log_modulus"]])
            nu = np.full(modulus.shape, float(self.priors.poisson))
            oedometric = modulus * oedometric_ratio(nu)
        if self.discrepancy == "load":
            delta = theta[..., col[self.delta_names[0]]:]
        else:
            delta = np.zeros(modulus.shape + (self.load_levels_n.size,))
        return {
            "modulus_mpa": modulus,
            "poisson": nu,
            "oedometric_modulus_mpa": oedometric,
            "sigma_mm": np.exp(theta[..., col["log_sigma"]]),
            "delta_mm": delta,
        }

    def named_samples(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Reported quantities of sampled coordinates, by name.

        ``modulus_mpa``, ``poisson`` (only when free), ``oedometric_modulus_mpa``,
        ``sigma_mm`` and ``delta_<F>kn_mm`` per load level (with discrepancy),
        each of shape ``theta.shape[:-1]``.
        """
        p = self.unpack(theta)
        out = {"modulus_mpa": p["modulus_mpa"]}
        if self.poisson_mode == "free":
            out["poisson"] = p["poisson"]
        out["oedometric_modulus_mpa"] = p["oedometric_modulus_mpa"]
        out["sigma_mm"] = p["sigma_mm"]
        for j, name in enumerate(self.delta_names):
            out[f"{name}_mm"] = p["delta_mm"][..., j]
        return out

    # ---------------------------------------------------------------- model
    def model_radius(self, modulus_mpa: np.ndarray, poisson: np.ndarray,
                     sphere_radius_mm: np.ndarray | None = None, force_n: np.ndarray | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Model mean and std of the radius for k parameter sets at every data point.

        Parameters
        ----------
        modulus_mpa, poisson : ndarray of shape (k,)
        sphere_radius_mm, force_n : ndarray of shape (n,), optional
            Cases to evaluate; default the data's.

        Returns
        -------
        mean, std : ndarray of shape (k, n)

        Raises
        ------
        ValueError
            If the model returns a wrong shape, a non-finite value or a negative std.
        """
        R = self.data.sphere_radius_mm if sphere_radius_mm is None else np.asarray(sphere_radius_mm, dtype=float)
        F = self.data.force_n if force_n is None else np.asarray(force_n, dtype=float)
        E = np.atleast_1d(np.asarray(modulus_mpa, dtype=float))
        nu = np.broadcast_to(np.atleast_1d(np.asarray(poisson, dtype=float)), E.shape)
        k, n = E.size, R.size
        args = (np.repeat(E, n), np.repeat(nu, n), np.tile(R, k), np.tile(F, k))
        mean, std = self.model.predict(*args)
        try:
            mean = np.broadcast_to(np.asarray(mean, dtype=float), (k * n,))
            std = np.broadcast_to(np.asarray(std, dtype=float), (k * n,))
        except ValueError:
            raise ValueError(f"model.predict must return (mean, std) broadcastable to shape ({k * n},), "
                             f"got shapes {np.shape(mean)} and {np.shape(std)}") from None
        bad = ~np.isfinite(mean) | ~np.isfinite(std) | (std < 0.0)
        if np.any(bad):
            j = int(np.flatnonzero(bad)[0])
            raise ValueError(
                f"model returned mean={float(mean[j])!r}, std={float(std[j])!r} (need finite values, std >= 0) at "
                f"modulus_mpa={args[0][j]:g}, poisson={args[1][j]:g}, sphere_radius_mm={args[2][j]:g}, "
                f"force_n={args[3][j]:g}")
        return mean.reshape(k, n), std.reshape(k, n)

    # ------------------------------------------------------------- density
    def log_prior(self, theta: np.ndarray) -> np.ndarray:
        """Log prior density of sampled coordinates (Jacobians of the log maps included).

        Parameters
        ----------
        theta : ndarray of shape (k, ndim)

        Returns
        -------
        ndarray of shape (k,)
            -inf outside the support.
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        p = self.unpack(theta)
        lo, hi = self.log_modulus_bounds
        log_e = np.log(p["modulus_mpa"])
        lp = np.where((log_e >= lo) & (log_e <= hi), -math.log(hi - lo), -np.inf)
        if self.poisson_mode == "free":
            nlo, nhi = self.priors.poisson_range
            nu = p["poisson"]
            lp = lp + np.where((nu >= nlo) & (nu <= nhi), -math.log(nhi - nlo), -np.inf)
        lp = lp + self._log_prior_log_sigma(np.log(p["sigma_mm"]))
        if self.discrepancy == "load":
            s = self.priors.discrepancy_scale_mm
            d = p["delta_mm"]
            lp = lp + np.sum(-0.5 * (d / s) ** 2 - math.log(s) - 0.5 * math.log(2.0 * math.pi), axis=-1)
        return lp

    def _log_prior_log_sigma(self, log_sigma: np.ndarray) -> np.ndarray:
        if self.priors.sigma_prior == "log-uniform":
            lo, hi = (math.log(v) for v in self.priors.sigma_range_mm)
            return np.where((log_sigma >= lo) & (log_sigma <= hi), -math.log(hi - lo), -np.inf)
        # half-Cauchy density of sigma times the Jacobian d sigma / d log sigma = sigma
        g = self.priors.sigma_scale_mm
        sigma = np.exp(log_sigma)
        return math.log(2.0 / (math.pi * g)) - np.log1p((sigma / g) ** 2) + log_sigma

    def log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Gaussian log likelihood of the measured radii (surrogate std added to sigma).

        Parameters
        ----------
        theta : ndarray of shape (k, ndim)

        Returns
        -------
        ndarray of shape (k,)
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        p = self.unpack(theta)
        mean, std = self.model_radius(p["modulus_mpa"], p["poisson"])
        var = p["sigma_mm"][:, None] ** 2 + std**2
        resid = self.data.measured_radius_mm[None, :] - mean - p["delta_mm"][:, self.level_index]
        return -0.5 * np.sum(resid**2 / var + np.log(2.0 * math.pi * var), axis=1)

    def log_posterior(self, theta: np.ndarray) -> np.ndarray:
        """Unnormalised log posterior; the model is only called inside the prior support.

        Parameters
        ----------
        theta : ndarray of shape (k, ndim)

        Returns
        -------
        ndarray of shape (k,)
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        lp = self.log_prior(theta)
        inside = np.isfinite(lp)
        if np.any(inside):
            lp[inside] = lp[inside] + self.log_likelihood(theta[inside])
        return lp


    def describe(self) -> dict:
        """The configuration as plain JSON values (stored with chains, checked on resume)."""
        return {
            "film": sorted(set(self.data.film.tolist())),
            "sphere_radius_mm": self.data.sphere_radius_mm.tolist(),
            "force_n": self.data.force_n.tolist(),
            "measured_radius_mm": self.data.measured_radius_mm.tolist(),
            "poisson": self.poisson_mode,
            "discrepancy": self.discrepancy,
            "priors": self.priors.to_dict(),
            "parameter_names": list(self.parameter_names),
        }
