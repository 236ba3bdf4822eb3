"""Studies that compose the stages: FE designs -> campaigns -> surrogates.

No science of its own lives here: the FE model (`filmcal.fem`), the designs
(`filmcal.doe`), the campaign store (`filmcal.campaign`) and the surrogates
(`filmcal.surrogate`) are wired together so that a calibration can see the FE
model as a validated surrogate (`SurrogateRadiusModel`) or directly
(`FERadiusModel`, FE in the loop).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from filmcal.fem import ContactOptions, Film, evaluate_point, get_model, hertz_radius_mm

# The campaign, design and surrogate stages are imported where they are used:
# reading a study's files (``filmcal correct``) then starts fast.
if TYPE_CHECKING:
    from filmcal.surrogate import GPSurrogate

__all__ = ["SurrogateDomain", "SurrogateValidation", "fe_design_points", "run_fe_points",
           "fit_radius_surrogate", "validate_radius_surrogate", "build_radius_surrogate",
           "SurrogateRadiusModel", "FERadiusModel", "INPUTS", "calibrate_from_study", "posterior_tag",
           "options_tag", "surrogate_path", "refine_radius_surrogate", "load_posterior_samples", "load_or_calibrate", "posterior_path"]

INPUTS = ("modulus_mpa", "poisson", "radius_mm", "force_kn")
#: The held-out design of a study uses seed + TEST_SEED_OFFSET (the training design uses seed).
TEST_SEED_OFFSET = 1000
LOG_INPUTS = ("modulus_mpa", "radius_mm", "force_kn")


@dataclass(frozen=True)
class SurrogateDomain:
    """The domain over which a radius surrogate is trained and validated.

    The default covers Table 1's experiments (R 300-600 mm, F 25-100 kN) with
    margins, film moduli from 400 MPa (softer films collapse at 100 kN) to
    20000 MPa and Poisson's ratios 0.29-0.37 (thin PET films, the paper's
    range). Sphere radii are discrete levels: each needs its own FE model.
    """

    modulus_mpa: tuple[float, float] = (400.0, 20000.0)
    poisson: tuple[float, float] = (0.29, 0.37)
    radius_levels_mm: tuple[float, ...] = (300.0, 375.0, 450.0, 525.0, 600.0)
    force_kn: tuple[float, float] = (20.0, 110.0)

    def space(self):
        """The `filmcal.doe.DesignSpace` of the domain (log E, nu, discrete R levels, F)."""
        from filmcal.doe import DesignSpace, Parameter

        return DesignSpace((Parameter("modulus_mpa", *self.modulus_mpa, unit="MPa", scale="log"),
                            Parameter("poisson", *self.poisson),
                            Parameter("radius_mm", levels=tuple(self.radius_levels_mm), unit="mm"),
                            Parameter("force_kn", *self.force_kn, unit="kN")))

    def bounds(self) -> dict[str, tuple[float, float]]:
        return {"modulus_mpa": self.modulus_mpa, "poisson": self.poisson,
                "radius_mm": (min(self.radius_levels_mm), max(self.radius_levels_mm)),
                "force_kn": self.force_kn}

    def contains(self, modulus_mpa, poisson, radius_mm, force_kn) -> np.ndarray:
        """Elementwise: inside the domain (radius within the levels' span)."""
        b = self.bounds()
        inside = np.ones(np.broadcast(modulus_mpa, poisson, radius_mm, force_kn).shape, bool)
        for name, x in zip(INPUTS, (modulus_mpa, poisson, radius_mm, force_kn)):
            lo, hi = b[name]
            inside &= (np.asarray(x) >= lo * (1 - 1e-12)) & (np.asarray(x) <= hi * (1 + 1e-12))
        return inside


def _option_columns(options: ContactOptions) -> dict:
    return {"sphere_contact": options.sphere_contact, "flat_contact": options.flat_contact,
            "friction_coefficient": options.friction_coefficient, "large_strain": options.large_strain}


def fe_design_points(domain: SurrogateDomain, samples: int, seed: int,
                     options: ContactOptions | None = None) -> list[dict]:
    """An optimal Latin hypercube over the domain as FE campaign points."""
    from filmcal.doe import latin_design

    design = latin_design(domain.space(), samples, seed=seed)
    cols = _option_columns(options or ContactOptions())
    return [dict(zip(INPUTS, map(float, row)), **cols) for row in design.points]


def run_fe_points(points: list[dict], store_path: str | Path, workers: int | None = None,
                  progress: bool = True):
    """Run FE points as a resumable campaign; return the stored results of these points."""
    from filmcal.campaign import Campaign, LocalPoolExecutor

    executor = LocalPoolExecutor(workers)
    try:
        campaign = Campaign(evaluate_point, store_path, model_name="filmcal.fem:evaluate_point", executor=executor)
        campaign.run(points, progress=progress)
    finally:
        executor.shutdown()
    results = campaign.results(status=None)
    return _select(results, points)


def _select(results, points: list[dict]):
    """Rows of `results` matching `points` (inputs and options), in the points' order."""
    keys = {}
    for i in range(len(results.status)):
        k = tuple(round(float(results.inputs[n][i]), 9) for n in INPUTS)
        k += tuple(str(results.inputs.get(o, [""] * len(results.status))[i]) for o in ("sphere_contact", "flat_contact", "large_strain"))
        keys[k] = i
    rows = []
    for p in points:
        k = tuple(round(float(p[n]), 9) for n in INPUTS) + tuple(str(p[o]) for o in ("sphere_contact", "flat_contact", "large_strain"))
        rows.append(keys.get(k, -1))
    rows = np.asarray(rows)
    found = rows >= 0
    X = {n: np.array([p[n] for p in points])[found] for n in INPUTS}
    ok = np.zeros(found.sum(), bool)
    radius = np.full(found.sum(), np.nan)
    idx = rows[found]
    ok[:] = results.status[idx] == "ok"
    radius[:] = np.asarray(results.outputs["contact_radius_mm"], dtype=float)[idx]
    return X, radius, ok


def _excess(X: dict, radius: np.ndarray) -> np.ndarray:
    return radius - hertz_radius_mm(X["radius_mm"], X["force_kn"] * 1e3)


def fit_radius_surrogate(X: dict, radius_mm: np.ndarray, domain: SurrogateDomain, seed: int = 0,
                         n_restarts: int = 8) -> GPSurrogate:
    """GP of the film's radius excess over Hertz, log output, over (log E, nu, log R, log F)."""
    from filmcal.surrogate import GPSurrogate

    return GPSurrogate(list(INPUTS), output="radius_excess_mm", log_inputs=list(LOG_INPUTS),
                       output_transform="log", input_bounds=domain.bounds(), n_restarts=n_restarts,
                       random_state=seed).fit(X, _excess(X, radius_mm))


@dataclass
class SurrogateValidation:
    """Held-out accuracy of a radius surrogate, in radius and in area.

    ``details["points"]`` holds the held-out inputs with the FE radius and the
    surrogate's mean and predictive std (incl. FE noise) at each.
    """

    n: int
    radius_rms_error_mm: float
    radius_max_error_mm: float
    area_rms_relative_error: float
    area_max_relative_error: float
    coverage90: float
    q2: float
    details: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "details"}


