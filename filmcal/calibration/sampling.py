"""Affine-invariant ensemble sampling (emcee) with a run length set by the chain itself.

The walkers start in a ball around the best point of a profile-likelihood grid
in log E, then run in chunks of `SamplerSettings.check_every` steps. After each
chunk the integrated autocorrelation time tau of every coordinate is estimated
(emcee.autocorr, averaged over walkers; Goodman & Weare 2010, Foreman-Mackey et
al. 2013). The run stops when

1. the chain is at least ``min_tau_multiple`` (50) times the largest tau long,
2. tau changed by less than ``tau_rtol`` since the previous checkpoint, and
3. after discarding ``burn_in_tau`` (5) tau as burn-in and thinning by tau/2,
   every R-hat is <= 1.01 and the bulk ESS of E and M is >= 2000
   (`filmcal.calibration.diagnostics`),

or when the chain reaches ``max_steps`` steps per walker; the diagnostics are
then reported as failed with the reasons.

Chains can live in emcee's `HDFBackend`: running again with the same file
continues the stored chain from its last state and random state (the result
is then the same as one uninterrupted run with the same seed); ``reset=True``
starts afresh (the file: `filmcal.calibration.chain_file`). The configuration of the problem is stored as JSON in the file
and checked before continuing. Nothing in the file is pickled.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from filmcal._validation import MIN_MCMC_STEPS as MIN_STEPS
from filmcal.calibration.diagnostics import Diagnostics, compute_diagnostics
from filmcal.calibration.likelihood import CalibrationProblem
from filmcal.elastic import oedometric_ratio

__all__ = ["SamplerSettings", "ChainRun", "StoredChain", "initial_positions", "run_chain", "read_chain"]




@dataclass(frozen=True)
class SamplerSettings:
    """Settings of the ensemble sampler and of its stopping rule.

    Parameters
    ----------
    n_walkers : int, default 32
        Walkers of the ensemble (at least twice the number of coordinates).
    check_every : int, default 500
        Steps between convergence checks; the checkpoints are multiples of it.
    max_steps : int, default 40000
        Cap on the chain length per walker (stored steps included).
    min_tau_multiple : float, default 50
        The chain must be this many autocorrelation times long.
    tau_rtol : float, default 0.05
        Largest relative change of tau between checkpoints deemed stable.
    burn_in_tau : float, default 5
        Burn-in discarded, in autocorrelation times (largest tau).
    thin_tau : float, default 0.5
        Thinning, in autocorrelation times (smallest tau).
    max_rhat : float, default 1.01
    min_ess : float, default 2000
        Thresholds of the diagnostics (R-hat of every parameter, bulk ESS of
        E and M).
    """

    n_walkers: int = 32
    check_every: int = 500
    max_steps: int = 40000
    min_tau_multiple: float = 50.0
    tau_rtol: float = 0.05
    burn_in_tau: float = 5.0
    thin_tau: float = 0.5
    max_rhat: float = 1.01
    min_ess: float = 2000.0

    def __post_init__(self) -> None:
        for name in ("n_walkers", "check_every", "max_steps"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
        if self.max_steps < MIN_STEPS:
            raise ValueError(f"max_steps must be at least {MIN_STEPS} (a shorter chain gives no autocorrelation "
                             f"time to judge it by), got {self.max_steps!r}")
        for name in ("min_tau_multiple", "tau_rtol", "burn_in_tau", "thin_tau", "min_ess"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be finite and > 0, got {getattr(self, name)!r}")
        if not float(self.max_rhat) > 1.0:
            raise ValueError(f"max_rhat must be > 1, got {self.max_rhat!r}")

    def to_dict(self) -> dict:
        """The settings as plain JSON values."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


