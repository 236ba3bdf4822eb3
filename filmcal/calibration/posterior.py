"""The result of a film calibration: posterior summaries, diagnostics, checks, storage.

A `CalibrationResult` is saved as one JSON file (summaries, diagnostics,
checks, settings and the kept posterior samples); the full chain, burn-in
included, stays in the emcee HDF5 file named by ``backend_path`` (read it with
`filmcal.calibration.read_chain`). Loading parses JSON only: no pickle, no code.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from filmcal._json import json_safe

from filmcal.calibration.checks import CaseIntervals, PredictiveCheck
from filmcal.calibration.diagnostics import Diagnostics
from filmcal.calibration.likelihood import Priors
from filmcal.calibration.sampling import SamplerSettings

__all__ = ["CalibrationResult", "summarize", "save_result", "load_result"]

FORMAT = "filmcal-calibration-result"
FORMAT_VERSION = 1


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
    def rhat_max(self) -> float:
        """Worst (largest) R-hat over the parameters."""
        return self.diagnostics.worst_rhat

    @property
    def ess_min(self) -> float:
        """Worst (smallest) bulk ESS over the parameters."""
        return self.diagnostics.worst_ess

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
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(payload, allow_nan=False) + "\n", encoding="utf-8")
    tmp.replace(path)  # whole or not at all: an interrupted save leaves no truncated result
    return path


def load_result(path: str | Path) -> CalibrationResult:
    """Read a result written by `save_result` (plain JSON, nothing executed)."""
    path = Path(path)
    payload = json.loads(path.read_text(encoding="utf-8"))
    if payload.get("format") != FORMAT:
        raise ValueError(f"{str(path)!r} is not a filmcal calibration result")
    if payload.get("version") != FORMAT_VERSION:
        raise ValueError(f"unsupported calibration result version {payload.get('version')!r} in {str(path)!r}")
    return CalibrationResult.from_dict(payload)