def validate_radius_surrogate(surrogate: GPSurrogate, X: dict, radius_mm: np.ndarray) -> SurrogateValidation:
    """Accuracy on held-out FE runs; intervals include the fitted FE noise (a new FE run's jitter)."""
    from filmcal.surrogate import validate

    v = validate(surrogate, X, _excess(X, radius_mm), noise=True)
    excess, std = surrogate.predict(X, return_std=True, noise=True)
    mean = excess + hertz_radius_mm(X["radius_mm"], X["force_kn"] * 1e3)
    area_rel = (mean / radius_mm) ** 2 - 1.0
    err = mean - radius_mm
    points = {**{k: np.asarray(X[k], dtype=float) for k in INPUTS}, "radius_fe_mm": np.asarray(radius_mm, float),
              "radius_mean_mm": mean, "radius_std_mm": std}
    return SurrogateValidation(int(len(radius_mm)), float(np.sqrt(np.mean(err**2))), float(np.max(np.abs(err))),
                               float(np.sqrt(np.mean(area_rel**2))), float(np.max(np.abs(area_rel))),
                               float(v.coverage90), float(v.q2), {"excess": v.__dict__, "points": points})


def build_radius_surrogate(study_dir: str | Path, options: ContactOptions | None = None,
                           domain: SurrogateDomain | None = None, n_train: int = 200, n_test: int = 100,
                           seed: int = 0, workers: int | None = None, progress: bool = True,
                           tag: str | None = None) -> tuple[GPSurrogate, SurrogateValidation]:
    """Train (and validate on held-out runs) the radius surrogate for one set of FE options.

    FE runs go to ``study_dir/runs.sqlite`` (resumable); the surrogate is saved
    as ``study_dir/surrogate-<tag>.npz/.json`` and reused when present.
    """
    options = options or ContactOptions()
    domain = domain or SurrogateDomain()
    study_dir = Path(study_dir)
    study_dir.mkdir(parents=True, exist_ok=True)
    train = fe_design_points(domain, n_train, seed, options)
    test = fe_design_points(domain, n_test, seed + TEST_SEED_OFFSET, options)
    X, radius, ok = run_fe_points(train + test, study_dir / "runs.sqlite", workers, progress)
    n_tr = len(train)
    Xtr = {k: v[:n_tr][ok[:n_tr]] for k, v in X.items()}
    Xte = {k: v[n_tr:][ok[n_tr:]] for k, v in X.items()}
    path = surrogate_path(study_dir, options) if tag is None else study_dir / f"surrogate-{tag}"
    from filmcal.surrogate import load_surrogate, save_surrogate

    if path.with_name(path.name + ".json").exists():
        surrogate = load_surrogate(path)
    else:
        surrogate = fit_radius_surrogate(Xtr, radius[:n_tr][ok[:n_tr]], domain, seed)
        save_surrogate(surrogate, path)
    return surrogate, validate_radius_surrogate(surrogate, Xte, radius[n_tr:][ok[n_tr:]])