@dataclass(frozen=True)
class ChainRun:
    """A finished (or capped) ensemble run.

    Attributes
    ----------
    chain : ndarray of shape (n_steps, n_walkers, ndim)
        Every stored step, burn-in included (sampled coordinates).
    log_prob : ndarray of shape (n_steps, n_walkers)
    parameter_names : list of str
        Names of the sampled coordinates.
    tau : ndarray of shape (ndim,)
        Integrated autocorrelation time of each coordinate (steps).
    burn_in, thin : int
        Steps discarded at the start and thinning of the kept steps.
    n_steps_new : int
        Steps added by this call (the rest came from the backend).
    acceptance_fraction : ndarray of shape (n_walkers,)
    tau_ok : bool
        Whether the chain is long enough (50 tau) and tau is stable.
    diagnostics : Diagnostics
        R-hat and ESS of the kept samples, with the verdict.
    seed : int
    backend_path : str or None
    """

    chain: np.ndarray
    log_prob: np.ndarray
    parameter_names: list[str]
    tau: np.ndarray
    burn_in: int
    thin: int
    n_steps_new: int
    acceptance_fraction: np.ndarray
    tau_ok: bool
    diagnostics: Diagnostics
    seed: int
    backend_path: str | None

    @property
    def n_steps(self) -> int:
        """Steps per walker in the chain."""
        return int(self.chain.shape[0])

    @property
    def n_walkers(self) -> int:
        """Walkers of the ensemble."""
        return int(self.chain.shape[1])

    @property
    def samples(self) -> np.ndarray:
        """Kept samples, shape (n_walkers, n_draws, ndim): after burn-in, thinned."""
        return np.swapaxes(self.chain[self.burn_in::self.thin], 0, 1)


@dataclass(frozen=True)
class StoredChain:
    """A chain read back from an HDF5 file.

    Attributes
    ----------
    chain : ndarray of shape (n_steps, n_walkers, ndim)
    log_prob : ndarray of shape (n_steps, n_walkers)
    metadata : dict
        Configuration stored with the chain (problem, walkers, seed).
    """

    chain: np.ndarray
    log_prob: np.ndarray
    metadata: dict


def initial_positions(problem: CalibrationProblem, n_walkers: int, rng: np.random.Generator) -> np.ndarray:
    """Starting points of the walkers: a ball around the best point of a grid in log E.

    On 97 values of log E over the prior range (nu at its fixed value or the
    middle of its range, no discrepancy), sigma is profiled out
    (``sigma^2 = mean squared residual``); the walkers start around the best
    grid point with std 0.1 in ln E (or ln M) and 0.3 in ln sigma (and ln tau, around a quarter
    of its prior scale), nu drawn from its
    prior and each delta from N(0, (scale/4)^2), all inside the prior support
    (with nu free the ball is in ln M around the best point's M).

    Returns
    -------
    ndarray of shape (n_walkers, ndim)
    """
    lo, hi = problem.log_modulus_bounds
    grid = np.linspace(lo, hi, 97)
    pri = problem.priors
    nu0 = pri.poisson if problem.poisson_mode == "fixed" else 0.5 * sum(pri.poisson_range)
    mean, std = problem.model_radius(np.exp(grid), np.full(grid.size, nu0))
    resid2 = (problem.target_radius_mm[None, :] - mean) ** 2 + std**2
    s2 = np.maximum(resid2.mean(axis=1), 1e-4)
    best = int(np.argmin(s2))
    margin = 1e-6
    log_e = rng.normal(grid[best], 0.1, n_walkers)
    if problem.poisson_mode == "free":
        # the ball is around the best M (at nu0); E = M / (M/E)(nu) is then kept inside its prior range
        nlo, nhi = pri.poisson_range
        nu = rng.uniform(nlo + margin, nhi - margin, n_walkers)
        log_ratio = np.log(oedometric_ratio(nu))
        log_m = np.clip(log_e + math.log(oedometric_ratio(nu0)), lo + log_ratio + margin, hi + log_ratio - margin)
        columns = [log_m, nu]
    else:
        columns = [np.clip(log_e, lo + margin, hi - margin)]
    log_sigma = rng.normal(0.5 * math.log(s2[best]), 0.3, n_walkers)
    if pri.sigma_prior == "log-uniform":
        slo, shi = (math.log(v) for v in pri.sigma_range_mm)
        log_sigma = np.clip(log_sigma, slo + margin, shi - margin)
    columns.append(log_sigma)
    if problem.case_scatter:  # start small: the repeats' spread goes to sigma first
        columns.append(rng.normal(math.log(0.25 * problem.priors.case_scale_mm), 0.3, n_walkers))
    for _ in problem.delta_names:
        columns.append(rng.normal(0.0, 0.25 * pri.discrepancy_scale_mm, n_walkers))
    return np.column_stack(columns)


