"""Convergence diagnostics of the posterior samples, computed with ArviZ.

Each emcee walker is treated as one chain. For every parameter this gives the
rank-normalised split R-hat and the bulk and tail effective sample sizes of
Vehtari et al., "Rank-normalization, folding, and localization: an improved
R-hat for assessing convergence of MCMC", Bayesian Analysis 16(2), 2021.
Walkers of an affine-invariant ensemble are not independent chains, so R-hat
near 1 is necessary rather than sufficient; the run length is set from the
integrated autocorrelation time as well (`filmcal.calibration.sampling`).

The reported quantiles (the median and the 5 % and 95 % bounds of the 90 %
interval) come with their Monte Carlo standard error, computed by the same
paper's method for quantiles (ArviZ ``mcse(method="quantile")``): how far a
reported median could move if the chain were run again. It is the sampler's
error, not the posterior's width.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

__all__ = ["Diagnostics", "compute_diagnostics", "quadrature_quantiles", "QUANTILE_LEVELS"]

#: The quantiles whose Monte Carlo error is reported: the median and the 90 % interval's bounds.
QUANTILE_LEVELS = {"median": 0.5, "q05": 0.05, "q95": 0.95}


def _arviz():
    """Import ArviZ lazily (slow import) and without its refactoring notice."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz
    return arviz


@dataclass(frozen=True)
class Diagnostics:
    """R-hat and effective sample sizes per parameter, and whether they pass.

    Attributes
    ----------
    rhat, ess_bulk, ess_tail : dict of str -> float
        Rank-normalised split R-hat, bulk ESS and tail ESS of each parameter.
    ok : bool
        True when every R-hat is <= `max_rhat` and the bulk ESS of every
        parameter in `ess_parameters` is >= `min_ess`.
    messages : list of str
        Why `ok` is False (empty otherwise).
    max_rhat, min_ess : float
        The thresholds applied.
    ess_parameters : list of str
        Parameters held to `min_ess`.
    mcse : dict of str -> dict of str -> float
        Monte Carlo standard error of each parameter's median, 5 % and 95 %
        quantiles (keys of `QUANTILE_LEVELS`), in the parameter's unit. Empty
        in results stored before it was computed.
    """

    rhat: dict[str, float]
    ess_bulk: dict[str, float]
    ess_tail: dict[str, float]
    ok: bool
    messages: list[str] = field(default_factory=list)
    max_rhat: float = 1.01
    min_ess: float = 2000.0
    ess_parameters: list[str] = field(default_factory=list)
    mcse: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def worst_rhat(self) -> float:
        """The largest R-hat over the parameters."""
        return max(self.rhat.values())

    @property
    def worst_ess(self) -> float:
        """The smallest bulk ESS over the parameters."""
        return min(self.ess_bulk.values())

    def to_dict(self) -> dict:
        """Plain JSON values."""
        return {"rhat": dict(self.rhat), "ess_bulk": dict(self.ess_bulk), "ess_tail": dict(self.ess_tail),
                "ok": bool(self.ok), "messages": list(self.messages), "max_rhat": self.max_rhat,
                "min_ess": self.min_ess, "ess_parameters": list(self.ess_parameters),
                "mcse": {name: dict(q) for name, q in self.mcse.items()}}

    @classmethod
    def from_dict(cls, d: dict) -> Diagnostics:
        """Inverse of `to_dict`."""
        return cls(rhat=dict(d["rhat"]), ess_bulk=dict(d["ess_bulk"]), ess_tail=dict(d["ess_tail"]),
                   ok=bool(d["ok"]), messages=list(d["messages"]), max_rhat=float(d["max_rhat"]),
                   min_ess=float(d["min_ess"]), ess_parameters=list(d["ess_parameters"]),
                   mcse={name: {k: float(v) for k, v in q.items()} for name, q in d.get("mcse", {}).items()})