def surrogate_path(study_dir: str | Path, options: ContactOptions) -> Path:
    """Where a study keeps the radius surrogate of these FE options (without suffix)."""
    return Path(study_dir) / f"surrogate-{options_tag(options)}"


def posterior_path(study_dir: str | Path, film: str, loads: str | None = None, options: ContactOptions | None = None,
                   seed: int = 0) -> Path:
    """Where a study keeps the posterior of a film's calibration (default: all loads, default FE options)."""
    return Path(study_dir) / f"posterior-{posterior_tag(film, loads, options or ContactOptions(), seed=seed)}.json"


class SurrogateRadiusModel:
    """A radius surrogate seen by the calibration: ``predict(E, nu, R, F) -> (mean, std)``.

    The std includes the FE model's numerical jitter (the GP's fitted noise).
    Points outside the surrogate's domain get a NaN mean.
    """

    def __init__(self, surrogate: GPSurrogate, domain: SurrogateDomain | None = None) -> None:
        self.surrogate = surrogate
        self.domain = domain or SurrogateDomain()

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        e, nu, r, f = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                            (modulus_mpa, poisson, sphere_radius_mm, force_n)))
        shape = e.shape
        X = {"modulus_mpa": e.ravel(), "poisson": nu.ravel(), "radius_mm": r.ravel(), "force_kn": f.ravel() / 1e3}
        mean, std = self.surrogate.predict(X, return_std=True, noise=True)
        mean = mean + hertz_radius_mm(X["radius_mm"], f.ravel())
        inside = self.domain.contains(*(X[n] for n in INPUTS))
        mean = np.where(inside, mean, np.nan)
        return mean.reshape(shape), std.reshape(shape)


class FERadiusModel:
    """The FE model itself seen by the calibration (FE in the loop): std = 0.

    Slow per call compared with a surrogate; meant for deterministic checks
    (e.g. inverting each case) rather than for MCMC.
    """

    def __init__(self, options: ContactOptions | None = None) -> None:
        self.options = options or ContactOptions()

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        e, nu, r, f = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in
                                            (modulus_mpa, poisson, sphere_radius_mm, force_n)))
        out = np.empty(e.shape)
        for idx in np.ndindex(e.shape):
            res = get_model(float(r[idx])).solve(Film(float(e[idx]), float(nu[idx])), float(f[idx]), self.options)
            out[idx] = res.contact_radius_mm if res.converged else np.nan
        return out, np.zeros(e.shape)


def options_tag(options: ContactOptions) -> str:
    """A file-name tag of the FE options."""
    return (f"{options.sphere_contact}-{options.flat_contact}-mu{options.friction_coefficient:g}-"
            f"{'large' if options.large_strain else 'small'}")


def calibrate_from_study(study_dir: str | Path, film: str, loads: str | None = None,
                         options: ContactOptions | None = None, poisson: str = "fixed",
                         discrepancy: str | None = None, seed: int = 0, n_train: int = 200, n_test: int = 100,
                         workers: int | None = None, max_steps: int | None = None, progress: bool = False):
    """Calibrate one film type on the study's FE surrogate; save the posterior as JSON.

    Returns ``(result, validation, radius_model, posterior_path)``. Everything
    (FE runs, surrogate, chain, posterior) is kept in `study_dir` and reused.
    """
    from filmcal.calibration import Priors, calibrate_film, load_table1, save_result

    load_table1(film, loads)  # check film and loads before any FE work
    options = options or ContactOptions()
    domain = SurrogateDomain()
    study = Path(study_dir)
    surrogate, validation = build_radius_surrogate(study, options, domain, n_train, n_test, seed, workers, progress)
    model = SurrogateRadiusModel(surrogate, domain)
    tag = posterior_tag(film, loads, options, poisson, discrepancy, seed)
    result = calibrate_film(film, model, loads, poisson=poisson, discrepancy=discrepancy,
                            priors=Priors(modulus_range_mpa=domain.modulus_mpa), seed=seed,
                            backend_path=study / f"chain-{tag}.h5", max_steps=max_steps, progress=progress)
    path = save_result(result, study / f"posterior-{tag}.json")
    return result, validation, model, path


