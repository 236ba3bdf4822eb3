"""Leave-one-case-out cross-validation of the sphere-on-flat correction.

For each (R, F) case of a film: calibrate the film without that case, correct
the case's measured radius, and check whether the Hertz area (the truth of
these Hertzian experiments) lies inside the corrected 90 % interval. A
correction that can be trusted puts it there in about 9 of 10 cases.

`psis_leave_one_case_out` does this from the one posterior calibrated on all
cases: the posterior without case i is the full posterior reweighted by
``1 / p(r_i | theta)``, the weights Pareto-smoothed (PSIS; Vehtari, Gelman &
Gabry, Stat. Comput. 27, 2017; ArviZ `psislw`). Where the Pareto shape k of
a case's weights exceeds 0.7 the reweighting is unreliable and that case is
refitted exactly by the caller's `refit` function; the result says how many
refits that took. The reweighted draws are resampled (sampling-importance
resampling) and handed to the product's corrector, `SphereCorrector`, so the
folds check the corrector users run. With several models (imprint readings,
film kinematics) and their weights, each model's posterior is reweighted on
its own and the corrections are pooled in proportion to the weights, the
weights themselves held fixed.

`cross_validate_case` / `leave_one_case_out` are the exact refits of Table 1
folds (one calibration per case). Nothing here imports the orchestration
layer: models, data and posteriors come in as arguments.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Callable, Mapping

import numpy as np

from filmcal.correction.sphere import SphereCorrector
from filmcal.hertz import hertz_radius_mm

__all__ = ["CaseCrossValidation", "cross_validate_case", "leave_one_case_out", "psis_leave_one_case_out",
           "PARETO_K_REFIT"]

#: Pareto k above which a fold is refitted exactly.
PARETO_K_REFIT = 0.7


@dataclass
class CaseCrossValidation:
    """Corrections of each held-out imprint by a posterior that did not see its case (arrays of shape (n,)).

    Attributes
    ----------
    film : str
    sphere_radius_mm, force_n, measured_radius_mm : ndarray
        The imprints (one per case for Table 1).
    hertz_area_mm2 : ndarray
        The truth: pi a_Hertz^2 of the imprint's bodies.
    area_mm2, area_std_mm2 : ndarray
        Corrected area (posterior mean and std) of each held-out imprint.
    area_ci90_mm2 : ndarray, shape (n, 2)
        Its 90 % interval.
    modulus_median_mpa : ndarray
        Median of E of each fold's posterior (pooled over models).
    pareto_k : ndarray or None
        Largest Pareto k of the fold's importance weights over the models
        (NaN for exact folds); None for folds of `leave_one_case_out`.
    refit : ndarray of bool or None
        Whether the fold was refitted exactly (for at least one model).
    method : str
        ``"refit"`` (every fold calibrated anew) or ``"psis"``.
    """

    film: str
    sphere_radius_mm: np.ndarray
    force_n: np.ndarray
    measured_radius_mm: np.ndarray
    hertz_area_mm2: np.ndarray
    area_mm2: np.ndarray
    area_std_mm2: np.ndarray
    area_ci90_mm2: np.ndarray
    modulus_median_mpa: np.ndarray
    pareto_k: np.ndarray | None = None
    refit: np.ndarray | None = None
    method: str = "refit"

    @property
    def inside(self) -> np.ndarray:
        """Whether each Hertz area lies inside its corrected 90 % interval."""
        return (self.area_ci90_mm2[:, 0] <= self.hertz_area_mm2) & (self.hertz_area_mm2 <= self.area_ci90_mm2[:, 1])

    @property
    def hits(self) -> int:
        return int(self.inside.sum())

    @property
    def n_refits(self) -> int:
        """Folds calibrated anew: every fold for ``method="refit"``, the high-k ones for PSIS."""
        if self.refit is None:
            return int(self.area_mm2.size)
        return int(np.sum(self.refit))

    @property
    def band_percent(self) -> np.ndarray:
        """Width of each 90 % interval as a percentage of the corrected area."""
        return 100.0 * (self.area_ci90_mm2[:, 1] - self.area_ci90_mm2[:, 0]) / self.area_mm2

    def to_dict(self) -> dict:
        """Plain JSON values (NaN Pareto k as None)."""
        out = {}
        for k, v in self.__dict__.items():
            if isinstance(v, np.ndarray):
                v = [None if isinstance(x, float) and not np.isfinite(x) else x for x in v.tolist()] \
                    if v.ndim == 1 else v.tolist()
            out[k] = v
        out["n_refits"] = self.n_refits
        out["hits"] = self.hits
        return out

    @classmethod
    def from_dict(cls, d: dict) -> CaseCrossValidation:
        """Inverse of `to_dict`."""
        floats = ("sphere_radius_mm", "force_n", "measured_radius_mm", "hertz_area_mm2", "area_mm2",
                  "area_std_mm2", "area_ci90_mm2", "modulus_median_mpa")
        kw = {k: np.asarray(d[k], dtype=float) for k in floats}
        if d.get("pareto_k") is not None:
            kw["pareto_k"] = np.array([np.nan if x is None else x for x in d["pareto_k"]], dtype=float)
        if d.get("refit") is not None:
            kw["refit"] = np.asarray(d["refit"], dtype=bool)
        return cls(film=str(d["film"]), method=str(d.get("method", "refit")), **kw)

    @classmethod
    def from_folds(cls, film: str, folds: list[dict]) -> CaseCrossValidation:
        """Gather the outputs of `cross_validate_case`, one per case, in case order."""
        keys = ("sphere_radius_mm", "force_n", "measured_radius_mm", "hertz_area_mm2", "area_mm2", "area_std_mm2",
                "area_ci90_mm2", "modulus_median_mpa")
        return cls(film, *(np.asarray([f[k] for f in folds], dtype=float) for k in keys))


def cross_validate_case(model, film: str, case: int, loads: str | None = None, priors=None, seed: int = 0) -> dict:
    """One fold: calibrate `film` without case `case` of Table 1 and correct that case's measured radius.

    Parameters
    ----------
    model : RadiusModel
        ``predict(E, nu, R, F) -> (mean, std)`` of the printed radius (e.g. a
        `filmcal.surrogate.radius.SurrogateRadiusModel`).
    film : str
        MS, HS or HHS.
    case : int
        Index of the held-out case in ``load_table1(film, loads)``.
    loads : str, optional
        Load range of the data (default: all loads).
    priors : filmcal.calibration.Priors, optional
    seed : int
        Seed of the fold's chains and scatter draws (the fold uses ``seed + case``).
    """
    from filmcal.calibration import calibrate, load_table1

    data = load_table1(film, loads)
    if not 0 <= case < len(data):
        raise ValueError(f"case must be in [0, {len(data) - 1}], got {case}")
    keep = np.ones(len(data), bool)
    keep[case] = False
    result = calibrate(data.select(keep), model, film=film, loads=loads, priors=priors, seed=seed + case)
    corrected = SphereCorrector(model, result.samples, random_state=seed + case).correct(
        data.measured_radius_mm[case], data.sphere_radius_mm[case], data.force_n[case])
    r, f = float(data.sphere_radius_mm[case]), float(data.force_n[case])
    return {"sphere_radius_mm": r, "force_n": f, "measured_radius_mm": float(data.measured_radius_mm[case]),
            "hertz_area_mm2": float(np.pi * hertz_radius_mm(r, f) ** 2), "area_mm2": float(corrected.area_mm2),
            "area_std_mm2": float(corrected.area_std_mm2),
            "area_ci90_mm2": [float(x) for x in corrected.area_ci90_mm2],
            "modulus_median_mpa": float(result.modulus_mpa["median"])}


def leave_one_case_out(model, film: str, loads: str | None = None, priors=None, seed: int = 0,
                       log=None) -> CaseCrossValidation:
    """All folds of a film type in turn (see `cross_validate_case`)."""
    from filmcal.calibration import load_table1

    folds = []
    for case in range(len(load_table1(film, loads))):
        folds.append(cross_validate_case(model, film, case, loads, priors, seed))
        if log:
            log(f"{film} fold {case + 1}: R{folds[-1]['sphere_radius_mm']:g} / {folds[-1]['force_n'] / 1e3:g} kN")
    return CaseCrossValidation.from_folds(film, folds)


def _refits(folds: list[tuple[int, str]], refit: Callable, data, case_index: np.ndarray, workers) -> dict:
    """``{(case, model): refit(model, data without case)}`` for the listed folds, in parallel with `workers`."""
    tasks = {(case, n): (refit, (n, data.select(case_index != case))) for case, n in folds}
    if workers is None:
        return {key: fn(*args) for key, (fn, args) in tasks.items()}
    from filmcal._parallel import run_tasks

    out: dict = {}
    run_tasks(tasks, workers, lambda key, posterior, k: out.__setitem__(key, posterior))
    return out


def _psislw(neg_log_lik: np.ndarray, reff: float) -> tuple[np.ndarray, float]:
    """Pareto-smoothed normalised log weights and the Pareto k of one fold (ArviZ)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz as az

        log_w, k = az.psislw(neg_log_lik, reff=reff)
    return np.asarray(log_w, dtype=float), float(np.asarray(k))


