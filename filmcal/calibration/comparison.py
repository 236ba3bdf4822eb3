"""Model comparison and model-form uncertainty: which radius model the data prefer, and their mixture.

A *model* here is any radius model calibrated on the same data: the same
film under another imprint reading (``edge``, ``activation``, ``capsule``),
other film kinematics (small or large strain), or any other callable. Each
calibrated model is a posterior with its pointwise log-likelihood
(`filmcal.calibration.posterior.posterior_inference_data`).

Per model, `assess_model` reports

- ``rms_residual_mm``: RMS of measured radius minus posterior predictive mean;
- ``ppc_inside_90``: rows inside their central 90 % posterior predictive
  interval (`filmcal.calibration.checks.predictive_check`), of ``n_data``;
- ``elpd_loo`` with its standard error, ``p_loo`` and the Pareto k of each
  left-out unit: Pareto-smoothed importance-sampling leave-one-out (ArviZ
  `loo`; Vehtari, Gelman & Gabry, Stat. Comput. 27, 2017). The unit left out
  is the case (the joint of its repeats); with one imprint per case, as in
  Table 1, that is the row.

Across models, `compare_models` corrects the leave-one-out terms that PSIS
cannot be trusted with: a case whose Pareto k exceeds 0.7 is left out and
the model calibrated again without it (the caller's ``refit``), and its term
becomes the exact ``log mean_s p(r_case | theta_s)`` over the refit's draws.
From the corrected pointwise terms it gives three sets of weights:

- **pseudo-BMA+** (Yao, Vehtari, Simpson & Gelman, Bayesian Analysis 13,
  2018): ``w_k`` proportional to ``exp(n sum_i alpha_i elpd_k,i)``, averaged
  over Bayesian-bootstrap draws ``alpha ~ Dirichlet(1, ..., 1)`` of the cases.
  It is smooth in the ELPD differences and carries their uncertainty: models
  the data cannot separate share the weight (their bootstrap draws swap the
  lead), a clearly worse model keeps a small weight rather than none;
- **stacking** (the same paper): the weights of the mixture of predictive
  densities that maximises the leave-one-out log score. For models with the
  same predictive densities its objective is flat and the optimum a corner
  (weight 1 and 0), so it is reported, not used;
- the **weights used** (``ModelComparison.weights``) are the pseudo-BMA+
  weights, a model below `MIN_WEIGHT` (0.001) left out: no step larger than
  that in any ELPD difference (moving one model's ELPD by 0.1 moves a weight
  by at most 0.025, since ``dw_k / d elpd_k = w_k (1 - w_k)``), and a mixture's 90 % band contains the median of every
  model of weight >= 0.1 (half of such a model's mass, >= 5 % of the mixture,
  lies on either side of its median).

`combine_posteriors` then draws the mixture: each sample carries the label
of its model, so that a corrector evaluates every sample with its own radius
model and pools the answers; the pooled band then spans what separates the
models that share the weight.
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from filmcal.calibration.checks import predictive_check
from filmcal.calibration.likelihood import CalibrationProblem
from filmcal.calibration.posterior import LOG_LIKELIHOOD_CASE

__all__ = [
    "MixturePosterior",
    "ModelAssessment",
    "ModelComparison",
    "assess_model",
    "combine_posteriors",
    "compare_models",
    "pseudo_bma_plus_weights",
    "stacking_weights",
]

#: Models whose pseudo-BMA+ weight is below this are left out of the mixture (and the rest renormalised):
#: they would cost solves and refits without moving an answer (a weight jumps by at most this much).
MIN_WEIGHT = 1e-3

#: Pareto k above which an importance-sampling leave-one-out estimate is unreliable.
PARETO_K_THRESHOLD = 0.7


def _quiet_arviz():
    """ArviZ, imported without its refactoring notice."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az
    return az