def posterior_tag(film: str, loads: str | None, options: ContactOptions, poisson: str = "fixed",
                  discrepancy: str | None = None, seed: int = 0) -> str:
    """The file-name tag of a calibration in a study folder."""
    return (f"{film.upper()}-{(loads or 'all').replace(' ', '')}-{poisson}-{discrepancy or 'none'}-seed{seed}-"
            f"{options_tag(options)}")


def load_posterior_samples(study_dir: str | Path, film: str, loads: str | None = None,
                           options: ContactOptions | None = None, seed: int = 0) -> tuple[dict, Path]:
    """Posterior samples (name -> ndarray) of a film's calibration saved in a study, and the file.

    Raises
    ------
    FileNotFoundError
        When the study holds no such posterior (run ``filmcal pipeline`` or ``filmcal calibrate``).
    """
    import json

    path = posterior_path(study_dir, film, loads, options, seed)
    if not path.exists():
        raise FileNotFoundError(f"no posterior of {film.upper()} in {study_dir} ({path.name}): run `filmcal pipeline` "
                                "or `filmcal calibrate` first")
    samples = json.loads(path.read_text(encoding="utf-8"))["samples"]
    return {k: np.asarray(v, dtype=float) for k, v in samples.items()}, path


def load_or_calibrate(study_dir: str | Path, film: str, loads: str | None = None, seed: int = 0, log=print):
    """The study's `CalibrationResult` of a film (default FE options), calibrated first when missing."""
    from filmcal.calibration import load_result

    path = posterior_path(study_dir, film, loads, seed=seed)
    if path.exists():
        log(f"{film}: reading {path}")
        return load_result(path)
    log(f"{film}: no posterior in {study_dir}, calibrating on the FE surrogate ...")
    result, _, _, written = calibrate_from_study(study_dir, film, loads, seed=seed, progress=True)
    log(f"{film}: wrote {written} ({result.elapsed_s:.0f} s)")
    return result


def refine_radius_surrogate(study_dir: str | Path, surrogate: GPSurrogate, options: ContactOptions | None = None,
                            domain: SurrogateDomain | None = None, target: float = 0.002,
                            max_evaluations: int = 64, batch_size: int = 8, seed: int = 0,
                            workers: int | None = None, experiments_radii_mm=(300.0, 450.0, 600.0),
                            experiments_force_kn=(25.0, 100.0)):
    """Add FE runs where the surrogate is least certain, in the region that matters for calibration.

    Candidates are drawn over the experiments' sphere radii and force range
    with every film modulus and Poisson's ratio of the domain; the batch with
    the largest relative predictive std of the radius excess is run through
    the study's campaign store (resumable), the surrogate is refitted on all
    runs, until the largest relative std is below `target` or `max_evaluations`
    runs were spent. Returns `filmcal.surrogate.RefinementResult`.
    """
    from filmcal.surrogate import refine

    options = options or ContactOptions()
    domain = domain or SurrogateDomain()
    store = Path(study_dir) / "runs.sqlite"
    cols = _option_columns(options)
    radii = np.asarray(experiments_radii_mm, dtype=float)

    def sampler(n: int, rng: np.random.Generator) -> dict:
        lo_e, hi_e = np.log(domain.modulus_mpa)
        return {"modulus_mpa": np.exp(rng.uniform(lo_e, hi_e, n)),
                "poisson": rng.uniform(*domain.poisson, n),
                "radius_mm": rng.choice(radii, n),
                "force_kn": rng.uniform(*experiments_force_kn, n)}

    def evaluate(points: dict) -> np.ndarray:
        design = [dict({k: float(points[k][i]) for k in INPUTS}, **cols) for i in range(len(points["radius_mm"]))]
        X, radius, ok = run_fe_points(design, store, workers, progress=False)
        return np.where(ok, _excess(X, radius), np.nan)

    X = {k: np.asarray(v, dtype=float) for k, v in zip(INPUTS, surrogate.X_train_.T)}
    return refine(surrogate, X, surrogate.y_train_, evaluate, sampler, target=target,
                  max_evaluations=max_evaluations, batch_size=batch_size, random_state=seed)
