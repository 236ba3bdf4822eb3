"""Conditioning the rough imprint's inputs on roughened-flat observations.

The paper roughened the flat of its Hertzian tests up to Ra ~ 1.5 um: MS and HS "detected a likewise gradual
increase in nominal contact area size", HHS "was not sensitive to roughness variations within the
investigated range" (section 2). Each statement is an observation of the growth ``g`` of one film's imprint
on sphere-on-flat at a flat's Ra, read through the scatter of one imprint:

    observed growth = g + e,   e ~ N(0, s^2),

with ``s`` the relative area scatter of one imprint, ``2 sigma / r`` (sigma the calibration's noise level of
one imprint's radius, 0.07-0.08 mm for MS and HS at r ~ 7 mm at R450 / 50 kN: s = 2 %). "Detected" means
the observed growth exceeded that scatter, ``P = Phi((g - s) / s)``; "not sensitive" that it stayed within
it, ``P = Phi((s - g) / s) - Phi((-s - g) / s)``. Prior draws of the inputs (`sample_roughness_prior`) are
weighted by the product over observations (importance sampling) and resampled to an equal-weight set: the
conditioned inputs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.stats import norm

__all__ = ["RoughFlatObservation", "PAPER_ROUGH_FLAT", "DETECTION_SCATTER", "observation_likelihood",
           "condition_weights", "resample"]

#: Relative area scatter of one imprint (2 sigma / r with sigma ~ 0.075 mm, r ~ 7 mm).
DETECTION_SCATTER = 0.02


@dataclass(frozen=True)
class RoughFlatObservation:
    """One observation of a film's imprint growth on a roughened flat.

    Attributes
    ----------
    film : str
    ra_um : float
        The flat's Ra (um).
    sphere_radius_mm, force_kn : float
        The test (the growth is computed there).
    detected : bool or None
        Qualitative: the growth was detected (True) or not (False).
    growth : float or None
        Quantitative: the measured growth of the imprint area (fraction, e.g. 0.05), instead of ``detected``.
    scatter : float
        Relative area scatter of one observation.
    source : str
    """

    film: str
    ra_um: float
    sphere_radius_mm: float = 450.0
    force_kn: float = 50.0
    detected: bool | None = None
    growth: float | None = None
    scatter: float = DETECTION_SCATTER
    source: str = ""

    def __post_init__(self) -> None:
        if (self.detected is None) == (self.growth is None):
            raise ValueError("an observation is either detected/not detected or a measured growth")
        if not self.scatter > 0:
            raise ValueError(f"scatter must be > 0, got {self.scatter!r}")


_PAPER = ("reference paper, section 2: the flat roughened gradually up to Ra ~ 1.5 um; MS and HS detected a "
          "gradual increase of the nominal contact area, HHS was not sensitive")

#: The paper's roughened-flat observations, at the middle of its test grid (R450, 50 kN).
PAPER_ROUGH_FLAT: tuple[RoughFlatObservation, ...] = (
    RoughFlatObservation("MS", 1.5, detected=True, source=_PAPER),
    RoughFlatObservation("HS", 1.5, detected=True, source=_PAPER),
    RoughFlatObservation("HHS", 1.5, detected=False, source=_PAPER),
)


def observation_likelihood(obs: RoughFlatObservation, growth: np.ndarray) -> np.ndarray:
    """Likelihood of ``obs`` given predicted growth factors (``g_f - 1``, fractions)."""
    g = np.asarray(growth, dtype=float)
    s = obs.scatter
    if obs.growth is not None:
        return norm.pdf((obs.growth - g) / s) / s
    if obs.detected:
        return norm.cdf((g - s) / s)
    return norm.cdf((s - g) / s) - norm.cdf((-s - g) / s)


def condition_weights(growths: dict, observations: Sequence[RoughFlatObservation]) -> tuple[np.ndarray, float]:
    """Normalised importance weights of prior draws and their effective number.

    Parameters
    ----------
    growths : dict
        Per observation index: the predicted growth (``g_f - 1``) of every draw.
    observations : sequence of RoughFlatObservation
    """
    log_w = None
    for k, obs in enumerate(observations):
        like = np.maximum(observation_likelihood(obs, growths[k]), 1e-300)
        log_w = np.log(like) if log_w is None else log_w + np.log(like)
    if log_w is None:
        raise ValueError("no observations to condition on")
    w = np.exp(log_w - log_w.max())
    w /= w.sum()
    return w, float(1.0 / np.sum(w * w))


def resample(weights: np.ndarray, n: int, random_state: int = 0) -> np.ndarray:
    """Systematic resampling: indices of ``n`` equal-weight draws."""
    w = np.asarray(weights, dtype=float)
    if w.ndim != 1 or w.size == 0 or not math.isclose(float(w.sum()), 1.0, rel_tol=1e-9) or np.any(w < 0):
        raise ValueError("weights must be a non-negative vector summing to 1")
    u = (np.random.default_rng(random_state).random() + np.arange(n)) / n
    return np.minimum(np.searchsorted(np.cumsum(w), u), w.size - 1)
