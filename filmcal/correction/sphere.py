"""Correction of sphere-on-flat film imprints: the contact without film, with its uncertainty.

Model (the calibration's): a radius measured on film is the FE radius with film
plus scatter, r_m = a_0(R, F) + delta(E; R, F) + eps, eps ~ N(0, sigma^2 + s^2),
where a_0 is the contact radius without film, delta the film's enlargement
(the radius model's excess over Hertz), sigma the scatter of one measurement
about the model (inferred by the calibration), and s the radius model's own
uncertainty. For each posterior sample (E, nu, sigma) the true radius is

    a_0 = r_m - delta(E, nu; R, F) - eps,   eps ~ N(0, sigma^2 + s^2 + u^2),

u being the user's stated measurement uncertainty. The corrected area is
pi a_0^2; its mean, standard deviation and 90 % interval summarise those
samples.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from filmcal.hertz import hertz_radius_mm

#: (R, F) predictions a sphere corrector keeps (each two arrays of its posterior samples, 32 kB at 2000).
PREDICTIONS_KEPT = 64

__all__ = ["CorrectedArea", "SphereCorrector", "pool_corrected"]

#: The largest standard uncertainty of a measured radius, as a share of it (twice this of a measured area): a
#: dataset's scatter is bounded alike (`filmcal.calibration.datasets.MAX_STD_OVER_HERTZ`).
MAX_RELATIVE_STD = 0.25


@dataclass
class CorrectedArea:
    """A corrected contact area (mm^2) with its uncertainty, per input point.

    Attributes
    ----------
    area_mm2, area_std_mm2 : ndarray
        Posterior mean and standard deviation.
    area_ci90_mm2 : ndarray, shape (..., 2)
        5 % and 95 % quantiles.
    radius_mm, radius_std_mm : ndarray
        The same for the equivalent radius.
    samples_mm2 : ndarray, shape (..., n_samples)
        Posterior samples of the corrected area.
    """

    area_mm2: np.ndarray
    area_std_mm2: np.ndarray
    area_ci90_mm2: np.ndarray
    radius_mm: np.ndarray
    radius_std_mm: np.ndarray
    samples_mm2: np.ndarray

    def to_dict(self) -> dict:
        """Scalar (or list) summaries for JSON, without the samples."""
        def plain(x):
            x = np.asarray(x)
            return x.item() if x.ndim == 0 else x.tolist()
        return {"area_mm2": plain(self.area_mm2), "area_std_mm2": plain(self.area_std_mm2),
                "area_ci90_mm2": plain(self.area_ci90_mm2), "radius_mm": plain(self.radius_mm),
                "radius_std_mm": plain(self.radius_std_mm), "n_samples": int(self.samples_mm2.shape[-1])}


def _summarise(samples_mm2: np.ndarray, radius_samples: np.ndarray) -> CorrectedArea:
    return CorrectedArea(samples_mm2.mean(axis=-1), samples_mm2.std(axis=-1, ddof=1),
                         np.moveaxis(np.quantile(samples_mm2, [0.05, 0.95], axis=-1), 0, -1),
                         radius_samples.mean(axis=-1), radius_samples.std(axis=-1, ddof=1), samples_mm2)


def pool_corrected(parts: list[CorrectedArea], weights, random_state=0) -> CorrectedArea:
    """Pool corrected areas of several models into one mixture, by model weights.

    Each model contributes samples in proportion to its weight (e.g. stacking
    weights of imprint models), so the pooled band is as wide as the models'
    spread that the data cannot tell apart.

    Parameters
    ----------
    parts : list of CorrectedArea
        The same points corrected under each model.
    weights : array_like
        Non-negative model weights (normalised here).
    random_state : int or numpy.random.Generator
    """
    w = np.asarray(weights, dtype=float)
    if len(parts) != len(w) or not len(parts) or np.any(w < 0) or not np.isfinite(w).all() or w.sum() <= 0:
        raise ValueError("weights must be one non-negative finite number per part, not all zero")
    w = w / w.sum()
    rng = np.random.default_rng(random_state)
    n = min(p.samples_mm2.shape[-1] for p in parts)
    counts = rng.multinomial(n, w)
    samples = np.concatenate([p.samples_mm2[..., rng.choice(p.samples_mm2.shape[-1], c, replace=False)]
                              for p, c in zip(parts, counts) if c > 0], axis=-1)
    return _summarise(samples, np.sqrt(samples / np.pi))


class SphereCorrector:
    """Correct sphere-on-flat imprints measured with one film type.

    Parameters
    ----------
    model : RadiusModel
        ``predict(modulus_mpa, poisson, sphere_radius_mm, force_n) -> (mean, std)``
        of the radius printed on film (e.g. `filmcal.surrogate.radius.SurrogateRadiusModel`).
    posterior : dict of ndarray
        Posterior samples ``modulus_mpa``, ``poisson`` and ``sigma_mm`` of equal
        shape, any layout (e.g. ``CalibrationResult.samples``, walkers x steps).
    max_samples : int
        Thin the posterior to at most this many samples (evenly).
    random_state : int or numpy.random.Generator, optional
        Seed of the scatter draws: the same seed gives the same answer.
    """

    def __init__(self, model, posterior: dict, max_samples: int = 2000, random_state=0) -> None:
        from filmcal.correction.moduli import thinned_posterior

        self.model = model
        samples = thinned_posterior({"poisson": 0.33, **posterior}, max_samples)
        self.modulus_mpa_, self.poisson_ = samples["modulus_mpa"], samples["poisson"]
        self.sigma_mm_ = samples["sigma_mm"]
        self.random_state = random_state

    @staticmethod
    def check_plausible(measured_radius_mm: float, sphere_radius_mm: float, force_n: float) -> None:
        """Refuse a measured radius that no film could print for this sphere and force.

        The rule is `filmcal.hertz.plausible_imprint_radius_mm` (datasets meet the same). Every caller (a
        command, a batch row, a served request) meets it here.
        """
        from filmcal.hertz import hertz_radius_mm, plausible_imprint_radius_mm

        a_h = float(hertz_radius_mm(sphere_radius_mm, force_n))
        lo, hi = (float(v) for v in plausible_imprint_radius_mm(a_h))
        if not lo <= measured_radius_mm <= hi:
            raise ValueError(f"measured_radius_mm {measured_radius_mm:g} is implausible for R = "
                             f"{sphere_radius_mm:g} mm and F = {force_n / 1e3:g} kN (Hertz radius {a_h:.2f} mm; a "
                             f"film imprint lies within {lo:.2f}-{hi:.2f} mm): check the units")

    def _predict(self, R: np.ndarray, F: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The radius model at every posterior sample for each (R, F); one (R, F)'s prediction is kept
        (`PREDICTIONS_KEPT` of them, the latest), so that imprints of one sphere and load are corrected without
        predicting again: the same numbers, computed once."""
        e, nu = self.modulus_mpa_[None, :], self.poisson_[None, :]
        if R.size != 1 or F.size != 1:
            return self.model.predict(e, nu, R.reshape(-1, 1), F.reshape(-1, 1))
        key = (float(R.ravel()[0]), float(F.ravel()[0]))
        kept = self.__dict__.setdefault("_predictions", {})
        if key not in kept:
            if len(kept) >= PREDICTIONS_KEPT:
                kept.pop(next(iter(kept)))
            kept[key] = self.model.predict(e, nu, np.full((1, 1), key[0]), np.full((1, 1), key[1]))
        return kept[key]

    def correct(self, measured_radius_mm, sphere_radius_mm, force_n, measurement_std_mm=0.0) -> CorrectedArea:
        """The contact area without film behind measured imprint radii (vectorised).

        Parameters
        ----------
        measured_radius_mm : float or array_like
            Imprint radius on the film (mm), > 0.
        sphere_radius_mm, force_n : float or array_like
            Sphere radius R (mm) and force F (N), > 0.
        measurement_std_mm : float or array_like
            The user's standard uncertainty of the measured radius (mm), >= 0.
        """
        r_m, R, F, u = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                             (measured_radius_mm, sphere_radius_mm, force_n, measurement_std_mm)))
        for name, x in (("measured_radius_mm", r_m), ("sphere_radius_mm", R), ("force_n", F)):
            if not np.all(np.isfinite(x)) or np.any(x <= 0):
                raise ValueError(f"{name} must be finite and > 0")
        if not np.all(np.isfinite(u)) or np.any(u < 0):
            raise ValueError("measurement_std_mm must be finite and >= 0")
        if np.any(u > MAX_RELATIVE_STD * r_m):
            worst = float(np.max(u / r_m))
            raise ValueError(f"measurement_std_mm is {100 * worst:.3g} % of the measured radius, more than "
                             f"{100 * MAX_RELATIVE_STD:g} %: an imprint read that loosely leaves the film's own "
                             "error (5-40 % of the radius) undecided; check the units")
        from filmcal.hertz import plausible_imprint_radius_mm

        lo, hi = plausible_imprint_radius_mm(hertz_radius_mm(R, F))
        outside = np.flatnonzero(~((lo <= r_m) & (r_m <= hi)))
        if outside.size:  # the first one, said as `check_plausible` says it
            i = outside[0]
            self.check_plausible(float(r_m.flat[i]), float(R.flat[i]), float(F.flat[i]))
        shape = r_m.shape
        mean, std = self._predict(R, F)
        if not np.all(np.isfinite(mean)):
            bounds = getattr(getattr(self.model, "domain", None), "bounds", None)
            where = ""
            if bounds is not None:
                (r0, r1), (f0, f1) = bounds()["sphere_radius_mm"], bounds()["force_kn"]
                where = f" (spheres of {r0:g}-{r1:g} mm at {f0:g}-{f1:g} kN)"
            raise ValueError(f"a sphere of {float(R.max()):g} mm at {float(F.min()) / 1e3:g} kN lies outside the "
                             f"calibrated domain{where}: correct it with a study calibrated there")
        delta = mean - hertz_radius_mm(R.reshape(-1, 1), F.reshape(-1, 1))
        rng = np.random.default_rng(self.random_state)
        scale = np.sqrt(self.sigma_mm_[None, :] ** 2 + std**2 + u.reshape(-1, 1) ** 2)
        a0 = r_m.reshape(-1, 1) - delta - scale * rng.standard_normal(delta.shape)
        a0 = np.clip(a0, 0.0, None)
        out = _summarise(np.pi * a0**2, a0)
        return CorrectedArea(*(x.reshape(shape + x.shape[1:]) for x in
                               (out.area_mm2, out.area_std_mm2, out.area_ci90_mm2, out.radius_mm,
                                out.radius_std_mm, out.samples_mm2)))
