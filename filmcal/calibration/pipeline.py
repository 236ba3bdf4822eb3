"""One call that calibrates a film type: data, posterior, diagnostics, checks.

`calibrate_film` loads the Table 1 rows of a film (and load range), samples the
posterior of E (and nu, sigma, per-load offsets) with emcee until the
autocorrelation and ArviZ criteria pass or the step cap is reached, then
summarises the posterior and checks it point by point. `calibrate` does the
same on any `RadiusErrorData` (e.g. synthetic data).

The whole run holds BLAS to one thread (`threadpoolctl`): the model calls are
small matrix products for which threading costs more than it gains, and a
fixed thread count keeps floating-point sums, hence the chains, reproducible.
"""
from __future__ import annotations

import time
import warnings
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from filmcal.calibration.checks import case_modulus_intervals, predictive_check
from filmcal.calibration.data import RadiusErrorData, parse_load_range
from filmcal.calibration.datasets import load_table1
from filmcal.calibration.likelihood import CalibrationProblem, Priors, RadiusModel
from filmcal.calibration.posterior import CalibrationResult, summarize
from filmcal.calibration.sampling import SamplerSettings, run_chain

__all__ = ["calibrate", "calibrate_film", "scatter_warning", "ScatterWarning", "SCATTER_BEYOND_FILMS_MM"]


def _notes(problem: CalibrationProblem) -> list[str]:
    """What the reported numbers mean for this configuration."""
    pri = problem.priors
    notes = []
    if problem.poisson_mode == "free":
        notes.append(
            f"nu is free (uniform {pri.poisson_range[0]:g}-{pri.poisson_range[1]:g}): in a small-strain film held "
            "laterally the radius depends on (E, nu) only through M = E(1-nu)/((1+nu)(1-2nu)), so the data "
            "constrain M; the marginal of E mostly reflects the nu prior and is not a finding about the film.")
    else:
        notes.append(
            f"nu is fixed at {pri.poisson:g} (as in the paper): E is conditional on that value; the data "
            "constrain the oedometric modulus M = E(1-nu)/((1+nu)(1-2nu)).")
    if problem.discrepancy == "load":
        notes.append(
            f"per-load offsets delta_F ~ N(0, {pri.discrepancy_scale_mm:g} mm) absorb what the model cannot fit "
            "at each load level; a common shift of all levels trades off against E, so E is wider than without "
            "them and is informed by the differences between sphere radii at each load and by the offsets' prior.")
    else:
        notes.append("no model discrepancy: systematic misfit (e.g. the paper's 25 kN curvature effect) "
                     "inflates sigma; check the posterior predictive residuals by load level.")
    return notes


#: The largest scatter of one imprint's radius (mm) that a film's data can have: Table 1's films give a
#: posterior median sigma of 0.10-0.13 mm (MS, HS, HHS under the edge model), so a sigma beyond 0.5 mm
#: (about 7 % of Table 1's 5-8 mm radii) says that the data or the model are wrong, not that the film scatters.
SCATTER_BEYOND_FILMS_MM = 0.5


class ScatterWarning(UserWarning):
    """A calibration whose inferred scatter lies beyond any film's (`SCATTER_BEYOND_FILMS_MM`)."""


def scatter_warning(sigma_median_mm: float, n_data: int) -> str | None:
    """The warning of a calibration whose scatter lies beyond any film's (`SCATTER_BEYOND_FILMS_MM`), or None."""
    if not sigma_median_mm > SCATTER_BEYOND_FILMS_MM:
        return None
    return (f"the inferred scatter of one imprint's radius, sigma = {sigma_median_mm:.3g} mm (median), is beyond "
            f"any film's (Table 1's films: 0.10-0.13 mm; the limit is {SCATTER_BEYOND_FILMS_MM:g} mm): the "
            f"{n_data} measured radii do not fit the model (a unit or transcription error in the data, rows of "
            "another film or set-up, or a model that cannot follow them); the modulus is not a finding about "
            "the film until that is resolved")