@dataclass(frozen=True)
class ModelAssessment:
    """Fit and out-of-sample predictive performance of one calibrated model.

    Attributes
    ----------
    name : str
    n_data : int
        Data rows.
    n_cases : int
        Units left out by the leave-one-out (cases).
    rms_residual_mm : float
        RMS of (measured radius - posterior predictive mean) over the rows.
    ppc_inside_90 : int
        Rows inside their central 90 % posterior predictive interval.
    elpd_loo, elpd_loo_se, p_loo : float
        PSIS-LOO expected log pointwise predictive density, its standard
        error and the effective number of parameters.
    pareto_k : ndarray of shape (n_cases,)
        Pareto shape of each left-out case's importance weights.
    modulus_mpa : dict
        Median and 90 % interval of E under this model.
    """

    name: str
    n_data: int
    n_cases: int
    rms_residual_mm: float
    ppc_inside_90: int
    elpd_loo: float
    elpd_loo_se: float
    p_loo: float
    pareto_k: np.ndarray
    modulus_mpa: dict

    @property
    def pareto_k_max(self) -> float:
        """Largest Pareto k."""
        return float(np.max(self.pareto_k))

    @property
    def n_pareto_k_high(self) -> int:
        """Cases whose leave-one-out estimate is unreliable (k > 0.7)."""
        return int(np.sum(self.pareto_k > PARETO_K_THRESHOLD))

    def to_dict(self) -> dict:
        """Plain JSON values."""
        return {"name": self.name, "n_data": self.n_data, "n_cases": self.n_cases,
                "rms_residual_mm": self.rms_residual_mm, "ppc_inside_90": self.ppc_inside_90,
                "elpd_loo": self.elpd_loo, "elpd_loo_se": self.elpd_loo_se, "p_loo": self.p_loo,
                "pareto_k": self.pareto_k.tolist(), "pareto_k_max": self.pareto_k_max,
                "n_pareto_k_high": self.n_pareto_k_high, "modulus_mpa": self.modulus_mpa}


def assess_model(problem: CalibrationProblem, idata, name: str | None = None,
                 max_samples: int = 2000) -> ModelAssessment:
    """Fit and PSIS-LOO of one calibrated model.

    Parameters
    ----------
    problem : CalibrationProblem
        The model's calibration problem (data, radius model, options).
    idata : arviz.InferenceData
        Its posterior (`posterior_inference_data`).
    name : str, optional
        Label; default the ``model`` attribute of `idata`.
    max_samples : int, default 2000
        Posterior samples pushed through the model for the predictive check.
    """
    az = _quiet_arviz()
    label = name if name is not None else str(idata.posterior.attrs.get("model", "model"))
    named = {k: idata.posterior[k].values for k in idata.posterior.data_vars}
    theta = problem.theta_from_named(named).reshape(-1, problem.ndim)
    check = predictive_check(problem, theta, level=0.9, max_samples=max_samples)
    rms = float(np.sqrt(np.mean((check.measured_radius_mm - check.mean_mm) ** 2)))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # high-k warnings are reported through pareto_k
        loo = az.loo(idata, pointwise=True, var_name=LOG_LIKELIHOOD_CASE)
    modulus = np.asarray(named["modulus_mpa"]).ravel()
    lo, med, hi = np.quantile(modulus, [0.05, 0.5, 0.95])
    return ModelAssessment(
        name=label, n_data=len(problem.data), n_cases=problem.n_cases, rms_residual_mm=rms,
        ppc_inside_90=int(np.sum(~check.outside)), elpd_loo=float(loo.elpd_loo), elpd_loo_se=float(loo.se),
        p_loo=float(loo.p_loo), pareto_k=np.asarray(loo.pareto_k.values, dtype=float),
        modulus_mpa={"median": float(med), "ci90": [float(lo), float(hi)]})


@dataclass(frozen=True)
class ModelComparison:
    """Models of the same data, side by side.

    Attributes
    ----------
    assessments : dict of str -> ModelAssessment
    weights : dict of str -> float
        The weights used (sum 1): the pseudo-BMA+ weights.
    stacking_weights : dict of str -> float
        Stacking weights of the corrected leave-one-out terms, reported.
    pseudo_bma_weights : dict of str -> float
        Pseudo-BMA+ weights (Bayesian bootstrap).
    table : list of dict
        Best first: ``name``, ``rank``, ``elpd_loo`` (with exact refits), ``se``, ``elpd_diff``, ``dse``,
        ``p_loo``, ``n_refit``, ``n_pareto_k_high``, ``stacking_weight``, ``pseudo_bma_weight``, ``weight``.
    preferred : str
        The model of largest weight (ties: largest ELPD).
    elpd_loo : dict of str -> float
        Each model's ELPD-LOO after the exact refits.
    n_refit : int
        Cases refitted exactly (over all models).
    """

    assessments: dict
    weights: dict
    stacking_weights: dict
    pseudo_bma_weights: dict
    table: list
    preferred: str
    elpd_loo: dict
    n_refit: int

    def to_dict(self) -> dict:
        """Plain JSON values."""
        return {"models": {k: a.to_dict() for k, a in self.assessments.items()}, "weights": dict(self.weights),
                "stacking_weights": dict(self.stacking_weights), "pseudo_bma_weights": dict(self.pseudo_bma_weights),
                "table": list(self.table), "preferred": self.preferred, "elpd_loo": dict(self.elpd_loo),
                "n_refit": self.n_refit, "weights_rule": "pseudo-BMA+"}