def compute_diagnostics(samples: dict[str, np.ndarray], max_rhat: float = 1.01, min_ess: float = 2000.0,
                        ess_parameters: list[str] | None = None, extra_messages: list[str] | None = None
                        ) -> Diagnostics:
    """R-hat, bulk and tail ESS of posterior samples, with a pass/fail verdict.

    Parameters
    ----------
    samples : dict of str -> ndarray of shape (n_chains, n_draws)
        Samples of each parameter, one row per walker (chain).
    max_rhat : float, default 1.01
        Largest acceptable R-hat for every parameter.
    min_ess : float, default 2000
        Smallest acceptable bulk ESS for the parameters in `ess_parameters`.
    ess_parameters : list of str, optional
        Parameters held to `min_ess`; default all.
    extra_messages : list of str, optional
        Failures found elsewhere (e.g. a chain shorter than 50 autocorrelation
        times); they make the verdict fail as well.

    Returns
    -------
    Diagnostics
        With the Monte Carlo standard error of every parameter's quantiles in `QUANTILE_LEVELS`.
    """
    if not samples:
        raise ValueError("samples must hold at least one parameter")
    shapes = {np.shape(v) for v in samples.values()}
    if len(shapes) != 1 or len(next(iter(shapes))) != 2:
        raise ValueError(f"every sample array must have the same shape (n_chains, n_draws), got {shapes}")
    n_chains, n_draws = next(iter(shapes))
    if n_chains < 2 or n_draws < 4:
        raise ValueError(f"diagnostics need >= 2 chains and >= 4 draws, got {n_chains} x {n_draws}")
    az = _arviz()
    with warnings.catch_warnings():  # the (chain, draw) layout is explicit; short runs have fewer draws
        warnings.filterwarnings("ignore", message="More chains", category=UserWarning)
        dataset = az.convert_to_dataset({name: np.asarray(v, dtype=float) for name, v in samples.items()})
    rhat_ds = az.rhat(dataset, method="rank")
    bulk_ds = az.ess(dataset, method="bulk")
    tail_ds = az.ess(dataset, method="tail")
    rhat = {name: float(rhat_ds[name].values) for name in samples}
    bulk = {name: float(bulk_ds[name].values) for name in samples}
    tail = {name: float(tail_ds[name].values) for name in samples}
    mcse_ds = {key: az.mcse(dataset, method="quantile", prob=prob) for key, prob in QUANTILE_LEVELS.items()}
    mcse = {name: {key: float(ds[name].values) for key, ds in mcse_ds.items()} for name in samples}
    held = list(samples) if ess_parameters is None else [p for p in ess_parameters if p in samples]
    messages = list(extra_messages or [])
    for name, value in rhat.items():
        if not value <= max_rhat:  # NaN fails too
            messages.append(f"R-hat of {name} is {value:.4f} > {max_rhat:g}")
    for name in held:
        if not bulk[name] >= min_ess:
            messages.append(f"bulk ESS of {name} is {bulk[name]:.0f} < {min_ess:g}")
    return Diagnostics(rhat=rhat, ess_bulk=bulk, ess_tail=tail, ok=not messages, messages=messages,
                       max_rhat=float(max_rhat), min_ess=float(min_ess), ess_parameters=held, mcse=mcse)


def quadrature_quantiles(problem, centre_mpa: float, levels: dict[str, float] | None = None, *,
                         half_width: float = 0.5, n_fine: int = 601, n_sigma: int = 250) -> dict[str, float]:
    """Quantiles of E of a posterior of (ln E, ln sigma) by quadrature: a reference for the sampler's.

    The unnormalised posterior is evaluated on a grid, fine over ``ln(centre_mpa) +/- half_width`` and
    coarse to the ends of E's prior (large sigma leaves the marginal of E a floor that reaches them), sigma
    over 0.002-20 mm; the marginal of ln E is integrated by trapezoids and its cumulative mass interpolated.

    Parameters
    ----------
    problem : CalibrationProblem
        With parameters ``["log_modulus", "log_sigma"]`` (nu fixed, no discrepancy, no case scatter).
    centre_mpa : float
        Where the posterior's mass lies (e.g. the sampler's median).
    levels : dict of str -> float, optional
        Name -> probability; default `QUANTILE_LEVELS`.
    half_width, n_fine, n_sigma
        The fine part of the grid in ln E and its points, and the points in ln sigma.

    Returns
    -------
    dict of str -> float
        The quantiles of E in MPa.

    Raises
    ------
    ValueError
        For a posterior of other parameters, or one whose sigma reaches the grid's ends.
    """
    if list(problem.parameter_names) != ["log_modulus", "log_sigma"]:
        raise ValueError(f"quadrature needs a posterior of (log_modulus, log_sigma), got {problem.parameter_names}")
    levels = QUANTILE_LEVELS if levels is None else levels
    low, high = (float(np.log(v)) for v in problem.priors.modulus_range_mpa)
    c = float(np.log(centre_mpa))
    log_e = np.unique(np.concatenate([np.linspace(low, c - half_width, 200),
                                      np.linspace(c - half_width, c + half_width, n_fine),
                                      np.linspace(c + half_width, high, 200)]))
    log_e = log_e[(log_e >= low) & (log_e <= high)]
    log_s = np.linspace(np.log(0.002), np.log(20.0), n_sigma)
    grid_e, grid_s = np.meshgrid(log_e, log_s, indexing="ij")
    log_p = problem.log_posterior(np.column_stack([grid_e.ravel(), grid_s.ravel()])).reshape(grid_e.shape)
    density = np.exp(log_p - log_p[np.isfinite(log_p)].max())
    if density[:, [0, -1]].max() > 1e-9 * density.max():
        raise ValueError("the posterior of sigma reaches the quadrature's grid (0.002-20 mm)")
    marginal = density.sum(axis=1)
    cells = 0.5 * (marginal[1:] + marginal[:-1]) * np.diff(log_e)
    cdf = np.concatenate([[0.0], np.cumsum(cells)]) / cells.sum()
    return {key: float(np.exp(np.interp(p, cdf, log_e))) for key, p in levels.items()}
