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

A study whose dataset measured the same cases on smooth and roughened flats conditions the shipped draws
again (`dataset_rough_flat_observations`: each rough case's growth over its smooth twin, model-free;
`reweighted_inputs`): its corrections and curves then use its own draws.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

__all__ = ["RoughFlatObservation", "PAPER_ROUGH_FLAT", "DETECTION_SCATTER", "observation_likelihood",
           "condition_weights", "resample", "RoughFlatGrowth", "RADIUS_SCATTER_MM", "dataset_rough_flat_observations",
           "reweighted_inputs"]

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
    from scipy.special import ndtr  # the standard normal CDF (scipy.stats would take a second to import)

    g = np.asarray(growth, dtype=float)
    s = obs.scatter
    if obs.growth is not None:
        x = (obs.growth - g) / s
        return np.exp(-x**2 / 2.0) / np.sqrt(2.0 * np.pi) / s
    if obs.detected:
        return ndtr((g - s) / s)
    return ndtr((s - g) / s) - ndtr((-s - g) / s)


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


class RoughFlatGrowth:
    """The growth of a film's imprint radius on a roughened flat, for the calibration's rough rows.

    A dataset row with ``flat_ra_um > 0`` measured its imprint on a roughened flat: the model's radius there is
    the smooth radius times ``sqrt(g_f(E))``, ``g_f`` the film model's rough/smooth area growth on
    sphere-on-flat (`filmcal.correction.roughness.sphere_growth`, the representative conditioned draw of the
    roughness inputs). ``g_f`` is solved once per rough case (R, F, Ra) at moduli log-spaced over the prior's
    range and interpolated linearly in log E (`prepare`); rows with no or zero Ra keep the factor 1.

    Parameters
    ----------
    film_model : FilmModel
        The film type, imprint model and kinematics being calibrated.
    modulus_range_mpa : (float, float)
        The prior's range of E.
    n_moduli : int
        Moduli at which each rough case is solved.
    """

    def __init__(self, film_model, modulus_range_mpa: tuple[float, float], n_moduli: int = 5) -> None:
        lo, hi = (float(v) for v in modulus_range_mpa)
        if not 0 < lo < hi:
            raise ValueError(f"modulus_range_mpa must be increasing and > 0, got {modulus_range_mpa!r}")
        self.film_model = film_model
        self.moduli_mpa = np.geomspace(lo, hi, int(n_moduli))
        self.log_growth: dict[tuple[float, float, float], np.ndarray] = {}

    @staticmethod
    def _cases(data) -> list[tuple[float, float, float]]:
        ra = np.asarray(data.flat_ra_um if data.flat_ra_um is not None else np.full(len(data), np.nan),
                        dtype=float)
        return [(float(r), float(f), float(a)) for r, f, a in
                zip(np.asarray(data.sphere_radius_mm, float), np.asarray(data.force_n, float), ra)]

    def prepare(self, data) -> None:
        """Solve the growth of every rough case of ``data`` not solved yet."""
        from filmcal.contact.rough_imprint import representative_roughness_inputs
        from filmcal.wheelrail.rough_growth import sphere_growth

        draw = representative_roughness_inputs()
        for case in self._cases(data):
            radius, force, ra = case
            if not (math.isfinite(ra) and ra > 0) or case in self.log_growth:
                continue
            self.log_growth[case] = np.log([sphere_growth(self.film_model, float(e), draw, ra,
                                                          sphere_radius_mm=radius, force_n=force)
                                            for e in self.moduli_mpa])

    def radius_factor(self, modulus_mpa: np.ndarray, data) -> np.ndarray:
        """``sqrt(g_f(E))`` for every modulus (k,) and row of ``data`` (n,): shape (k, n)."""
        log_e = np.log(np.atleast_1d(np.asarray(modulus_mpa, dtype=float)))
        out = np.ones((log_e.size, len(data)))
        grid = np.log(self.moduli_mpa)
        for j, case in enumerate(self._cases(data)):
            table = self.log_growth.get(case)
            if table is not None:
                out[:, j] = np.exp(0.5 * np.interp(log_e, grid, table))
            elif math.isfinite(case[2]) and case[2] > 0:
                raise ValueError(f"the rough case R {case[0]:g} mm, F {case[1] / 1e3:g} kN, flat Ra {case[2]:g} um "
                                 "was not prepared")
        return out