def _log_mean_exp(x: np.ndarray, axis: int = 0) -> np.ndarray:
    top = np.max(x, axis=axis, keepdims=True)
    return np.squeeze(top, axis=axis) + np.log(np.mean(np.exp(x - top), axis=axis))


def _refit_theta(problem: CalibrationProblem, samples) -> np.ndarray:
    """Sampled coordinates (k, ndim) of a refit's named samples (nu dropped when the problem fixes it)."""
    named = {k: np.asarray(v, dtype=float) for k, v in samples.items()}
    if problem.poisson_mode == "fixed":
        named.pop("poisson", None)
    return problem.theta_from_named(named).reshape(-1, problem.ndim)


def _exact_terms(problems: Mapping[str, CalibrationProblem], high: list[tuple[str, int]], refit, workers,
                 progress=None) -> dict:
    """``{(model, case): exact leave-one-case-out term}`` from refits without the case."""
    if not high:
        return {}
    ref = next(iter(problems.values()))
    tasks = {(name, case): (refit, (name, ref.data.select(ref.case_index != case))) for name, case in high}
    fits: dict = {}

    def done(key, value, k=None) -> None:
        fits[key] = value
        if progress is not None:
            progress(len(fits), len(tasks))

    if workers is None:
        for key, (fn, args) in tasks.items():
            done(key, fn(*args))
    else:
        from filmcal._parallel import run_tasks

        run_tasks(tasks, workers, done)
    out = {}
    for (name, case), samples in fits.items():
        theta = _refit_theta(problems[name], samples)
        out[name, case] = float(_log_mean_exp(problems[name].case_log_likelihood(theta)[:, case]))
    return out


def pseudo_bma_plus_weights(pointwise: np.ndarray, n_bootstrap: int = 1000, random_state: int = 0) -> np.ndarray:
    """Pseudo-BMA+ weights of models from their pointwise leave-one-out terms (Yao et al. 2018, eq. 10).

    Parameters
    ----------
    pointwise : ndarray, shape (n_models, n_cases)
    n_bootstrap : int
        Bayesian-bootstrap draws.
    random_state : int
    """
    elpd_i = np.asarray(pointwise, dtype=float)
    n = elpd_i.shape[1]
    alpha = np.random.default_rng(random_state).dirichlet(np.ones(n), size=n_bootstrap)  # (B, n)
    z = n * alpha @ elpd_i.T  # (B, n_models)
    z -= z.max(axis=1, keepdims=True)
    w = np.exp(z)
    w /= w.sum(axis=1, keepdims=True)
    return w.mean(axis=0)


def stacking_weights(pointwise: np.ndarray) -> np.ndarray:
    """Stacking weights: maximise ``sum_i log sum_k w_k exp(elpd_k,i)`` over the simplex (Yao et al. 2018)."""
    from scipy.optimize import minimize
    from scipy.special import logsumexp, softmax

    elpd_i = np.asarray(pointwise, dtype=float)
    k = elpd_i.shape[0]

    def loss(z: np.ndarray) -> float:
        return -float(np.sum(logsumexp(elpd_i.T + np.log(softmax(np.append(z, 0.0))), axis=1)))

    best = minimize(loss, np.zeros(k - 1), method="L-BFGS-B")
    return softmax(np.append(best.x, 0.0))