def calibrate(data: RadiusErrorData, model: RadiusModel, *, film: str | None = None, loads: str | None = None,
              poisson: str = "fixed", discrepancy: str | None = None, priors: Priors | None = None,
              seed: int = 0, backend_path: str | Path | None = None, reset: bool = False,
              settings: SamplerSettings | None = None, progress: bool = False,
              rough_flat=None) -> CalibrationResult:
    """Calibrate the film model on given measured radii.

    Parameters
    ----------
    data : RadiusErrorData
        Measured radii (one film type).
    model : RadiusModel
        ``predict(modulus_mpa, poisson, sphere_radius_mm, force_n) -> (mean_mm, std_mm)``.
    film : str, optional
        Label of the result; default the film column of `data`.
    loads : str, optional
        Load range label of the result (kN).
    poisson, discrepancy, priors, seed, backend_path, reset, settings, progress
        As in `calibrate_film`.
    rough_flat : RoughFlatGrowth, optional
        The film model's growth on a roughened flat, for rows with ``flat_ra_um > 0`` (`CalibrationProblem`).

    Returns
    -------
    CalibrationResult
    """
    t0 = time.perf_counter()
    problem = CalibrationProblem(data, model, priors, poisson=poisson,
                                 discrepancy="none" if discrepancy is None else discrepancy, rough_flat=rough_flat)
    settings = SamplerSettings() if settings is None else settings
    label = film if film is not None else "+".join(sorted(set(data.film.tolist())))
    with threadpool_limits(limits=1):
        run = run_chain(problem, settings, seed, backend_path, reset, progress)
        flat = run.samples.reshape(-1, problem.ndim)
        named = problem.named_samples(run.samples)
        sigma_median = float(np.median(named["sigma_mm"]))
        nu_for_cases = (problem.priors.poisson if problem.poisson_mode == "fixed"
                        else float(np.median(named["poisson"])))
        predictive = predictive_check(problem, flat)
        cases = case_modulus_intervals(problem, sigma_median, nu_for_cases)
    scatter = scatter_warning(sigma_median, len(data))
    if scatter:
        warnings.warn(ScatterWarning(scatter), stacklevel=2)
    poisson_summary = ({"fixed": float(problem.priors.poisson)} if problem.poisson_mode == "fixed"
                       else summarize(named["poisson"]))
    return CalibrationResult(
        film=label, loads=loads, n_data=len(data), poisson_mode=problem.poisson_mode,
        discrepancy=problem.discrepancy,
        modulus_mpa=summarize(named["modulus_mpa"]),
        oedometric_modulus_mpa=summarize(named["oedometric_modulus_mpa"]),
        sigma_mm=summarize(named["sigma_mm"]), poisson=poisson_summary,
        delta_mm={name: summarize(named[f"{name}_mm"]) for name in problem.delta_names},
        diagnostics=run.diagnostics,
        tau={name: float(t) for name, t in zip(run.parameter_names, run.tau)},
        n_steps=run.n_steps, n_walkers=run.n_walkers, burn_in=run.burn_in, thin=run.thin,
        n_steps_new=run.n_steps_new, acceptance_fraction=float(np.mean(run.acceptance_fraction)),
        seed=run.seed, elapsed_s=time.perf_counter() - t0, samples=named, predictive=predictive,
        case_intervals=cases, priors=problem.priors, settings=settings, backend_path=run.backend_path,
        notes=_notes(problem) + ([scatter] if scatter else []))


def calibrate_film(film: str, model: RadiusModel, loads: str | None = None, *, poisson: str = "fixed",
                   discrepancy: str | None = None, priors: Priors | None = None, seed: int = 0,
                   backend_path: str | Path | None = None, reset: bool = False, max_steps: int | None = None,
                   n_walkers: int | None = None, settings: SamplerSettings | None = None,
                   progress: bool = False) -> CalibrationResult:
    """Bayesian calibration of the film modulus of one Prescale film type against Table 1.

    Parameters
    ----------
    film : {"MS", "HS", "HHS"}
        Film type (case-insensitive).
    model : RadiusModel
        Model of the printed radius: ``predict(modulus_mpa, poisson,
        sphere_radius_mm, force_n) -> (mean_mm, std_mm)`` (a GP surrogate
        adapter or the FE model in the loop).
    loads : str, optional
        Load range in kN, e.g. ``"50-100"``; all loads when omitted.
    poisson : {"fixed", "free"}, default "fixed"
        nu fixed at 0.33 (the paper) or uniform over 0.29-0.37. With nu free,
        only M is identified and the E marginal reflects the nu prior.
    discrepancy : {None, "load"}, default None
        ``"load"`` adds an offset per load level with a N(0, 0.2 mm) prior.
    priors : Priors, optional
        Override the default priors (see `Priors`).
    seed : int, default 0
        Same seed, same posterior summary, digit for digit.
    backend_path : str or Path, optional
        emcee HDF5 file of the chain; an existing chain of the same
        configuration is continued.
    reset : bool, default False
        Start a new chain in `backend_path`.
    max_steps, n_walkers : int, optional
        Override these fields of `settings` (cap on steps per walker; walkers).
    settings : SamplerSettings, optional
        Sampler and stopping-rule settings.
    progress : bool, default False
        Show emcee's progress bar.

    Returns
    -------
    CalibrationResult
        Posterior summaries with their diagnostics (``diagnostics_ok`` False,
        with messages, when the run hit the cap before converging), the
        posterior predictive check and the per-case E ranges.

    Raises
    ------
    ValueError
        For an unknown film, a bad load range, no data in the range, bad
        options, or a model returning non-finite values.
    """
    settings = SamplerSettings() if settings is None else settings
    overrides = {k: v for k, v in (("max_steps", max_steps), ("n_walkers", n_walkers)) if v is not None}
    if overrides:
        settings = SamplerSettings(**{**settings.to_dict(), **overrides})
    if loads is not None:
        low, high = parse_load_range(loads)
        loads_label = f"{low:g}-{high:g}" if low != high else f"{low:g}"
    else:
        loads_label = None
    data = load_table1(film, loads)
    if len(data) < 2:
        raise ValueError(f"loads {loads!r} selects {len(data)} measured radii of film {film!r}; need at least 2 "
                         "(Table 1 has 25, 50, 75 and 100 kN)")
    return calibrate(data, model, film=str(film).strip().upper(), loads=loads_label, poisson=poisson,
                     discrepancy=discrepancy, priors=priors, seed=seed, backend_path=backend_path, reset=reset,
                     settings=settings, progress=progress)