#: Scatter of one imprint's radius (mm) where a case has no repeats to measure it: the calibration's noise
#: level of Table 1 (0.07-0.08 mm for MS and HS).
RADIUS_SCATTER_MM = 0.075


def dataset_rough_flat_observations(data, film: str) -> list[RoughFlatObservation]:
    """A lab's roughened-flat observations in its dataset: one per rough case (R, F, flat Ra) of ``film``
    that the dataset also measured on a smooth flat.

    The observed growth is model-free, ``(mean rough radius / mean smooth radius)^2 - 1``, and its scatter
    ``2 sqrt(s_r^2 / n_r / r_r^2 + s_s^2 / n_s / r_s^2)`` (relative area), with ``s`` the radii's pooled
    within-case standard deviation where cases repeat, else `RADIUS_SCATTER_MM`. Rough cases without a
    smooth twin are not observations of the growth (they still calibrate the modulus).
    """
    rows = np.asarray(data.film) == film
    r = np.asarray(data.sphere_radius_mm, float)[rows]
    f = np.asarray(data.force_n, float)[rows]
    y = np.asarray(data.measured_radius_mm, float)[rows]
    ra = (np.full(rows.sum(), np.nan) if data.flat_ra_um is None
          else np.asarray(data.flat_ra_um, float)[rows])
    ra = np.where(np.isfinite(ra) & (ra > 0), ra, 0.0)
    groups: dict = {}
    for key, value in zip(zip(r, f, ra), y):
        groups.setdefault(tuple(float(v) for v in key), []).append(float(value))
    spread = [np.var(v, ddof=1) * (len(v) - 1) for v in groups.values() if len(v) > 1]
    dof = sum(len(v) - 1 for v in groups.values() if len(v) > 1)
    s = math.sqrt(sum(spread) / dof) if dof else RADIUS_SCATTER_MM
    out = []
    for (radius, force, flat_ra), values in sorted(groups.items()):
        smooth = groups.get((radius, force, 0.0))
        if flat_ra == 0.0 or smooth is None:
            continue
        r_rough, r_smooth = float(np.mean(values)), float(np.mean(smooth))
        scatter = 2.0 * math.hypot(s / math.sqrt(len(values)) / r_rough, s / math.sqrt(len(smooth)) / r_smooth)
        out.append(RoughFlatObservation(film, flat_ra, radius, force / 1e3, growth=(r_rough / r_smooth) ** 2 - 1.0,
                                        scatter=max(scatter, 1e-4),
                                        source=f"dataset: {len(values)} rough and {len(smooth)} smooth imprints"))
    return out


def reweighted_inputs(draws: Sequence, growths: dict, observations: Sequence[RoughFlatObservation],
                      random_state: int = 0) -> dict:
    """Condition equal-weight draws of the roughness inputs again on more observations (a study's own).

    Parameters
    ----------
    draws : sequence of RoughnessInputs
        The draws (the shipped conditioned set: already conditioned on the paper's observation).
    growths : dict
        Per observation index: each draw's predicted growth (``g_f - 1``) for it.
    observations : sequence of RoughFlatObservation

    Returns
    -------
    dict
        ``weights`` (normalised importance weights of the draws), ``effective_draws`` and ``conditioned``:
        as many draws again, resampled by the weights (systematic) and put in a seeded random order, so that
        the first N of them are a fair subset.
    """
    w, n_eff = condition_weights(growths, observations)
    picked = resample(w, len(draws), random_state)
    order = np.random.default_rng(random_state).permutation(len(picked))
    return {"weights": w.tolist(), "effective_draws": n_eff, "conditioned": [draws[int(picked[k])] for k in order]}