def compare_models(models: Mapping[str, tuple[CalibrationProblem, object]], max_samples: int = 2000,
                   random_state: int = 0, refit=None, workers=None, n_bootstrap: int = 1000,
                   progress=None) -> ModelComparison:
    """Assess every model and weigh them by their leave-one-case-out predictive accuracy (module docstring).

    Parameters
    ----------
    models : mapping of name -> (CalibrationProblem, InferenceData)
        At least two models calibrated on the same measured radii.
    max_samples : int
        As in `assess_model`.
    random_state : int
        Seed of the Bayesian bootstrap of the pseudo-BMA+ weights.
    refit : callable, optional
        ``refit(name, data) -> named samples``: model ``name`` calibrated on ``data`` (the data without one
        case); called for every case whose Pareto k exceeds 0.7. Without it those terms stay PSIS's.
    workers : int or Executor, optional
        Where the refits run (`filmcal._parallel.run_tasks`); None: in this process.
    n_bootstrap : int
        Bayesian-bootstrap draws of the pseudo-BMA+ weights.
    progress : callable, optional
        ``progress(done, total)`` after each exact refit.

    Raises
    ------
    ValueError
        With fewer than two models, or models of different data.
    """
    az = _quiet_arviz()
    if len(models) < 2:
        raise ValueError(f"models must hold at least 2 calibrated models, got {len(models)}")
    names = list(models)
    ref_problem = models[names[0]][0]
    for name in names[1:]:
        problem = models[name][0]
        same = (len(problem.data) == len(ref_problem.data)
                and np.array_equal(problem.target_radius_mm, ref_problem.target_radius_mm)
                and np.array_equal(problem.case_index, ref_problem.case_index))
        if not same:
            raise ValueError(f"model {name!r} was calibrated on other data than {names[0]!r}; "
                             "models are compared on the same measured radii only")
    assessments = {name: assess_model(problem, idata, name, max_samples) for name, (problem, idata) in
                   models.items()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pointwise = {name: np.asarray(az.loo(idata, pointwise=True, var_name=LOG_LIKELIHOOD_CASE).loo_i.values,
                                      dtype=float) for name, (_, idata) in models.items()}
    high = [(name, int(case)) for name in names
            for case in np.flatnonzero(assessments[name].pareto_k > PARETO_K_THRESHOLD)]
    exact = (_exact_terms({n: models[n][0] for n in names}, high, refit, workers, progress)
             if refit is not None else {})
    for (name, case), term in exact.items():
        pointwise[name][case] = term
    matrix = np.array([pointwise[n] for n in names])
    n_cases = matrix.shape[1]
    elpd = matrix.sum(axis=1)
    pseudo_bma = pseudo_bma_plus_weights(matrix, n_bootstrap, random_state)
    stacking = stacking_weights(matrix)
    used = np.where(pseudo_bma >= MIN_WEIGHT, pseudo_bma, 0.0)
    used /= used.sum()
    best = int(np.argmax(elpd))
    table = []
    for k in np.argsort(-elpd, kind="stable"):
        diff = matrix[best] - matrix[k]
        table.append({"name": names[k], "rank": len(table), "elpd_loo": float(elpd[k]),
                      "se": float(math.sqrt(n_cases * np.var(matrix[k]))), "elpd_diff": float(diff.sum()),
                      "dse": float(math.sqrt(n_cases * np.var(diff))), "p_loo": assessments[names[k]].p_loo,
                      "n_refit": sum(1 for (n, _) in exact if n == names[k]),
                      "n_pareto_k_high": assessments[names[k]].n_pareto_k_high,
                      "stacking_weight": float(stacking[k]), "pseudo_bma_weight": float(pseudo_bma[k]),
                      "weight": float(used[k])})
    weights = {n: float(w) for n, w in zip(names, used)}
    preferred = max(names, key=lambda n: (weights[n], elpd[names.index(n)]))
    return ModelComparison(assessments=assessments, weights=weights,
                           stacking_weights={n: float(w) for n, w in zip(names, stacking)},
                           pseudo_bma_weights={n: float(w) for n, w in zip(names, pseudo_bma)}, table=table,
                           preferred=preferred,
                           elpd_loo={n: float(e) for n, e in zip(names, elpd)},
                           n_refit=len(exact))


@dataclass(frozen=True)
class MixturePosterior:
    """Samples of a mixture of model posteriors, each labelled with its model.

    Attributes
    ----------
    model : ndarray of str, shape (n,)
        The model each sample belongs to.
    samples : dict of str -> ndarray of shape (n,)
        The parameters every model has (``modulus_mpa``, ``poisson``,
        ``sigma_mm``, ...).
    weights : dict of str -> float
        The mixture weights.
    counts : dict of str -> int
        Samples drawn from each model.
    """

    model: np.ndarray
    samples: dict
    weights: dict
    counts: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.model.size)

    def by_model(self) -> dict[str, dict[str, np.ndarray]]:
        """The samples of each model that has any, as posterior dicts a corrector takes."""
        out = {}
        for name in self.weights:
            mask = self.model == name
            if np.any(mask):
                out[name] = {k: v[mask] for k, v in self.samples.items()}
        return out

    def to_dict(self) -> dict:
        """Plain JSON values (samples included)."""
        return {"model": self.model.tolist(), "samples": {k: v.tolist() for k, v in self.samples.items()},
                "weights": dict(self.weights), "counts": dict(self.counts)}

    @classmethod
    def from_dict(cls, d: dict) -> MixturePosterior:
        """Inverse of `to_dict`."""
        return cls(model=np.asarray(d["model"], dtype=str),
                   samples={k: np.asarray(v, dtype=float) for k, v in d["samples"].items()},
                   weights={k: float(v) for k, v in d["weights"].items()},
                   counts={k: int(v) for k, v in d.get("counts", {}).items()})


