"""Statistical model of the film calibration: priors, likelihood, posterior density.

For one film type, the radius of imprint j of case i (sphere radius R_i,
force F_i; a case's imprints are its repeats) is modelled as::

    r_ij = model_radius(E, nu, R_i, F_i) + delta_{F_i} + g_i + b_i + eps_ij,
    eps_ij ~ N(0, sigma^2 + u_ij^2),   g_i ~ N(0, s_i^2),   b_i ~ N(0, tau^2)

where ``s_i`` is the predictive std of the model (a Gaussian-process surrogate's
own uncertainty; 0 for an exact model), ``u_ij`` the measurement uncertainty
stated in the dataset (0 when not stated), ``sigma`` the scatter of one imprint
(inferred, never fixed to 0: Table 1 repeats disagree by 0.1-0.3 mm),
``delta_F`` an optional model-discrepancy offset per load level and ``b_i`` an
optional case-level scatter. The model's error g_i is shared by the repeats of
a case (they have the same R and F), and so is b_i; both are integrated out
analytically, so that a case's imprints are jointly normal with covariance
``diag(sigma^2 + u_ij^2) + (s_i^2 + tau^2) 1 1^T``. For one imprint per case
this is the independent likelihood with variance ``sigma^2 + u_i^2 + s_i^2
(+ tau^2)``.

Repeats and identifiability: the spread of a case's repeats about their mean
informs sigma alone; the spread of the case means about the model informs
``sigma^2 / n_i + tau^2``. tau is therefore identified only when some case has
at least two imprints, and the default (``case_scatter="auto"``) adds it only
then. It is what a day-to-day or sphere-to-sphere effect looks like: without
it, repeats that agree with each other but not with the model would make the
posterior of E too narrow.

Pointwise log-likelihood (for PSIS-LOO and model comparison): the joint
density of a case is split by the chain rule into one term per imprint,
``log p(r_ij | r_i1 .. r_i(j-1), theta)``, so that the terms of a case add up to
its joint density and those of all cases to the likelihood. With one imprint
per case (Table 1) the terms are the independent row densities; with repeats
the meaningful unit to leave out is the case (`CalibrationProblem.case_log_likelihood`).

Priors (stated in `Priors`):

- E: log-uniform over 50-20000 MPa; the sampler works in ``log E``.
- nu: fixed at 0.33 as in the paper (section 2.1), or uniform over 0.29-0.37,
  the range measured on thin PET films that the paper cites.
- sigma: half-Cauchy with scale 0.2 mm (default; weakly informative, puts its
  mass at the scatter seen between Table 1 repeats while letting the data
  decide larger values, as recommended for scale parameters estimated from few
  groups by Gelman, Bayesian Analysis 1(3), 2006), or log-uniform over
  0.001-2 mm. The sampler works in ``log sigma``. Below `SIGMA_FLOOR_MM`
  (0.1 um, finer than any reading of an imprint) the half-Cauchy is cut: with
  repeats that read alike (a ruler's 0.1 mm steps) the likelihood no longer
  falls as sigma -> 0, and the posterior would be improper there.
- tau (case-level scatter): half-Cauchy with scale 0.1 mm, sampled in ``log tau``.
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
from filmcal.films import FILM_POISSON, FilmType

__all__ = [
    "RadiusModel",
    "Priors",
    "CalibrationProblem",
    "POISSON_MODES",
    "SIGMA_PRIORS",
    "DISCREPANCY_MODES",
    "CASE_SCATTER_MODES",
    "oedometric_ratio",
]

POISSON_MODES = ("fixed", "free")
SIGMA_PRIORS = ("half-cauchy", "log-uniform")
DISCREPANCY_MODES = ("none", "load")
CASE_SCATTER_MODES = ("auto", "none", "case")


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
    poisson : float, default `filmcal.films.FILM_POISSON` (0.33)
        Poisson's ratio when it is fixed (the paper's value; `for_film` takes
        a film type's nominal value).
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
    case_scale_mm : float, default 0.1
        Scale of the half-Cauchy prior of the case-level scatter tau (mm).
    """

    modulus_range_mpa: tuple[float, float] = (50.0, 20000.0)
    poisson: float = FILM_POISSON
    poisson_range: tuple[float, float] = (0.29, 0.37)
    sigma_prior: str = "half-cauchy"
    sigma_scale_mm: float = 0.2
    sigma_range_mm: tuple[float, float] = (0.001, 2.0)
    discrepancy_scale_mm: float = 0.2
    case_scale_mm: float = 0.1

    @classmethod
    def for_film(cls, film: FilmType, **kwargs) -> Priors:
        """Default priors with nu fixed at the film type's nominal Poisson's ratio."""
        if not isinstance(film, FilmType):
            raise ValueError(f"film must be a filmcal.films.FilmType, got {type(film).__name__}")
        return cls(**{"poisson": film.poisson, **kwargs})

    def __post_init__(self) -> None:
        _check_interval("modulus_range_mpa", self.modulus_range_mpa, 0.0, math.inf)
        _check_interval("poisson_range", self.poisson_range, -1.0, 0.5)
        _check_interval("sigma_range_mm", self.sigma_range_mm, 0.0, math.inf)
        if not -1.0 < float(self.poisson) < 0.5:
            raise ValueError(f"poisson must lie in (-1, 0.5), got {self.poisson!r}")
        check_choice("sigma_prior", self.sigma_prior, SIGMA_PRIORS)
        check_positive("sigma_scale_mm", self.sigma_scale_mm)
        check_positive("discrepancy_scale_mm", self.discrepancy_scale_mm)
        check_positive("case_scale_mm", self.case_scale_mm)

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
            "case_sigma_mm": {"distribution": "half-cauchy", "scale": self.case_scale_mm},
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
                   discrepancy_scale_mm=d["delta_mm"]["scale"],
                   case_scale_mm=d.get("case_sigma_mm", {}).get("scale", cls.case_scale_mm))


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
    is free; then ``log_sigma`` (ln sigma, mm), ``log_case_sigma`` (ln tau, mm)
    with the case-level scatter and, with ``discrepancy="load"``, one
    ``delta_<F>kn`` (mm) per load level present in the data. See the module docstring for the model and priors.

    With nu free the sampler works in (ln M, nu): the data constrain M, so the
    posterior is close to a product of an M factor and the nu prior, whereas
    in (ln E, nu) it is a narrow curved ridge ``ln E = ln M - ln(M/E)(nu)``
    that the ensemble moves explore slowly. The prior is the same in both
    coordinates (log-uniform E, uniform nu; the map has unit Jacobian).

    Parameters
    ----------
    data : RadiusErrorData
        Measured radii of one film type (at least 2), e.g. rows of Table 1 or
        ``load_dataset(path).select(film)``.
    model : RadiusModel
        Model of the printed radius.
    priors : Priors, optional
    poisson : {"fixed", "free"}, default "fixed"
        Fix nu at ``priors.poisson`` or sample it. With nu free, only M is
        identified by sphere-on-flat radii (module docstring).
    discrepancy : {"none", "load"}, default "none"
        ``"load"`` adds an offset delta_F per load level.
    case_scatter : {"auto", "none", "case"}, default "auto"
        Case-level scatter tau: ``"auto"`` adds it when some case has
        repeats (only then is it identified), ``"case"`` always, ``"none"``
        never.
    film : FilmType, optional
        The film calibrated; the data must hold only this film. Its nominal
        nu is used when `priors` is not given.
    rough_flat : RoughFlatGrowth, optional
        Needed when rows have ``flat_ra_um > 0``: their model radius is the
        smooth one times the film model's rough-flat growth
        (`filmcal.calibration.roughness.RoughFlatGrowth`).
    """

    def __init__(self, data: RadiusErrorData, model: RadiusModel, priors: Priors | None = None,
                 poisson: str = "fixed", discrepancy: str = "none", case_scatter: str = "auto",
                 film: FilmType | None = None, rough_flat=None) -> None:
        if film is not None:
            if not isinstance(film, FilmType):
                raise ValueError(f"film must be a filmcal.films.FilmType, got {type(film).__name__}")
            others = sorted(set(np.asarray(data.film).tolist()) - {film.name})
            if others:
                raise ValueError(f"data hold film(s) {', '.join(others)} besides {film.name}; select one film")
            if priors is None:
                priors = Priors.for_film(film)
        self.film = film
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
        mode = check_choice("case_scatter", case_scatter, CASE_SCATTER_MODES)
        self.case_scatter = mode == "case" or (mode == "auto" and data.has_repeats)
        self.case_index = np.asarray(data.case_index)
        self.n_cases = int(data.n_cases)
        self._repeats = bool(data.has_repeats)
        # position of each row within its case (0 for the first imprint), for the sequential likelihood
        self._position = np.zeros(len(data), dtype=int)
        counts: dict[int, int] = {}
        for i, c in enumerate(self.case_index):
            self._position[i] = counts.get(int(c), 0)
            counts[int(c)] = self._position[i] + 1
        self._measurement_var = np.asarray(data.measurement_std_mm, dtype=float) ** 2
        ra = np.asarray(data.flat_ra_um if data.flat_ra_um is not None else np.full(len(data), np.nan), float)
        self.rough_flat = None
        if np.any(np.isfinite(ra) & (ra > 0)):
            if rough_flat is None:
                raise ValueError("rows with flat_ra_um > 0 were measured on a roughened flat: the calibration needs "
                                 "the film model's rough-flat growth (rough_flat=RoughFlatGrowth(...)) to use them")
            rough_flat.prepare(data)
            self.rough_flat = rough_flat
        self.target_radius_mm = np.asarray(data.target_radius_mm, dtype=float)
        self._predictor = self._case_table()
        # the data's rows as the table's cases: a sampler's steps then evaluate the table once per modulus
        case_index = getattr(self._predictor, "case_index", None)
        self._row_cases = None if case_index is None else case_index(data.sphere_radius_mm, data.force_n)
        if self._row_cases is not None and np.any(self._row_cases < 0):
            self._row_cases = None
        self.parameter_names = self._names()
        self.ndim = len(self.parameter_names)

    def _case_table(self):
        """The model as the sampler calls it: with nu fixed, a model that offers ``restricted_to`` (a cheap
        surrogate) is tabulated at the data's cases along ln E (`filmcal.surrogate.radius.CaseTable`)."""
        restrict = getattr(self.model, "restricted_to", None)
        if self.poisson_mode != "fixed" or restrict is None:
            return self.model
        cases = zip(np.asarray(self.data.sphere_radius_mm, float), np.asarray(self.data.force_n, float))
        return restrict(cases, self.priors.poisson, self.priors.modulus_range_mpa)

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
        if self.case_scatter:
            names.append("log_case_sigma")
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
            ``sigma_mm``, ``case_sigma_mm`` (zero without the case-level
            scatter; each of shape ``theta.shape[:-1]``) and ``delta_mm``
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
            "case_sigma_mm": (np.exp(theta[..., col["log_case_sigma"]]) if self.case_scatter
                              else np.zeros(modulus.shape)),
            "delta_mm": delta,
        }

    def named_samples(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        """Reported quantities of sampled coordinates, by name.

        ``modulus_mpa``, ``poisson`` (only when free), ``oedometric_modulus_mpa``,
        ``sigma_mm``, ``case_sigma_mm`` (with the case-level scatter) and
        ``delta_<F>kn_mm`` per load level (with discrepancy), each of shape
        ``theta.shape[:-1]``. `theta_from_named` is the inverse.
        """
        p = self.unpack(theta)
        out = {"modulus_mpa": p["modulus_mpa"]}
        if self.poisson_mode == "free":
            out["poisson"] = p["poisson"]
        out["oedometric_modulus_mpa"] = p["oedometric_modulus_mpa"]
        out["sigma_mm"] = p["sigma_mm"]
        if self.case_scatter:
            out["case_sigma_mm"] = p["case_sigma_mm"]
        for j, name in enumerate(self.delta_names):
            out[f"{name}_mm"] = p["delta_mm"][..., j]
        return out

    def theta_from_named(self, named: dict[str, np.ndarray]) -> np.ndarray:
        """Sampled coordinates of reported samples (the inverse of `named_samples`).

        Parameters
        ----------
        named : dict of str -> ndarray
            E.g. ``CalibrationResult.samples`` of a calibration of this problem.

        Returns
        -------
        ndarray of shape ``named["modulus_mpa"].shape + (ndim,)``
        """
        def get(key: str) -> np.ndarray:
            if key not in named:
                raise ValueError(f"samples lack {key!r}, needed by the parameters {self.parameter_names}")
            return np.asarray(named[key], dtype=float)

        columns = []
        for name in self.parameter_names:
            if name == "log_modulus":
                columns.append(np.log(get("modulus_mpa")))
            elif name == "log_oedometric_modulus":
                columns.append(np.log(get("oedometric_modulus_mpa")))
            elif name == "poisson":
                columns.append(get("poisson"))
            elif name == "log_sigma":
                columns.append(np.log(get("sigma_mm")))
            elif name == "log_case_sigma":
                columns.append(np.log(get("case_sigma_mm")))
            else:
                columns.append(get(f"{name}_mm"))
        return np.stack(np.broadcast_arrays(*columns), axis=-1)

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

        def points() -> tuple[np.ndarray, ...]:
            return np.repeat(E, n), np.repeat(nu, n), np.tile(R, k), np.tile(F, k)

        if self._row_cases is not None and sphere_radius_mm is None and force_n is None:
            mean, std = self._predictor.predict_cases(E, nu, self._row_cases)
            mean, std = mean.ravel(), std.ravel()
        else:
            mean, std = self._predictor.predict(*points())
        try:
            mean, std = (np.asarray(v, dtype=float) for v in (mean, std))
            mean, std = (v if v.shape == (k * n,) else np.broadcast_to(v, (k * n,)) for v in (mean, std))
        except ValueError:
            raise ValueError(f"model.predict must return (mean, std) broadcastable to shape ({k * n},), "
                             f"got shapes {np.shape(mean)} and {np.shape(std)}") from None
        bad = ~np.isfinite(mean) | ~np.isfinite(std) | (std < 0.0)
        if np.any(bad):
            j = int(np.flatnonzero(bad)[0])
            args = points()
            raise ValueError(
                f"model returned mean={float(mean[j])!r}, std={float(std[j])!r} (need finite values, std >= 0) at "
                f"modulus_mpa={args[0][j]:g}, poisson={args[1][j]:g}, sphere_radius_mm={args[2][j]:g}, "
                f"force_n={args[3][j]:g}")
        mean, std = mean.reshape(k, n), std.reshape(k, n)
        if self.rough_flat is not None and sphere_radius_mm is None and force_n is None:
            factor = self.rough_flat.radius_factor(E, self.data)  # rows measured on a roughened flat
            mean, std = mean * factor, std * factor
        return mean, std

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
        if self.case_scatter:
            lp = lp + _log_half_cauchy_log(np.log(p["case_sigma_mm"]), self.priors.case_scale_mm)
        if self.discrepancy == "load":
            s = self.priors.discrepancy_scale_mm
            d = p["delta_mm"]
            lp = lp + np.sum(-0.5 * (d / s) ** 2 - math.log(s) - 0.5 * math.log(2.0 * math.pi), axis=-1)
        return lp

    def _log_prior_log_sigma(self, log_sigma: np.ndarray) -> np.ndarray:
        if self.priors.sigma_prior == "log-uniform":
            lo, hi = (math.log(v) for v in self.priors.sigma_range_mm)
            return np.where((log_sigma >= lo) & (log_sigma <= hi), -math.log(hi - lo), -np.inf)
        return np.where(log_sigma >= math.log(SIGMA_FLOOR_MM),
                        _log_half_cauchy_log(log_sigma, self.priors.sigma_scale_mm), -np.inf)

    def _moments(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Mean of each imprint, its own variance and the variance its case shares, shape (k, n)."""
        p = self.unpack(theta)
        mean, std = self.model_radius(p["modulus_mpa"], p["poisson"])
        mu = mean + p["delta_mm"][:, self.level_index]
        own = p["sigma_mm"][:, None] ** 2 + self._measurement_var[None, :]
        shared = std**2 + p["case_sigma_mm"][:, None] ** 2
        return mu, own, shared

    def predictive_moments(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Mean and std of a new imprint of each row's case, given the parameters.

        The marginal of one imprint, ``N(model + delta_F, sigma^2 + u^2 + s^2 + tau^2)``
        (no conditioning on the case's other repeats): what a posterior
        predictive check compares each measured radius with.

        Parameters
        ----------
        theta : ndarray of shape (k, ndim)

        Returns
        -------
        mean_mm, std_mm : ndarray of shape (k, n)
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        mu, own, shared = self._moments(theta)
        return mu, np.sqrt(own + shared)

    def pointwise_log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Log likelihood of each measured radius: one term per data row.

        Row j of case i contributes ``log p(r_ij | r_i1 .. r_i(j-1), theta)``
        (module docstring): the terms add up to `log_likelihood`, and with one
        imprint per case they are the independent row densities.

        Parameters
        ----------
        theta : ndarray of shape (k, ndim)

        Returns
        -------
        ndarray of shape (k, n)
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        mu, own, shared = self._moments(theta)
        resid = self.target_radius_mm[None, :] - mu
        if not self._repeats:  # every row its case's first: the loop's one pass, without its bookkeeping
            var = own + shared
            return -0.5 * (resid**2 / var + np.log(2.0 * math.pi * var))
        k = theta.shape[0]
        out = np.empty_like(resid)
        # running sums of the earlier repeats of each case: sum 1/d and sum r/d
        acc_precision = np.zeros((k, self.n_cases))
        acc_weighted = np.zeros((k, self.n_cases))
        for position in range(int(self._position.max()) + 1 if len(self._position) else 0):
            rows = np.flatnonzero(self._position == position)
            cases = self.case_index[rows]
            c = shared[:, rows]
            a = acc_precision[:, cases]
            # the shared effect given the earlier repeats: mean c B / (1 + c A), variance c / (1 + c A); where
            # c A overflows (a scatter far below the case's), as B / (1/c + A) and 1 / (1/c + A)
            b = acc_weighted[:, cases]
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
                denom = 1.0 + c * a
                gain = c / denom
                cond_mean = c * b / denom
                bad = ~(np.isfinite(gain) & np.isfinite(cond_mean))
                if np.any(bad):
                    gain[bad] = 1.0 / (1.0 / c[bad] + a[bad])
                    cond_mean[bad] = gain[bad] * b[bad]
            var = own[:, rows] + gain
            r = resid[:, rows]
            out[:, rows] = -0.5 * ((r - cond_mean) ** 2 / var + np.log(2.0 * math.pi * var))
            acc_precision[:, cases] += 1.0 / own[:, rows]
            acc_weighted[:, cases] += r / own[:, rows]
        return out

    def case_log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Joint log likelihood of each case's imprints, shape (k, n_cases).

        The unit to leave out in cross-validation when cases have repeats.
        """
        pointwise = self.pointwise_log_likelihood(theta)
        out = np.zeros((pointwise.shape[0], self.n_cases))
        np.add.at(out.T, self.case_index, pointwise.T)
        return out

    def log_likelihood(self, theta: np.ndarray) -> np.ndarray:
        """Gaussian log likelihood of the measured radii (module docstring).

        Parameters
        ----------
        theta : ndarray of shape (k, ndim)

        Returns
        -------
        ndarray of shape (k,)
        """
        if not self._repeats:
            return self.pointwise_log_likelihood(theta).sum(axis=1)
        return self._case_closed_form(theta).sum(axis=1)

    def _case_closed_form(self, theta: np.ndarray) -> np.ndarray:
        """Each case's joint log density in closed form, shape (k, n_cases): linear in the rows.

        The case's covariance is ``D + c 1 1^T`` (own variances D, shared c), so with
        ``A = sum 1/d``, ``B = sum r/d``, ``Q = sum r^2/d`` its log density is
        ``-(n log 2 pi + sum log d + log(1 + c A) + Q - c B^2 / (1 + c A)) / 2`` (matrix
        determinant lemma and Sherman-Morrison): the same as the sequential terms of
        `pointwise_log_likelihood` summed, without their loop over the repeats (a case of
        many repeats costs one pass, not one pass per repeat).
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        mu, own, shared = self._moments(theta)
        resid = self.target_radius_mm[None, :] - mu
        k = theta.shape[0]

        def per_case(x: np.ndarray) -> np.ndarray:
            out = np.zeros((self.n_cases, k))
            np.add.at(out, self.case_index, x.T)
            return out.T

        a, b, q = per_case(1.0 / own), per_case(resid / own), per_case(resid**2 / own)
        log_d = per_case(np.log(2.0 * math.pi * own))
        c = np.empty((k, self.n_cases))
        c[:, self.case_index] = shared  # one value per case: its rows share their (R, F)
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            ca = c * a
            gain = np.where(np.isfinite(ca), c / (1.0 + ca), 1.0 / a)  # c / (1 + c A), also as c -> inf
            log_det = np.where(np.isfinite(ca), np.log1p(ca), np.log(c) + np.log(a))
        return -0.5 * (log_d + log_det + q - gain * b**2)

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
        """The configuration as plain JSON values (stored with chains, checked on resume).

        Keys of the dataset extensions (measurement uncertainty, body
        materials, repeats) appear only when they are used, so that chains of
        Table 1 stored before them still match.
        """
        priors = self.priors.to_dict()
        if not self.case_scatter:
            priors.pop("case_sigma_mm")
        d = {
            "film": sorted(set(self.data.film.tolist())),
            "sphere_radius_mm": self.data.sphere_radius_mm.tolist(),
            "force_n": self.data.force_n.tolist(),
            "measured_radius_mm": self.target_radius_mm.tolist(),
            "poisson": self.poisson_mode,
            "discrepancy": self.discrepancy,
            "priors": priors,
            "parameter_names": list(self.parameter_names),
        }
        if np.any(self._measurement_var > 0):
            d["measurement_std_mm"] = np.sqrt(self._measurement_var).tolist()
        if self.data.has_repeats:
            d["case_index"] = self.case_index.tolist()
        return d


#: The smallest scatter of one imprint's radius (mm) the half-Cauchy prior allows (module notes).
SIGMA_FLOOR_MM = 1e-4


def _log_half_cauchy_log(log_scale: np.ndarray, g: float) -> np.ndarray:
    """Log density of ln(s) when s is half-Cauchy with scale g (Jacobian ds/dln s = s included)."""
    s = np.exp(log_scale)
    return math.log(2.0 / (math.pi * g)) - np.log1p((s / g) ** 2) + log_scale
