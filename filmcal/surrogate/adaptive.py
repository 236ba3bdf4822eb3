"""Adaptive refinement: add model runs where the surrogate is least certain.

The criterion is the weighted predictive standard deviation of the smooth
latent function, ``w(x) * std(x)``, or relative to the prediction,
``w(x) * std(x) / |mean(x)|``; the weight ``w`` marks the region that matters
(e.g. film moduli near the calibrated value). A batch is chosen greedily with
the kriging believer: after each pick the GP is conditioned on a pseudo
observation there (hyperparameters fixed), which lowers the predictive variance
around it, so that the next pick goes elsewhere. With fixed hyperparameters the
updated variance does not depend on the believed value, so it is computed
exactly by rank-one updates.

The relative criterion goes with ``output_transform="log"``, where the GP's
std is itself a relative std and stationary in the log. With a standardised
output it packs points where the output is small, and the stationary kernel
then grows overconfident where the output is large and steep (on a smooth
test function: 90 % coverage 0.77 after relative refinement with
``"standardize"``, 0.89 with ``"log"``).

`refine` drives the loop: evaluate a batch with a user-supplied callable
(e.g. a function running finite-element campaigns), refit, and repeat until
the largest weighted std falls below a target or the evaluation budget is spent.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import solve_triangular
from scipy.stats import qmc
from sklearn.base import clone
from sklearn.utils.validation import check_is_fitted

from filmcal.surrogate.gp import GPSurrogate
from filmcal.surrogate.transforms import as_input_matrix

__all__ = [
    "Batch",
    "RefinementStep",
    "RefinementResult",
    "sample_candidates",
    "weighted_std",
    "select_batch",
    "refine",
]

Weight = Callable[[dict[str, np.ndarray]], np.ndarray]
Sampler = Callable[[int, np.random.Generator], object]


def sample_candidates(bounds: Mapping[str, Sequence[float]], n: int, *, log_inputs: Sequence[str] = (),
                      random_state: int | np.random.Generator | None = None) -> dict[str, np.ndarray]:
    """Latin-hypercube sample of a box domain (log-uniform for log inputs).

    Parameters
    ----------
    bounds : mapping of name -> (low, high)
        The domain, in physical units.
    n : int
        Number of points.
    log_inputs : sequence of str
        Inputs sampled uniformly in log scale (bounds must be > 0).
    random_state : int, Generator or None
        Seed.

    Returns
    -------
    dict of name -> ndarray of shape (n,)
    """
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be an integer >= 1, got {n!r}")
    names = list(bounds)
    unknown = [name for name in log_inputs if name not in names]
    if unknown:
        raise ValueError(f"log_inputs names input(s) {unknown} without bounds; bounds given for {names}")
    lo_hi = np.array([np.asarray(bounds[name], dtype=float) for name in names])
    if lo_hi.shape != (len(names), 2) or not np.all(np.isfinite(lo_hi)) or np.any(lo_hi[:, 0] >= lo_hi[:, 1]):
        raise ValueError(f"bounds must map each input to (low, high) with low < high, got {dict(bounds)!r}")
    is_log = np.array([name in log_inputs for name in names])
    if np.any(lo_hi[is_log] <= 0):
        raise ValueError("bounds of log inputs must be > 0")
    lo_hi[is_log] = np.log(lo_hi[is_log])
    unit = qmc.LatinHypercube(len(names), rng=np.random.default_rng(random_state)).random(n)
    values = lo_hi[:, 0] + unit * (lo_hi[:, 1] - lo_hi[:, 0])
    values[:, is_log] = np.exp(values[:, is_log])
    return {name: values[:, j] for j, name in enumerate(names)}


def _criterion(surrogate: GPSurrogate, candidates: object, weight: Weight | None, relative: bool
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """GP coordinates, GP cross-terms, latent variance and std-to-score factor of candidates."""
    check_is_fitted(surrogate)
    names = surrogate.input_names_
    X = as_input_matrix(candidates, names)
    T = surrogate.input_transform_.transform(X)
    K_cross = surrogate.kernel_(T, surrogate.X_gp_)
    V = solve_triangular(surrogate.cholesky_, K_cross.T, lower=True, check_finite=False)
    mean = K_cross @ surrogate.dual_coef_
    var = np.maximum(surrogate.kernel_.k1.diag(T) - np.einsum("ij,ij->j", V, V), 0.0)
    factor = np.abs(surrogate.output_transform_.derivative(mean))
    if relative:
        factor = factor / np.maximum(np.abs(surrogate.output_transform_.inverse(mean)), np.finfo(float).tiny)
    if weight is not None:
        w = np.asarray(weight({name: X[:, j] for j, name in enumerate(names)}), dtype=float)
        if w.shape != (X.shape[0],) or not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError(f"weight must return {X.shape[0]} finite values >= 0")
        factor = factor * w
    return T, V, var, factor


def weighted_std(surrogate: GPSurrogate, candidates: object, weight: Weight | None = None,
                 relative: bool = True) -> np.ndarray:
    """Refinement criterion ``w(x) * std(x)`` (``/ |mean(x)|`` if `relative`).

    Parameters
    ----------
    surrogate : GPSurrogate
        A fitted surrogate.
    candidates : mapping, DataFrame or array of shape (m, d)
        Points in physical units.
    weight : callable, optional
        ``weight(points) -> (m,)`` non-negative weights, `points` a dict of
        input name -> values; default 1.
    relative : bool, default True
        Divide by the absolute predicted mean.

    Returns
    -------
    ndarray of shape (m,)
        The std is that of the smooth latent function in output units.
    """
    _, _, var, factor = _criterion(surrogate, candidates, weight, relative)
    return factor * np.sqrt(var)


@dataclass(frozen=True)
class Batch:
    """Points chosen for the next model runs.

    Attributes
    ----------
    points : dict of name -> ndarray
        The chosen points (physical units), in the order they were picked.
    indices : ndarray of int
        Their rows in the candidate set.
    scores : ndarray
        Criterion of each point when it was picked (after the believer updates).
    max_score : float
        Largest criterion over all candidates before any pick.
    """

    points: dict[str, np.ndarray]
    indices: np.ndarray
    scores: np.ndarray
    max_score: float


def select_batch(surrogate: GPSurrogate, candidates: object, batch_size: int, *,
                 weight: Weight | None = None, relative: bool = True) -> Batch:
    """Pick `batch_size` candidates with the largest weighted std (kriging believer).

    Parameters
    ----------
    surrogate : GPSurrogate
        A fitted surrogate.
    candidates : mapping, DataFrame or array of shape (m, d)
        Candidate points in physical units.
    batch_size : int
        Number of points to pick (fewer if fewer candidates have a score > 0).
    weight, relative
        As in `weighted_std`.

    Returns
    -------
    Batch
    """
    if not isinstance(batch_size, (int, np.integer)) or batch_size < 1:
        raise ValueError(f"batch_size must be an integer >= 1, got {batch_size!r}")
    T, V, var, factor = _criterion(surrogate, candidates, weight, relative)
    X = as_input_matrix(candidates, surrogate.input_names_)
    noise = surrogate.noise_variance_
    latent = surrogate.kernel_.k1
    updates: list[np.ndarray] = []
    picked: list[int] = []
    scores: list[float] = []
    max_score = float(np.max(factor * np.sqrt(var)))
    for _ in range(min(batch_size, X.shape[0])):
        score = factor * np.sqrt(var)
        score[picked] = -np.inf
        j = int(np.argmax(score))
        if not score[j] > 0:
            break
        # Covariance of every candidate with candidate j given the data and the earlier picks.
        cov = latent(T, T[j:j + 1])[:, 0] - V.T @ V[:, j]
        for u in updates:
            cov -= u * u[j]
        u = cov / np.sqrt(var[j] + noise)
        var = np.maximum(var - u**2, 0.0)
        updates.append(u)
        picked.append(j)
        scores.append(float(score[j]))
    indices = np.array(picked, dtype=int)
    points = {name: X[indices, k] for k, name in enumerate(surrogate.input_names_)}
    return Batch(points=points, indices=indices, scores=np.array(scores), max_score=max_score)


@dataclass(frozen=True)
class RefinementStep:
    """One iteration of `refine`.

    Attributes
    ----------
    iteration : int
        0 for the initial surrogate.
    n_points : int
        Training points of the surrogate assessed in this step.
    max_score : float
        Largest weighted (relative) std over this step's candidates.
    n_new : int
        Points sent to `evaluate` after the assessment (0 in the last step).
    n_failed : int
        Of those, results that were not finite (dropped).
    """

    iteration: int
    n_points: int
    max_score: float
    n_new: int
    n_failed: int


@dataclass(frozen=True)
class RefinementResult:
    """Outcome of `refine`.

    Attributes
    ----------
    surrogate : GPSurrogate
        The last fitted surrogate.
    X : ndarray of shape (n, d)
        All training points (physical units), columns ``surrogate.input_names_``.
    y : ndarray of shape (n,)
        Their outputs.
    steps : tuple of RefinementStep
    converged : bool
        Whether the target was reached (else the budget ran out).
    n_evaluations : int
        Points sent to `evaluate`, failures included.
    n_failed : int
        Evaluations that returned a non-finite value.
    """

    surrogate: GPSurrogate
    X: np.ndarray
    y: np.ndarray
    steps: tuple[RefinementStep, ...]
    converged: bool
    n_evaluations: int
    n_failed: int


def _candidate_source(domain: Mapping[str, Sequence[float]] | Sampler, names: list[str],
                      log_inputs: Sequence[str]) -> Sampler:
    if callable(domain):
        return domain
    if not isinstance(domain, Mapping) or set(domain) != set(names):
        got = sorted(domain) if isinstance(domain, Mapping) else type(domain).__name__
        raise ValueError(f"domain must give (low, high) for exactly the inputs {names}; got {got}")
    return lambda n, rng: sample_candidates(domain, n, log_inputs=log_inputs, random_state=rng)


def refine(surrogate: GPSurrogate, X: object, y: object,
           evaluate: Callable[[dict[str, np.ndarray]], object],
           domain: Mapping[str, Sequence[float]] | Sampler, *,
           target: float = 0.01, max_evaluations: int = 100, batch_size: int = 8,
           n_candidates: int = 2000, weight: Weight | None = None, relative: bool = True,
           random_state: int | np.random.Generator | None = None,
           callback: Callable[[RefinementStep], None] | None = None) -> RefinementResult:
    """Refine a surrogate with batches of model runs until it is accurate enough.

    Each iteration draws fresh candidates from `domain`, stops if the largest
    `weighted_std` is at most `target` (converged) or if the budget is spent,
    and otherwise evaluates a `select_batch` batch and refits a clone of
    `surrogate` on all finite results.

    Parameters
    ----------
    surrogate : GPSurrogate
        Settings of the surrogate (cloned and refitted at each iteration).
    X, y : initial design and its outputs
        As `GPSurrogate.fit` takes them.
    evaluate : callable
        ``evaluate(points) -> y`` with `points` a dict of input name -> (b,)
        values; returns (b,) outputs, NaN for a failed run (dropped, counted).
    domain : mapping of name -> (low, high), or callable
        Box domain sampled by `sample_candidates` (log-uniform for the
        surrogate's `log_inputs`), or ``sampler(n, rng) -> candidates``.
    target : float, default 0.01
        Accuracy goal for the largest weighted (relative) std.
    max_evaluations : int, default 100
        Budget of points sent to `evaluate`.
    batch_size : int, default 8
        Points per batch.
    n_candidates : int, default 2000
        Candidates drawn per iteration.
    weight, relative
        As in `weighted_std`.
    random_state : int, Generator or None
        Seed of the candidate draws.
    callback : callable, optional
        Called with each `RefinementStep` (progress reporting).

    Returns
    -------
    RefinementResult
    """
    if not (np.isfinite(target) and target > 0):
        raise ValueError(f"target must be > 0, got {target!r}")
    if not isinstance(max_evaluations, (int, np.integer)) or max_evaluations < 0:
        raise ValueError(f"max_evaluations must be an integer >= 0, got {max_evaluations!r}")
    rng = np.random.default_rng(random_state)
    model = clone(surrogate).fit(X, y)
    names = model.input_names_
    X_all, y_all = model.X_train_, model.y_train_
    draw = _candidate_source(domain, names, model.log_inputs)
    steps: list[RefinementStep] = []
    n_evaluations = n_failed = 0
    iteration = 0
    while True:
        candidates = draw(n_candidates, rng)
        budget = min(batch_size, max_evaluations - n_evaluations)
        score = float(np.max(weighted_std(model, candidates, weight, relative)))
        converged = score <= target
        if converged or budget <= 0:
            step = RefinementStep(iteration, X_all.shape[0], score, 0, 0)
            steps.append(step)
            if callback is not None:
                callback(step)
            break
        batch = select_batch(model, candidates, budget, weight=weight, relative=relative)
        X_new = np.column_stack([batch.points[name] for name in names])
        y_new = _evaluated(evaluate, batch.points, X_new.shape[0], model.output)
        ok = np.isfinite(y_new)
        n_evaluations += X_new.shape[0]
        n_failed += int((~ok).sum())
        step = RefinementStep(iteration, X_all.shape[0], score, X_new.shape[0], int((~ok).sum()))
        steps.append(step)
        if callback is not None:
            callback(step)
        X_all = np.vstack([X_all, X_new[ok]])
        y_all = np.concatenate([y_all, y_new[ok]])
        model = clone(surrogate).set_params(inputs=names).fit(X_all, y_all)
        iteration += 1
    return RefinementResult(surrogate=model, X=X_all, y=y_all, steps=tuple(steps), converged=converged,
                            n_evaluations=n_evaluations, n_failed=n_failed)


def _evaluated(evaluate: Callable[[dict[str, np.ndarray]], object], points: dict[str, np.ndarray],
               n: int, output: str) -> np.ndarray:
    """Call `evaluate` and check that it returned `n` numbers (NaN allowed)."""
    result = evaluate({name: values.copy() for name, values in points.items()})
    try:
        values = np.asarray(result[output] if isinstance(result, Mapping) else result, dtype=float)
    except (TypeError, ValueError, KeyError):
        raise ValueError(f"evaluate must return {n} numbers (NaN for a failed run)") from None
    if values.shape != (n,):
        raise ValueError(f"evaluate returned shape {values.shape} for {n} points")
    return values