def _flat_samples(posterior) -> dict[str, np.ndarray]:
    """Samples of one model as flat arrays: from InferenceData or a dict of arrays."""
    if hasattr(posterior, "posterior"):
        post = posterior.posterior
        return {k: np.asarray(post[k].values, dtype=float).ravel() for k in post.data_vars}
    if isinstance(posterior, Mapping):
        return {k: np.asarray(v, dtype=float).ravel() for k, v in posterior.items()}
    raise ValueError("each posterior must be an InferenceData or a dict of sample arrays")


def _allocate(weights: np.ndarray, n: int) -> np.ndarray:
    """Integer counts summing to n, proportional to the weights (largest remainders)."""
    exact = weights * n
    counts = np.floor(exact).astype(int)
    short = n - int(counts.sum())
    if short > 0:
        counts[np.argsort(-(exact - counts), kind="stable")[:short]] += 1
    return counts


def combine_posteriors(results: Mapping[str, object], weights: Mapping[str, float],
                       random_state: int | np.random.Generator | None = 0,
                       n_samples: int | None = None) -> MixturePosterior:
    """Draw the weighted mixture of several model posteriors.

    Parameters
    ----------
    results : mapping of name -> InferenceData or dict of arrays
        Each model's posterior samples (`posterior_inference_data`, or
        ``CalibrationResult.samples``). A model without ``poisson`` samples
        must have it fixed: give it in the dict.
    weights : mapping of name -> float
        Mixture weights (e.g. ``compare_models(...).weights``); >= 0, not all
        0; normalised here. Models with weight 0 contribute no sample.
    random_state : int or numpy.random.Generator, optional
        Seed of the draws: the same seed gives the same mixture.
    n_samples : int, optional
        Size of the mixture; default the number of samples of the smallest
        posterior with a positive weight.

    Returns
    -------
    MixturePosterior
        ``round(w_m n)`` samples from model m (largest remainders), drawn
        without replacement where the posterior has enough, each labelled.
    """
    if set(results) != set(weights):
        raise ValueError(f"weights must name the same models as results: {sorted(results)} vs {sorted(weights)}")
    names = list(results)
    w = np.array([float(weights[n]) for n in names])
    if not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights must be finite, >= 0 and not all 0, got {dict(weights)}")
    w = w / w.sum()
    flat = {name: _flat_samples(results[name]) for name in names}
    for name, s in flat.items():
        if "modulus_mpa" not in s:
            raise ValueError(f"posterior of model {name!r} has no modulus_mpa samples")
    common = set.intersection(*(set(s) for s in flat.values()))
    sizes = {name: flat[name]["modulus_mpa"].size for name in names}
    if n_samples is None:
        n_samples = min(sizes[name] for name, wi in zip(names, w) if wi > 0)
    if isinstance(n_samples, bool) or not isinstance(n_samples, (int, np.integer)) or n_samples < 1:
        raise ValueError(f"n_samples must be an integer >= 1, got {n_samples!r}")
    rng = np.random.default_rng(random_state)
    counts = _allocate(w, int(n_samples))
    labels, columns = [], {k: [] for k in sorted(common)}
    for name, count in zip(names, counts):
        if count == 0:
            continue
        size = sizes[name]
        take = rng.choice(size, size=count, replace=count > size)
        labels.append(np.full(count, name))
        for k in columns:
            columns[k].append(flat[name][k][take])
    order = rng.permutation(int(counts.sum()))
    model = np.concatenate(labels)[order]
    samples = {k: np.concatenate(v)[order] for k, v in columns.items()}
    return MixturePosterior(model=model, samples=samples, weights=dict(zip(names, map(float, w))),
                            counts={n: int(c) for n, c in zip(names, counts)})