def _tau(chain: np.ndarray) -> np.ndarray:
    """Integrated autocorrelation time of each coordinate, averaged over walkers."""
    from emcee.autocorr import integrated_time

    return np.asarray(integrated_time(chain, c=5, tol=0, quiet=True), dtype=float)


def _metadata(problem: CalibrationProblem, settings: SamplerSettings, seed: int) -> dict:
    from filmcal.calibration.chain_file import CHAIN_FORMAT

    return {"format": CHAIN_FORMAT, "problem": problem.describe(), "n_walkers": settings.n_walkers, "seed": seed}


def read_chain(path: str | Path) -> StoredChain:
    """Read a chain written by `run_chain` (read-only; no pickle involved).

    Parameters
    ----------
    path : str or Path
        The HDF5 file.

    Returns
    -------
    StoredChain
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no chain file at {str(path)!r}")
    from filmcal.calibration.chain_file import CHAIN_FORMAT, read_metadata, read_stored

    metadata = read_metadata(path)
    if metadata is None or metadata.get("format") != CHAIN_FORMAT:
        raise ValueError(f"{str(path)!r} is not a filmcal calibration chain")
    chain, log_prob = read_stored(path)
    return StoredChain(chain=chain, log_prob=log_prob, metadata=metadata)


def _assess(problem: CalibrationProblem, chain: np.ndarray, settings: SamplerSettings, final: bool,
            tau_cache: dict[int, np.ndarray]) -> tuple[np.ndarray, int, int, bool, Diagnostics | None]:
    """Tau, burn-in, thinning and (when the chain is long enough, or `final`) the diagnostics.

    `tau_cache` maps chain lengths to their tau (a deterministic function of the
    chain prefix), so that each checkpoint's tau is computed once.
    """
    def tau_of(length: int) -> np.ndarray:
        if length not in tau_cache:
            tau_cache[length] = _tau(chain[:length])
        return tau_cache[length]

    n = chain.shape[0]
    tau = tau_of(n)
    messages = []
    if n < settings.min_tau_multiple * tau.max():
        messages.append(f"chain of {n} steps is shorter than {settings.min_tau_multiple:g} tau "
                        f"= {settings.min_tau_multiple * tau.max():.0f} steps")
    previous = n - settings.check_every
    if previous >= settings.check_every:
        change = np.abs(tau - tau_of(previous)) / tau
        if change.max() > settings.tau_rtol:
            messages.append(f"tau changed by {100 * change.max():.1f} % over the last "
                            f"{settings.check_every} steps (> {100 * settings.tau_rtol:g} %)")
    else:
        messages.append("tau stability not yet checked (one checkpoint only)")
    tau_ok = not messages
    burn = min(int(math.ceil(settings.burn_in_tau * tau.max())), n // 2)
    thin = max(1, int(settings.thin_tau * tau.min()))
    if not (tau_ok or final):
        return tau, burn, thin, False, None
    kept = np.swapaxes(chain[burn::thin], 0, 1)
    if kept.shape[1] < 4:
        thin = 1
        kept = np.swapaxes(chain[burn:], 0, 1)
    diagnostics = compute_diagnostics(problem.named_samples(kept), settings.max_rhat, settings.min_ess,
                                      ["modulus_mpa", "oedometric_modulus_mpa"], messages)
    if final and not diagnostics.ok:
        cap = (f"stopped at the cap of {settings.max_steps} steps per walker; raise max_steps "
               "(with the same backend_path the chain continues)")
        diagnostics = replace(diagnostics, messages=[cap] + diagnostics.messages)
    return tau, burn, thin, tau_ok, diagnostics


def _run_steps(sampler, state, n_steps: int, progress: bool, desc: str) -> None:
    """``sampler.run_mcmc(state, n_steps)``, but Ctrl-C ends the run cleanly after the current step.

    emcee reports an interrupt inside the likelihood as an error of the
    likelihood function (printing the walkers' positions) and may leave a step
    half stored. Here Ctrl-C (SIGINT) only sets a flag while the steps run;
    the step under way finishes (a few milliseconds), the chain stays
    consistent for resuming, and a plain `KeyboardInterrupt` is raised.
    """
    import signal
    import threading

    interrupted = []
    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, lambda signum, frame: interrupted.append(signum)) if in_main else None
    try:
        initial = state if state is not None else sampler._previous_state  # as run_mcmc resumes
        last = None
        for last in sampler.sample(initial, iterations=n_steps, progress=progress, progress_kwargs={"desc": desc}):
            if interrupted:
                break
        if last is not None:
            sampler._previous_state = last
    finally:
        if in_main:
            signal.signal(signal.SIGINT, previous)
    if interrupted:
        raise KeyboardInterrupt


def run_chain(problem: CalibrationProblem, settings: SamplerSettings | None = None, seed: int = 0,
              backend_path: str | Path | None = None, reset: bool = False, progress: bool = False) -> ChainRun:
    """Sample the posterior of `problem` until converged or capped.

    Parameters
    ----------
    problem : CalibrationProblem
    settings : SamplerSettings, optional
    seed : int, default 0
        Seeds the starting points and emcee's random state: the same seed
        gives the same chain, digit for digit.
    backend_path : str or Path, optional
        HDF5 file for the chain (continued if it holds one of this
        configuration); in memory when omitted.
    reset : bool, default False
        Discard a chain stored at `backend_path` and start afresh.
    progress : bool, default False
        Show emcee's tqdm progress bar (stderr).

    Returns
    -------
    ChainRun
    """
    settings = SamplerSettings() if settings is None else settings
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    seed = int(seed)
    if settings.n_walkers < 2 * problem.ndim:
        raise ValueError(f"n_walkers must be >= 2 * {problem.ndim} coordinates, got {settings.n_walkers}")
    import emcee

    from filmcal.calibration.chain_file import ChunkedHDFBackend, open_backend

    backend = open_backend(backend_path, _metadata(problem, settings, seed), reset, problem.ndim)
    sampler = emcee.EnsembleSampler(settings.n_walkers, problem.ndim, problem.log_posterior,
                                    vectorize=True, backend=backend)
    start = sampler.iteration
    state = None
    if start == 0:
        rng = np.random.default_rng(seed)
        coords = initial_positions(problem, settings.n_walkers, rng)
        emcee_seed = int(rng.integers(2**32 - 1))
        state = emcee.State(coords, random_state=np.random.RandomState(emcee_seed).get_state())
    tau_cache: dict[int, np.ndarray] = {}
    while True:
        n = sampler.iteration
        capped = n >= settings.max_steps
        if n > 0:
            chain = sampler.get_chain()
            tau, burn, thin, tau_ok, diagnostics = _assess(problem, chain, settings, capped, tau_cache)
            if diagnostics is not None and (diagnostics.ok or capped):
                break
        target = min((n // settings.check_every + 1) * settings.check_every, settings.max_steps)
        try:
            _run_steps(sampler, state, target - n, progress, f"emcee steps {n}-{target}")
        finally:  # keep the steps done so far, also when interrupted
            if isinstance(backend, ChunkedHDFBackend):
                backend.flush()
        state = None
    return ChainRun(chain=chain, log_prob=sampler.get_log_prob(), parameter_names=list(problem.parameter_names),
                    tau=tau, burn_in=burn, thin=thin, n_steps_new=int(chain.shape[0] - start),
                    acceptance_fraction=np.asarray(sampler.acceptance_fraction, dtype=float),
                    tau_ok=tau_ok, diagnostics=diagnostics, seed=seed,
                    backend_path=None if backend_path is None else str(backend_path))
