"""The result of a film calibration: posterior summaries, diagnostics, checks, storage.

A `CalibrationResult` is saved as one JSON file (summaries, diagnostics,
checks, settings and the kept posterior samples); the full chain, burn-in
included, stays in the emcee HDF5 file named by ``backend_path`` (read it with
`filmcal.calibration.read_chain`). Loading parses JSON only: no pickle, no code.

For model comparison a posterior is also kept as ArviZ InferenceData with its
pointwise log-likelihood (`posterior_inference_data`), stored as NetCDF
(`save_posterior_netcdf`, `load_posterior_netcdf`).
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from filmcal._io import atomic_path, atomic_write_text
from filmcal._json import json_safe

from filmcal.calibration.checks import CaseIntervals, PredictiveCheck
from filmcal.calibration.diagnostics import Diagnostics
from filmcal.calibration.likelihood import Priors
from filmcal.calibration.result_file import FORMAT, FORMAT_VERSION, read_result_payload
from filmcal.calibration.sampling import SamplerSettings

__all__ = ["CalibrationResult", "summarize", "save_result", "load_result", "posterior_inference_data",
           "save_posterior_netcdf", "load_posterior_netcdf", "LOG_LIKELIHOOD_ROW", "LOG_LIKELIHOOD_CASE"]

def summarize(values: np.ndarray) -> dict:
    """Median, mean and central 90 % interval of posterior samples.

    Returns
    -------
    dict
        ``{"median": float, "mean": float, "ci90": [5 % quantile, 95 % quantile]}``.
    """
    values = np.asarray(values, dtype=float).ravel()
    lo, med, hi = np.quantile(values, [0.05, 0.5, 0.95])
    return {"median": float(med), "mean": float(np.mean(values)), "ci90": [float(lo), float(hi)]}


@dataclass(frozen=True)
class CalibrationResult:
    """Posterior of the film parameters of one film type, with its diagnostics and checks.

    Attributes
    ----------
    film : str
        Film type (MS, HS, HHS) or a label of the data.
    loads : str or None
        Load range of the data in kN (e.g. ``"50-100"``), None for all loads.
    n_data : int
        Measured radii used.
    poisson_mode : {"fixed", "free"}
    discrepancy : {"none", "load"}
    modulus_mpa, oedometric_modulus_mpa, sigma_mm : dict
        ``median``, ``mean`` and ``ci90`` [5 %, 95 % quantiles] of E (MPa),
        M (MPa) and the experimental scatter sigma (mm).
    poisson : dict
        ``{"fixed": value}``, or the summary of nu when it is free.
    delta_mm : dict of str -> dict
        Summary of each per-load offset (empty without discrepancy).
    diagnostics : Diagnostics
        R-hat, bulk and tail ESS per parameter, the verdict and its reasons.
    tau : dict of str -> float
        Integrated autocorrelation time of each sampled coordinate (steps).
    n_steps, n_walkers, burn_in, thin, n_steps_new : int
        Chain length per walker, walkers, discarded steps, thinning, and the
        steps added by this run (the rest were read from the backend).
    acceptance_fraction : float
        Mean acceptance fraction of the walkers.
    seed : int
    elapsed_s : float
        Wall time of the calibration.
    samples : dict of str -> ndarray of shape (n_walkers, n_draws)
        Kept posterior samples of every reported parameter.
    predictive : PredictiveCheck
    case_intervals : CaseIntervals
    priors : Priors
    settings : SamplerSettings
    backend_path : str or None
        HDF5 file of the full chain.
    notes : list of str
        What the numbers mean (identifiability of E and nu, what the
        discrepancy absorbs).
    """

    film: str
    loads: str | None
    n_data: int
    poisson_mode: str
    discrepancy: str
    modulus_mpa: dict
    oedometric_modulus_mpa: dict
    sigma_mm: dict
    poisson: dict
    delta_mm: dict
    diagnostics: Diagnostics
    tau: dict
    n_steps: int
    n_walkers: int
    burn_in: int
    thin: int
    n_steps_new: int
    acceptance_fraction: float
    seed: int
    elapsed_s: float
    samples: dict
    predictive: PredictiveCheck
    case_intervals: CaseIntervals
    priors: Priors
    settings: SamplerSettings
    backend_path: str | None = None
    notes: list[str] = field(default_factory=list)

    # --------------------------------------------------------- diagnostics
    @property
    def diagnostics_ok(self) -> bool:
        """True when the chain is long enough, R-hat <= 1.01 and bulk ESS >= 2000 (E, M)."""
        return self.diagnostics.ok

    @property
    def rhat(self) -> dict[str, float]:
        """Rank-normalised split R-hat of each parameter."""
        return self.diagnostics.rhat

    @property
    def ess_bulk(self) -> dict[str, float]:
        """Bulk effective sample size of each parameter."""
        return self.diagnostics.ess_bulk

    @property
    def ess_tail(self) -> dict[str, float]:
        """Tail (5 % / 95 % quantile) effective sample size of each parameter."""
        return self.diagnostics.ess_tail

    @property
    def mcse(self) -> dict[str, dict[str, float]]:
        """Monte Carlo standard error of each parameter's median, 5 % and 95 % quantiles (``median``,
        ``q05``, ``q95``; empty for results stored before it was computed)."""
        return self.diagnostics.mcse

    @property
    def rhat_max(self) -> float:
        """Worst (largest) R-hat over the parameters."""
        return self.diagnostics.worst_rhat

    @property
    def ess_min(self) -> float:
        """Worst (smallest) bulk ESS over the parameters."""
        return self.diagnostics.worst_ess

    @property
    def case_sigma_mm(self) -> dict | None:
        """Summary of the case-level scatter tau (mm); None when the calibration had none."""
        if "case_sigma_mm" not in self.samples:
            return None
        return summarize(self.samples["case_sigma_mm"])

    # ----------------------------------------------------------------- I/O
    def to_dict(self, include_samples: bool = False) -> dict:
        """JSON-ready dict (non-finite numbers as None).

        Holds the contract keys ``modulus_mpa`` {median, ci90},
        ``oedometric_modulus_mpa`` {median, ci90}, ``sigma_mm`` {median},
        ``rhat`` and ``ess`` (worst over the parameters) and ``n_data``, then
        the per-parameter diagnostics, the checks and the settings.

        Parameters
        ----------
        include_samples : bool, default False
            Add the kept posterior samples (``samples``: name -> walkers x draws).
        """
        d = {
            "film": self.film, "loads": self.loads, "n_data": self.n_data,
            "modulus_mpa": self.modulus_mpa, "oedometric_modulus_mpa": self.oedometric_modulus_mpa,
            "sigma_mm": self.sigma_mm, "poisson": self.poisson, "delta_mm": self.delta_mm,
            "rhat": self.rhat_max, "ess": self.ess_min,
            "diagnostics_ok": self.diagnostics_ok, "diagnostics": self.diagnostics.to_dict(),
            "tau": self.tau, "n_steps": self.n_steps, "n_walkers": self.n_walkers, "burn_in": self.burn_in,
            "thin": self.thin, "n_steps_new": self.n_steps_new, "acceptance_fraction": self.acceptance_fraction,
            "seed": self.seed, "elapsed_s": self.elapsed_s,
            "poisson_mode": self.poisson_mode, "discrepancy": self.discrepancy,
            "predictive_check": self.predictive.to_dict(), "case_intervals": self.case_intervals.to_dict(),
            "priors": self.priors.to_dict(), "settings": self.settings.to_dict(),
            "backend_path": self.backend_path, "notes": list(self.notes),
        }
        if self.case_sigma_mm is not None:
            d["case_sigma_mm"] = self.case_sigma_mm
        if include_samples:
            d["samples"] = {k: np.asarray(v).tolist() for k, v in self.samples.items()}
        return json_safe(d)

    @classmethod
    def from_dict(cls, d: dict) -> CalibrationResult:
        """Inverse of ``to_dict(include_samples=True)``."""
        if "samples" not in d:
            raise ValueError("the result holds no samples; save it with include_samples=True")
        return cls(
            film=d["film"], loads=d["loads"], n_data=int(d["n_data"]), poisson_mode=d["poisson_mode"],
            discrepancy=d["discrepancy"], modulus_mpa=d["modulus_mpa"],
            oedometric_modulus_mpa=d["oedometric_modulus_mpa"], sigma_mm=d["sigma_mm"], poisson=d["poisson"],
            delta_mm=d["delta_mm"], diagnostics=Diagnostics.from_dict(d["diagnostics"]), tau=d["tau"],
            n_steps=int(d["n_steps"]), n_walkers=int(d["n_walkers"]), burn_in=int(d["burn_in"]),
            thin=int(d["thin"]), n_steps_new=int(d["n_steps_new"]),
            acceptance_fraction=float(d["acceptance_fraction"]), seed=int(d["seed"]),
            elapsed_s=float(d["elapsed_s"]),
            samples={k: np.asarray(v, dtype=float) for k, v in d["samples"].items()},
            predictive=PredictiveCheck.from_dict(d["predictive_check"]),
            case_intervals=CaseIntervals.from_dict(d["case_intervals"]),
            priors=Priors.from_dict(d["priors"]), settings=SamplerSettings(**d["settings"]),
            backend_path=d["backend_path"], notes=list(d["notes"]))


def save_result(result: CalibrationResult, path: str | Path) -> Path:
    """Write a result as JSON (samples included); the chain stays in its HDF5 file.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    payload = {"format": FORMAT, "version": FORMAT_VERSION, **result.to_dict(include_samples=True)}
    # whole or not at all: an interrupted save leaves no truncated result
    atomic_write_text(path, json.dumps(payload, allow_nan=False) + "\n")
    return path


