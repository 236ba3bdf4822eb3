"""The whole job on the embedded default, in one study folder.

Stages, each kept in the folder and reused when present, so that an
interrupted run loses no finished work and a second run only reads:

``design``        quality of the optimal Latin hypercubes (``design.json``)
``calibration``   FE campaign (``runs.sqlite``) -> validated surrogate
                  (``surrogate-*.npz/json``, ``surrogate-validation.json``) ->
                  posterior of each film (``posterior-*.json``, chains ``*.h5``)
``verification``  FE against Hertz without film and FE against the surrogate at
                  the posterior medians (``fe-verification.json``)
``curves``        wheel-rail correction curves with 90 % bands, smooth and rough
                  wheel (``curves-<film>.csv``)
``outlines``      wheel-rail contact outlines with and without film
                  (``wheelrail-outlines.json``)
``crossval``      leave-one-case-out cross-validation of the sphere-on-flat
                  correction on Table 1 (``crossval-<film>.json``)
``report``        HTML and PDF report (``report/``)

The settings and seed are written to ``settings.json`` (with their hash) on
the first run; a later run with other settings in the same folder is refused
rather than mixed, while films may be added.
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from filmcal._json import json_safe
from filmcal.films import FILM_TYPES, FILM_THICKNESS_MM

__all__ = ["PipelineSettings", "run_pipeline", "settings_hash"]

#: Sphere and force of the pressure profiles shown in the report (the DESIGN's Hertz example).
PROFILE_CASE = (450.0, 75_000.0)
FILM_POISSON = 0.33


@dataclass(frozen=True)
class PipelineSettings:
    """Sizes of the pipeline's stages (`quick` is a small version for tests).

    Attributes
    ----------
    train_runs, test_runs : int
        FE runs of the surrogate's training design and of its held-out design.
    offsets_mm, forces_kn : tuple of float
        Grid of the wheel-rail correction curves.
    rough_ra_um : float or None
        Roughness Ra of the rough-wheel curves (None: smooth wheel only).
    outline_force_kn : float
        Load of the contact outlines (the paper's Fig. 7 uses 50 kN).
    crossval_films : tuple of str
        Film types cross-validated leave-one-case-out on Table 1 (ten
        calibrations each).
    max_steps : int or None
        Cap of the MCMC steps per walker (None: until converged).
    """

    train_runs: int = 200
    test_runs: int = 100
    offsets_mm: tuple[float, ...] = tuple(float(x) for x in np.arange(-7.0, 2.01, 1.0))
    forces_kn: tuple[float, ...] = (50.0, 100.0)
    rough_ra_um: float | None = 1.5
    outline_force_kn: float = 50.0
    crossval_films: tuple[str, ...] = FILM_TYPES
    max_steps: int | None = None

    @classmethod
    def quick(cls) -> "PipelineSettings":
        """Few FE runs, three offsets at 50 kN, short chains: a minute or two."""
        return cls(train_runs=40, test_runs=12, offsets_mm=(-6.0, -3.0, 0.0), forces_kn=(50.0,),
                   crossval_films=("HS",), max_steps=3000)


def settings_hash(settings: PipelineSettings, seed: int) -> str:
    """SHA-256 (first 16 hex digits) of the settings and the seed as canonical JSON."""
    text = json.dumps(json_safe({"settings": asdict(settings), "seed": seed}), sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _write_json(path: Path, obj) -> None:
    """Write whole or not at all."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(json_safe(obj), indent=1) + "\n", encoding="utf-8")
    tmp.replace(path)


def _check_settings(study: Path, record: dict) -> dict:
    """The folder's record: its settings must be these; films add up over runs."""
    path = study / "settings.json"
    if path.exists():
        old = json.loads(path.read_text(encoding="utf-8"))
        if old.get("hash") != record["hash"]:
            raise ValueError(f"study_dir {study} holds a study made with other settings (hash {old.get('hash')}, "
                             f"now {record['hash']}); use another --study-dir")
        films = set(old["films"]) | set(record["films"])
        record = {**record, "films": [f for f in FILM_TYPES if f in films]}
        if record["films"] == old["films"]:
            return record  # unchanged: keep the file (and its time stamp, which the report stage reads)
    _write_json(path, record)
    return record


def run_pipeline(study_dir: str | Path, settings: PipelineSettings | None = None, films=FILM_TYPES,
                 seed: int = 0, workers: int | None = None, log=print, report: bool = True) -> dict:
    """Run (or resume) the pipeline; returns the summary also written to ``summary.json``.

    Parameters
    ----------
    study_dir : str or Path
        The study folder (created if missing).
    settings : PipelineSettings, optional
        Stage sizes (default: the full study).
    films : sequence of str
        Film types to calibrate and propagate (with those of earlier runs in
        the same folder).
    seed : int
        Seed of the designs, the surrogate and the chains.
    workers : int, optional
        FE worker processes (default: all cores).
    log : callable
        Progress messages.
    report : bool
        Write the HTML and PDF report at the end.
    """
    settings = settings or PipelineSettings()
    films = [f.upper() for f in films]
    study = Path(study_dir)
    study.mkdir(parents=True, exist_ok=True)
    record = _check_settings(study, {"settings": asdict(settings), "films": films, "seed": seed,
                                     "hash": settings_hash(settings, seed)})
    films = record["films"]  # with those of earlier runs in this folder, which are reused
    t0 = time.perf_counter()
    summary: dict = {"study_dir": str(study), **record, "films": {}, "stages_s": {}}

    def stage(name: str, fn, *args):
        t = time.perf_counter()
        out = fn(*args)
        summary["stages_s"][name] = time.perf_counter() - t
        return out

    stage("design", _design_stage, study, settings, seed, log)
    results = stage("calibration", _calibration_stage, study, settings, films, seed, workers, log)
    medians = {film: float(r.modulus_mpa["median"]) for film, (r, _) in results.items()}
    stage("verification", _verification_stage, study, medians, log)
    stage("curves", _curves_stage, study, settings, results, workers, log)
    stage("outlines", _outlines_stage, study, settings, medians, log)
    stage("crossval", _crossval_stage, study, settings, films, seed, workers, log)
    for film, (result, path) in results.items():
        d = result.to_dict()
        s = {k: d[k] for k in ("modulus_mpa", "oedometric_modulus_mpa", "sigma_mm", "rhat", "ess", "n_data")}
        s.update(diagnostics_ok=bool(result.diagnostics_ok), posterior_file=str(path),
                 curves_file=str(study / f"curves-{film}.csv"),
                 predictive_hits=int(np.sum(~result.predictive.outside)), n_cases=int(len(result.predictive.outside)))
        crossval = study / f"crossval-{film}.json"
        if crossval.exists():
            from filmcal.correction.crossval import CaseCrossValidation

            s["crossval_hits"] = CaseCrossValidation.from_dict(json.loads(crossval.read_text())).hits
        summary["films"][film] = s
    summary["surrogate_validation"] = json.loads((study / "surrogate-validation.json").read_text())["summary"]
    if report:
        summary["report"] = stage("report", _report_stage, study, log)
    summary["elapsed_s"] = time.perf_counter() - t0
    _write_json(study / "summary.json", summary)
    return summary


# ------------------------------------------------------------------ stages
def _design_stage(study: Path, settings: PipelineSettings, seed: int, log) -> None:
    path = study / "design.json"
    if path.exists():
        return
    from scipy.stats import qmc

    from filmcal.doe import design_quality, latin_design
    from filmcal.study import TEST_SEED_OFFSET, SurrogateDomain

    log("[design] optimal Latin hypercubes and their quality")
    space = SurrogateDomain().space()
    out = {"names": list(space.names)}
    for name, n, s in (("train", settings.train_runs, seed), ("test", settings.test_runs, seed + TEST_SEED_OFFSET)):
        design = latin_design(space, n, seed=s)
        # reference: plain random Latin hypercubes of the same size, realised on the same discrete levels
        rng = np.random.default_rng(s)
        ref = [design_quality(space.to_unit(space.to_physical(qmc.LatinHypercube(d=space.d, seed=rng).random(n))))
               .as_dict() for _ in range(10)]
        out[name] = {"n": n, "seed": s, "quality": design.quality.as_dict(), "unit": design.unit,
                     "random_lhs_median": {k: float(np.median([r[k] for r in ref])) for k in ref[0]
                                           if k != "latin"}}
    _write_json(path, out)


def _calibration_stage(study: Path, settings: PipelineSettings, films, seed: int, workers, log) -> dict:
    from filmcal.calibration import load_result
    from filmcal.study import calibrate_from_study, posterior_path

    results = {}
    for film in films:
        path = posterior_path(study, film, seed=seed)
        if path.exists() and (study / "surrogate-validation.json").exists():
            results[film] = (load_result(path), path)
            continue
        log(f"[calibration] {film}: FE campaign, surrogate and posterior")
        result, validation, _, path = calibrate_from_study(
            study, film, None, seed=seed, n_train=settings.train_runs, n_test=settings.test_runs, workers=workers,
            max_steps=settings.max_steps, progress=True)
        results[film] = (result, path)
        vpath = study / "surrogate-validation.json"
        if not vpath.exists():
            _write_json(vpath, {"summary": validation.to_dict(), "points": validation.details["points"]})
    return results


def _verification_stage(study: Path, medians: dict, log) -> None:
    path = study / "fe-verification.json"
    if path.exists() and set(json.loads(path.read_text())["films"]) >= set(medians):
        return
    from filmcal.calibration import load_table1
    from filmcal.fem import ContactOptions, Film, get_model
    from filmcal.study import SurrogateDomain, SurrogateRadiusModel, surrogate_path
    from filmcal.surrogate import load_surrogate

    log("[verification] FE without film against Hertz; FE against the surrogate at the posterior medians")
    data = load_table1("HS")  # the ten (R, F) cases (the same for every film)
    cases = [(float(r), float(f)) for r, f in zip(data.sphere_radius_mm, data.force_n)]
    hertz = []
    for r, f in cases:
        res = get_model(r).solve(None, f)
        hertz.append({"radius_mm": r, "force_n": f, "fe_radius_mm": res.contact_radius_mm,
                      "hertz_radius_mm": res.hertz_radius_mm, "fe_max_pressure_mpa": res.max_pressure_mpa,
                      "converged": res.converged})
    options = ContactOptions()
    model = SurrogateRadiusModel(load_surrogate(surrogate_path(study, options)), SurrogateDomain())
    films = {}
    for film, e in medians.items():
        rows = []
        for r, f in cases:
            res = get_model(r).solve(Film(e, FILM_POISSON), f, options)
            mean, std = model.predict(e, FILM_POISSON, r, f)
            rows.append({"radius_mm": r, "force_n": f, "fe_radius_mm": res.contact_radius_mm,
                         "surrogate_mean_mm": float(mean), "surrogate_std_mm": float(std), "converged": res.converged})
        films[film] = {"modulus_mpa": e, "cases": rows}
    r, f = PROFILE_CASE
    profiles = {"no film": _profile(get_model(r).solve(None, f))}
    for film, e in medians.items():
        profiles[f"{film} film, E = {e:.0f} MPa"] = _profile(get_model(r).solve(Film(e, FILM_POISSON), f, options))
    _write_json(path, {"hertz": hertz, "films": films, "profile_case": {"radius_mm": r, "force_n": f},
                       "profiles": profiles})


def _profile(res) -> dict:
    return {"r_mm": res.r_mm, "pressure_mpa": res.pressure_mpa, "contact_radius_mm": res.contact_radius_mm,
            "hertz_radius_mm": res.hertz_radius_mm}


def _parallel(tasks: dict, workers: int | None, on_done) -> None:
    """Run ``{key: (function, args)}`` on spawned processes with one BLAS thread each; ``on_done(key, result, k)``
    as each finishes (in the parent, so that finished work is written at once)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from filmcal.campaign.pool import limit_native_threads

    n = max(1, min(len(tasks), workers or os.cpu_count() or 1))
    with ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("spawn"),
                             initializer=limit_native_threads) as pool:
        futures = {pool.submit(fn, *args): key for key, (fn, args) in tasks.items()}
        for k, future in enumerate(as_completed(futures), 1):
            on_done(futures[future], future.result(), k)


def _curves_stage(study: Path, settings: PipelineSettings, results: dict, workers: int | None, log) -> None:
    """Curves of the films without a CSV yet: one task per (film, wheel)."""
    from filmcal.correction import curve_rows, wheel_label, write_curves_csv

    wheels = [None] + ([settings.rough_ra_um] if settings.rough_ra_um else [])
    todo = [film for film in results if not (study / f"curves-{film}.csv").exists()]
    tasks = {(film, ra): (curve_rows, (film, np.asarray(results[film][0].samples["modulus_mpa"], dtype=float),
                                       settings.offsets_mm, settings.forces_kn, ra, FILM_POISSON, FILM_THICKNESS_MM))
             for film in todo for ra in wheels}
    if not tasks:
        return
    log(f"[curves] {len(todo)} film(s) x {len(wheels)} wheel(s), {len(settings.forces_kn)} loads x "
        f"{len(settings.offsets_mm)} offsets each")
    rows: dict = {}

    def done(key, result, k):
        film, ra = key
        rows[key] = result
        log(f"[curves] {film}, {wheel_label(ra)} wheel done ({k}/{len(tasks)})")
        if all((film, w) in rows for w in wheels):  # a film's CSV as soon as its wheels are done
            write_curves_csv(study / f"curves-{film}.csv", [r for w in wheels for r in rows[film, w]])

    _parallel(tasks, workers, done)


@functools.lru_cache(maxsize=2)
def _study_radius_model(study: str):
    """The study's radius surrogate as a calibration model, loaded once per process."""
    from filmcal.fem import ContactOptions
    from filmcal.study import SurrogateDomain, SurrogateRadiusModel, surrogate_path
    from filmcal.surrogate import load_surrogate

    return SurrogateRadiusModel(load_surrogate(surrogate_path(study, ContactOptions())), SurrogateDomain())


def _crossval_fold(study: str, film: str, case: int, seed: int) -> dict:
    from filmcal.calibration import Priors
    from filmcal.correction.crossval import cross_validate_case
    from filmcal.study import SurrogateDomain

    priors = Priors(modulus_range_mpa=SurrogateDomain().modulus_mpa)
    return cross_validate_case(_study_radius_model(study), film, case, priors=priors, seed=seed)


def _crossval_stage(study: Path, settings: PipelineSettings, films, seed: int, workers: int | None, log) -> None:
    """Leave-one-case-out cross-validation on Table 1 (``crossval-<film>.json``): one task per fold."""
    from filmcal.calibration import load_table1
    from filmcal.correction.crossval import CaseCrossValidation

    todo = [f for f in films if f in settings.crossval_films and not (study / f"crossval-{f}.json").exists()]
    n_cases = {film: len(load_table1(film)) for film in todo}
    tasks = {(film, case): (_crossval_fold, (str(study), film, case, seed))
             for film in todo for case in range(n_cases[film])}
    if not tasks:
        return
    log(f"[crossval] leave-one-case-out on Table 1: {len(tasks)} calibrations ({', '.join(todo)})")
    folds: dict = {}

    def done(key, result, k):
        film = key[0]
        folds[key] = result
        if all((film, c) in folds for c in range(n_cases[film])):
            cv = CaseCrossValidation.from_folds(film, [folds[film, c] for c in range(n_cases[film])])
            _write_json(study / f"crossval-{film}.json", cv.to_dict())
            log(f"[crossval] {film}: Hertz area inside the corrected 90 % interval in {cv.hits}/{n_cases[film]} "
                f"cases ({k}/{len(tasks)} calibrations done)")

    _parallel(tasks, workers, done)


def _outlines_stage(study: Path, settings: PipelineSettings, medians: dict, log) -> None:
    path = study / "wheelrail-outlines.json"
    if path.exists() and set(json.loads(path.read_text())["films"]) >= set(medians):
        return
    from filmcal.wheelrail import FilmLayer, solve_wheel_rail

    force = settings.outline_force_kn * 1e3
    log(f"[outlines] wheel-rail contact outlines at {settings.outline_force_kn:g} kN")
    cases = []
    for eta in settings.offsets_mm:
        bare = solve_wheel_rail(eta, force)
        case = {"offset_mm": eta, "contact_y_mm": bare.placement.contact.y_mm,
                "no film": {"area_mm2": bare.area_mm2, "outline_mm": bare.outline_mm}}
        for film, e in medians.items():
            res = solve_wheel_rail(eta, force, film=FilmLayer(e, FILM_POISSON, FILM_THICKNESS_MM))
            case[film] = {"area_mm2": res.area_mm2, "outline_mm": res.outline_mm}
        cases.append(case)
    _write_json(path, {"force_n": force, "films": medians, "cases": cases})


def _report_stage(study: Path, log) -> dict:
    from filmcal.report import write_report

    out = study / "report"
    html = out / "report.html"
    inputs = [p for p in study.iterdir() if p.is_file() and p.suffix in (".json", ".csv", ".npz")
              and p.name != "summary.json"]
    if html.exists() and (out / "report.pdf").exists() and all(
            os.path.getmtime(p) <= os.path.getmtime(html) for p in inputs):
        return {"html": str(html), "pdf": str(out / "report.pdf")}
    log("[report] HTML and PDF")
    paths = write_report(study, out)
    return {"html": str(paths["html"]), "pdf": str(paths["pdf"]), "figures": paths["figures"]}