def _relative_ess(named: dict[str, np.ndarray]) -> float:
    """Relative efficiency of the draws, as ArviZ's `loo` takes it: mean bulk ESS (method "mean") over the
    parameters divided by the number of draws; 1 for a single chain."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz as az

        first = next(iter(named.values()))
        n_chain, n_draw = first.shape[:2]
        if n_chain < 2:
            return 1.0
        ess = [float(az.ess(np.asarray(v, dtype=float), method="mean")) for v in named.values()]
    return float(np.clip(np.mean(ess) / (n_chain * n_draw), 1e-3, None))


def _as_theta(problem, posterior) -> np.ndarray:
    """Sampled coordinates of a posterior (InferenceData, dict of named samples or array), (chains, draws, ndim)."""
    if hasattr(posterior, "posterior"):
        post = posterior.posterior
        named = {k: post[k].values for k in post.data_vars}
    elif isinstance(posterior, Mapping):
        named = {k: np.asarray(v, dtype=float) for k, v in posterior.items()}
    else:
        theta = np.asarray(posterior, dtype=float)
        return theta if theta.ndim == 3 else theta.reshape(1, -1, problem.ndim)
    if "poisson" in named and problem.poisson_mode == "fixed":
        named = {k: v for k, v in named.items() if k != "poisson"}
    theta = problem.theta_from_named(named)
    return theta if theta.ndim == 3 else theta.reshape(1, -1, problem.ndim)


def _reported(problem, theta: np.ndarray) -> dict[str, np.ndarray]:
    """The parameters as an InferenceData posterior holds them (nu included when fixed)."""
    named = problem.named_samples(theta)
    named.setdefault("poisson", np.full(theta.shape[:-1], float(problem.priors.poisson)))
    return named


def _corrector_samples(problem, theta: np.ndarray) -> dict[str, np.ndarray]:
    p = problem.unpack(theta)
    return {"modulus_mpa": p["modulus_mpa"], "poisson": p["poisson"],
            "sigma_mm": np.sqrt(p["sigma_mm"] ** 2 + p["case_sigma_mm"] ** 2)}


def _draws_per_model(models: Mapping[str, tuple], weights: Mapping[str, float] | None,
                     n_draws: int) -> tuple[list[str], np.ndarray]:
    """The models' names and how many of the `n_draws` each gives a fold (by weight, largest remainders),
    after checking that the models hold the same data."""
    if not models:
        raise ValueError("models must hold at least one (problem, posterior) pair")
    names = list(models)
    if weights is not None and set(weights) != set(names):
        raise ValueError(f"weights must name the same models as models: {sorted(weights)} vs {sorted(names)}")
    w = np.ones(len(names)) if weights is None else np.array([float(weights[n]) for n in names])
    if not np.all(np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
        raise ValueError(f"weights must be finite, >= 0 and not all 0, got {weights}")
    w = w / w.sum()
    if not (isinstance(n_draws, (int, np.integer)) and n_draws >= 10):
        raise ValueError(f"n_draws must be an integer >= 10, got {n_draws!r}")
    ref = models[names[0]][0]
    for n in names[1:]:
        if not (np.array_equal(models[n][0].target_radius_mm, ref.target_radius_mm)
                and np.array_equal(models[n][0].case_index, ref.case_index)):
            raise ValueError(f"model {n!r} holds other data than {names[0]!r}")
    counts = np.floor(w * n_draws).astype(int)
    counts[np.argsort(-(w * n_draws - counts), kind="stable")[:n_draws - counts.sum()]] += 1
    return names, counts


def _fold_areas(problem, data, samples: dict, count: int, rows: np.ndarray, seed: int) -> np.ndarray:
    """Corrected area samples (rows x draws) of a left-out case's rows, from one model's fold posterior."""
    corrector = SphereCorrector(problem.model, samples, max_samples=count, random_state=seed)
    out = corrector.correct(problem.target_radius_mm[rows], data.sphere_radius_mm[rows], data.force_n[rows],
                            data.measurement_std_mm[rows])
    # back from the steel-equivalent radius to the row's bodies (no change for steel)
    shift = data.hertz_radius_mm[rows] - data.steel_hertz_radius_mm[rows]
    radius = np.sqrt(out.samples_mm2 / np.pi) + shift[:, None]
    return np.pi * np.clip(radius, 0.0, None) ** 2


def _fold_row(data, row: int, a: np.ndarray, modulus: np.ndarray, pareto_k: float, refitted: bool) -> dict:
    """One left-out row's answer: its pooled area samples summarised, with the fold's modulus and Pareto k."""
    return {"sphere_radius_mm": float(data.sphere_radius_mm[row]), "force_n": float(data.force_n[row]),
            "measured_radius_mm": float(data.measured_radius_mm[row]),
            "hertz_area_mm2": float(np.pi * data.hertz_radius_mm[row] ** 2),
            "area_mm2": float(a.mean()), "area_std_mm2": float(a.std(ddof=1)),
            "area_ci90_mm2": [float(x) for x in np.quantile(a, [0.05, 0.95])],
            "modulus_median_mpa": float(np.median(modulus)), "pareto_k": float(pareto_k),
            "refit": refitted}


def psis_leave_one_case_out(models: Mapping[str, tuple], weights: Mapping[str, float] | None = None,
                            refit: Callable[[str, object], object] | None = None, *, film: str | None = None,
                            n_draws: int = 2000, k_threshold: float = PARETO_K_REFIT,
                            random_state: int | np.random.Generator | None = 0,
                            log: Callable[[str], None] | None = None, workers=None) -> CaseCrossValidation:
    """Leave-one-case-out cross-validation of the correction from the full posterior(s).

    Parameters
    ----------
    models : mapping of name -> (CalibrationProblem, posterior)
        Each model's calibration problem (its data and radius model) and its
        posterior on all cases: InferenceData, a dict of reported samples
        (``CalibrationResult.samples``, walkers x draws) or sampled
        coordinates (chains, draws, ndim). All models must hold the same data.
    weights : mapping of name -> float, optional
        Weights of the models in the combined correction (e.g. from
        `filmcal.calibration.comparison.compare_models`); default equal.
        Held fixed over the folds.
    refit : callable, optional
        ``refit(name, data_without_case) -> posterior`` (same forms as
        above): an exact calibration of model `name` on the other cases,
        called only for folds whose Pareto k exceeds `k_threshold`. Without
        it such folds keep their PSIS estimate and stay flagged by their k.
    film : str, optional
        Label; default the data's film.
    n_draws : int, default 2000
        Posterior draws resampled per fold and model for the corrector.
    k_threshold : float, default 0.7
    random_state : int or Generator, optional
        Seed of the resampling and of the corrector's scatter draws.
    log : callable, optional
        Receives one line per refit.
    workers : int or filmcal._parallel.Executor, optional
        Where the refits run, together (`filmcal._parallel.run_tasks`):
        worker processes, or a pool; `refit` must then be picklable (a
        module-level function or a `functools.partial` of one). Default: one
        after the other in this process.

    Returns
    -------
    CaseCrossValidation
        One row per imprint of the data (left out with its whole case), with
        ``method="psis"``, the Pareto k of each fold and which folds were
        refitted (``n_refits``).
    """
    names, counts = _draws_per_model(models, weights, n_draws)
    problems = {n: models[n][0] for n in names}
    ref = problems[names[0]]
    rng = np.random.default_rng(random_state)
    data = ref.data

    thetas = {n: _as_theta(problems[n], models[n][1]) for n in names}
    case_ll = {n: problems[n].case_log_likelihood(thetas[n].reshape(-1, problems[n].ndim))
               .reshape(thetas[n].shape[:2] + (problems[n].n_cases,)) for n in names}
    reff = {n: _relative_ess(_reported(problems[n], thetas[n])) for n in names}

    # the Pareto k of every fold first, so that the exact refits can run together
    smoothed = {(case, n): _psislw(-case_ll[n][..., case].ravel(), reff[n])
                for case in range(ref.n_cases) for n, count in zip(names, counts) if count > 0}
    exact = _refits([key for key, (_, k) in smoothed.items() if k > k_threshold], refit, data, ref.case_index,
                    workers) if refit is not None else {}

    rows_out = []
    for case in range(ref.n_cases):
        rows = np.flatnonzero(ref.case_index == case)
        area_samples, moduli, ks, refitted = [], [], [], False
        for n, count in zip(names, counts):
            if count == 0:
                continue
            problem = problems[n]
            flat = thetas[n].reshape(-1, problem.ndim)
            log_w, k = smoothed[case, n]
            if (case, n) in exact:
                fold_theta = _as_theta(problem, exact[case, n]).reshape(-1, problem.ndim)
                take = rng.choice(fold_theta.shape[0], size=count, replace=count > fold_theta.shape[0])
                draws = fold_theta[take]
                refitted = True
                ks.append(k)
                if log:
                    log(f"fold {case + 1} ({n}): Pareto k {k:.2f} > {k_threshold:g}, refitted")
            else:
                prob = np.exp(log_w - log_w.max())
                draws = flat[rng.choice(flat.shape[0], size=count, replace=True, p=prob / prob.sum())]
                ks.append(k)
            samples = _corrector_samples(problem, draws)
            moduli.append(samples["modulus_mpa"])
            area_samples.append(_fold_areas(problem, data, samples, count, rows, int(rng.integers(2**31))))
        pooled = np.concatenate(area_samples, axis=1)
        modulus = np.concatenate(moduli)
        rows_out.extend((row, _fold_row(data, row, pooled[j], modulus, max(ks), refitted))
                        for j, row in enumerate(rows))
    rows_out.sort(key=lambda t: t[0])
    folds = [f for _, f in rows_out]
    label = film if film is not None else ",".join(dict.fromkeys(data.film.tolist()))
    cv = CaseCrossValidation.from_folds(label, folds)
    cv.pareto_k = np.array([f["pareto_k"] for f in folds])
    cv.refit = np.array([f["refit"] for f in folds], dtype=bool)
    cv.method = "psis"
    return cv