def load_result(path: str | Path) -> CalibrationResult:
    """Read a result written by `save_result` (plain JSON, nothing executed)."""
    return CalibrationResult.from_dict(read_result_payload(path))


# ------------------------------------------------------------------ InferenceData (NetCDF)
#: Log-likelihood variables kept with a posterior: one term per data row, and the joint per case.
LOG_LIKELIHOOD_ROW = "radius"
LOG_LIKELIHOOD_CASE = "case"


def posterior_inference_data(problem, samples: dict | np.ndarray, model_name: str = "model",
                             max_draws: int | None = None, attrs: dict | None = None):
    """A posterior with its pointwise log-likelihood as ArviZ InferenceData.

    Groups: ``posterior`` (every reported parameter, with ``poisson`` also when
    fixed, so that a corrector finds it), ``log_likelihood`` (``radius``: one
    term per data row, ``case``: the joint of each case; see
    `filmcal.calibration.likelihood`), ``observed_data`` (the radius compared
    with the model) and ``constant_data`` (R, F, case of each row, stated
    measurement uncertainty).

    Parameters
    ----------
    problem : CalibrationProblem
        The problem the samples belong to.
    samples : dict of str -> ndarray of shape (chains, draws), or ndarray of shape (chains, draws, ndim)
        Reported samples (``CalibrationResult.samples``; emcee's walkers count
        as chains) or sampled coordinates.
    model_name : str
        Label of the radius model (kept in the attributes).
    max_draws : int, optional
        Keep at most this many draws per chain (evenly spaced).
    attrs : dict, optional
        Extra attributes (JSON-serialisable values; stored as text).

    Returns
    -------
    arviz.InferenceData
    """
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az

    if isinstance(samples, dict):
        theta = problem.theta_from_named(samples)
    else:
        theta = np.asarray(samples, dtype=float)
    if theta.ndim == 2:
        theta = theta[None]
    if theta.ndim != 3 or theta.shape[-1] != problem.ndim:
        raise ValueError(f"samples must have shape (chains, draws, {problem.ndim}), got {theta.shape}")
    if max_draws is not None and theta.shape[1] > max_draws:
        if max_draws < 1:
            raise ValueError(f"max_draws must be >= 1, got {max_draws}")
        theta = theta[:, np.linspace(0, theta.shape[1] - 1, max_draws).round().astype(int)]
    n_chain, n_draw, _ = theta.shape
    flat = theta.reshape(-1, problem.ndim)
    named = problem.named_samples(theta)
    named.setdefault("poisson", np.full((n_chain, n_draw), float(problem.priors.poisson)))
    pointwise = problem.pointwise_log_likelihood(flat).reshape(n_chain, n_draw, -1)
    per_case = np.zeros((n_chain, n_draw, problem.n_cases))
    np.add.at(np.moveaxis(per_case, -1, 0), problem.case_index, np.moveaxis(pointwise, -1, 0))
    data = problem.data
    info = {"model": model_name, "film": ",".join(sorted(set(data.film.tolist()))),
            "poisson_mode": problem.poisson_mode, "discrepancy": problem.discrepancy,
            "case_scatter": int(problem.case_scatter), "parameter_names": json.dumps(problem.parameter_names),
            "problem": json.dumps(json_safe(problem.describe())), "format": "filmcal-posterior", "version": 1}
    for key, value in (attrs or {}).items():
        info[key] = value if isinstance(value, (str, int, float)) else json.dumps(json_safe(value))
    idata = az.from_dict(
        posterior={k: np.asarray(v, dtype=float) for k, v in named.items()},
        log_likelihood={LOG_LIKELIHOOD_ROW: pointwise, LOG_LIKELIHOOD_CASE: per_case},
        observed_data={LOG_LIKELIHOOD_ROW: problem.target_radius_mm},
        constant_data={"sphere_radius_mm": data.sphere_radius_mm, "force_n": data.force_n,
                       "case_index": problem.case_index.astype(np.int64),
                       "measurement_std_mm": data.measurement_std_mm},
        dims={LOG_LIKELIHOOD_ROW: ["row"], LOG_LIKELIHOOD_CASE: ["case"], "sphere_radius_mm": ["row"],
              "force_n": ["row"], "case_index": ["row"], "measurement_std_mm": ["row"]})
    for group in idata.groups():
        idata[group].attrs.update(info)
    return idata


def save_posterior_netcdf(idata, path: str | Path) -> Path:
    """Write an InferenceData to NetCDF (HDF5 via h5netcdf), whole or not at all.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    with atomic_path(path) as tmp:
        idata.to_netcdf(str(tmp), engine="h5netcdf")
    return path


def load_posterior_netcdf(path: str | Path):
    """Read a posterior written by `save_posterior_netcdf` (data only, nothing executed).

    Raises
    ------
    ValueError
        When the file is missing or is not a filmcal posterior.
    """
    import arviz as az

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"no posterior file at {str(path)!r}")
    try:
        idata = az.from_netcdf(str(path), engine="h5netcdf")
    except (OSError, ValueError) as exc:
        raise ValueError(f"{str(path)!r} is not a readable NetCDF posterior ({exc})") from None
    if "posterior" not in idata.groups() or idata.posterior.attrs.get("format") != "filmcal-posterior":
        raise ValueError(f"{str(path)!r} is not a filmcal posterior")
    return idata
