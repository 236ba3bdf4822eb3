"""The whole job as declared stages of a `Study`.

Each stage reads and writes through the study (its layout and manifest); a
stage whose outputs are recorded with the same spec is skipped, so an
interrupted run loses no finished work and a second run only reads:

``design``        quality of the optimal Latin hypercubes (``design.json``)
``calibration``   FE campaign -> validated radius surrogates -> posterior of
                  each film under each imprint model and film kinematics
``comparison``    the models of each film compared by PSIS-LOO and stacked
                  (``comparison-<film>.json``)
``verification``  FE against Hertz without film and FE against the surrogate at
                  the posterior medians (``fe-verification.json``)
``curves``        wheel-rail correction curves with 90 % bands, smooth and rough
                  wheel (``curves/curves-<film>.csv``)
``outlines``      wheel-rail contact outlines with and without film
``crossval``      leave-one-case-out cross-validation of the sphere-on-flat correction
``report``        HTML and PDF report (``report/``)
"""
from __future__ import annotations

import time
import warnings
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from filmcal._errors import InputError
from filmcal._io import atomic_write_json, read_json
from filmcal.films import FILM_TYPES
from filmcal.surrogate.radius import MODULI_PER_CASE, check_moduli_per_case
from filmcal.study.core import (IMPRINT_MODELS, KINEMATICS, CalibrationSpec, FESettings, Study, as_recorded,
                                refit_without_case, seed_for)

__all__ = ["PipelineSettings", "run_pipeline", "STAGES"]

#: Sphere and force of the pressure profiles shown in the report (the DESIGN's Hertz example).
PROFILE_CASE = (450.0, 75_000.0)
STAGES = ("design", "calibration", "comparison", "verification", "curves", "outlines", "crossval", "report")


@dataclass(frozen=True)
class PipelineSettings:
    """Sizes and model choices of the pipeline's stages (`quick` is a small version for tests).

    Attributes
    ----------
    train_runs, test_runs : int
        FE runs of the surrogate's training design and of its held-out design.
    moduli_per_case : int
        FE runs added to the training design at each of the dataset's (R, F) cases, along ln E
        (`FESettings.moduli_per_case`; 0: none, as the quick and smoke sizes).
    imprint_models : tuple of str
        What the film records, each calibrated and compared (`filmcal.contact.imprint`).
    kinematics : tuple of str
        Film kinematics of the FE model, each calibrated and compared.
    offsets_mm, forces_kn : tuple of float
        Grid of the wheel-rail correction curves.
    rough_ra_um : float or None
        Roughness Ra of the rough-wheel curves (None: smooth wheel only).
    rough_draws : int
        Draws of the roughness inputs (the first of the shipped conditioned set) that the rough curves' bands
        take.
    outline_force_kn : float
        Load of the contact outlines (the paper's Fig. 7 uses 50 kN).
    crossval_films : tuple of str or None
        Film types cross-validated leave-one-case-out (None: every film).
    max_steps : int or None
        Cap of the MCMC steps per walker (None: until converged).
    simulator : filmcal.campaign.simulator.Simulator, optional
        A lab's own simulator in place of the in-house FE for the calibration's runs. The wheel-rail stages
        still apply filmcal's own film model at the calibrated modulus (and its transfer term, fitted to
        filmcal's FE): valid where the lab's model and filmcal's agree.
    """

    train_runs: int = 200
    test_runs: int = 100
    moduli_per_case: int = MODULI_PER_CASE
    imprint_models: tuple[str, ...] = IMPRINT_MODELS
    kinematics: tuple[str, ...] = ("small", "large")
    offsets_mm: tuple[float, ...] = tuple(float(x) for x in np.arange(-7.0, 2.01, 1.0))
    forces_kn: tuple[float, ...] = (50.0, 100.0)
    rough_ra_um: float | None = 1.5
    rough_draws: int = 8
    outline_force_kn: float = 50.0
    crossval_films: tuple[str, ...] | None = None
    max_steps: int | None = None
    simulator: Any = None

    def __post_init__(self) -> None:
        for m in self.imprint_models:
            if m not in IMPRINT_MODELS:
                raise InputError(f"imprint model must be one of {', '.join(IMPRINT_MODELS)}, got {m!r}")
        for k in self.kinematics:
            if k not in KINEMATICS:
                raise InputError(f"kinematics must be one of {', '.join(KINEMATICS)}, got {k!r}")
        if not self.imprint_models or not self.kinematics:
            raise InputError("at least one imprint model and one film kinematics are needed")
        for name, values in (("imprint model", self.imprint_models), ("kinematics", self.kinematics)):
            twice = sorted({v for v in values if list(values).count(v) > 1})
            if twice:
                raise InputError(f"{name} {', '.join(twice)} is given more than once")
        if isinstance(self.rough_draws, bool) or not isinstance(self.rough_draws, int) or self.rough_draws < 1:
            raise InputError(f"rough_draws must be an integer >= 1, got {self.rough_draws!r}")
        check_moduli_per_case(self.moduli_per_case)

    @classmethod
    def quick(cls) -> "PipelineSettings":
        """Few FE runs, two imprint models, three offsets at 50 kN, short chains: a minute or two."""
        return cls(train_runs=40, test_runs=12, moduli_per_case=0, imprint_models=("edge", "activation"),
                   kinematics=("small",), offsets_mm=(-6.0, -3.0, 0.0), forces_kn=(50.0,), rough_draws=2,
                   crossval_films=("HS",), max_steps=10000)

    @classmethod
    def smoke(cls) -> "PipelineSettings":
        """The whole path at its smallest size (20+5 FE runs, one offset, short chains, no cross-validation):
        a check that an installation runs the job, about 20 s; its numbers are not a calibration."""
        return cls(train_runs=20, test_runs=5, moduli_per_case=0, imprint_models=("edge", "activation"),
                   kinematics=("small",), offsets_mm=(0.0,), forces_kn=(50.0,), rough_ra_um=None, crossval_films=(),
                   max_steps=400)

    def fe(self, kinematics: str, seed: int) -> FESettings:
        return FESettings(kinematics=kinematics, n_train=self.train_runs, n_test=self.test_runs, seed=seed,
                          moduli_per_case=self.moduli_per_case, simulator=self.simulator)

    def record(self) -> dict:
        """The settings as the study records them (a lab's simulator by its spec; none: as before)."""
        # the rough curves' draws are in their own spec (a change recomputes them): not a setting of the folder
        # none at the dataset's cases: recorded as before they existed, so that such studies go on
        out = {k: v for k, v in asdict(self).items() if k not in ("simulator", "rough_draws")
               and not (k == "moduli_per_case" and v == 0)}
        if self.simulator is not None:
            out["simulator"] = self.simulator.spec()
        return out

    def specs(self, film: str, imprint_models, seed: int) -> list[CalibrationSpec]:
        return [CalibrationSpec(film, imprint=m, fe=self.fe(k, seed), max_steps=self.max_steps)
                for k in self.kinematics for m in imprint_models]


def _models_for(study: Study, film: str, settings: PipelineSettings) -> tuple[str, ...]:
    from filmcal.contact.imprint import imprint_models_for

    allowed = imprint_models_for(study.film(film))
    return tuple(m for m in settings.imprint_models if m in allowed)


def run_pipeline(study_dir, settings: PipelineSettings | None = None, films=FILM_TYPES, seed: int = 0,
                 workers: int | None = None, progress=None, report=None, films_file=None, dataset=None,
                 dask: str | None = None, run_store=None) -> dict:
    """Run (or resume) the pipeline in a study folder; return the summary also written to ``summary.json``.

    Parameters
    ----------
    study_dir : str or Path
        The study folder (created if missing).
    settings : PipelineSettings, optional
        Stage sizes and model choices (default: the full study).
    films : sequence of str
        Film types to calibrate and propagate (added to those of earlier runs).
    seed : int
        The study's seed; every stage draws from its own stream of it.
    workers : int, optional
        Worker processes, shared by every stage (default: all cores; 1: everything in this process).
    dask : str, optional
        A Dask scheduler's address: every stage's parallel work (FE or simulator runs, fits, calibrations,
        roughness laws and curve solves) runs on that cluster instead (`workers` is then unused).
    progress : filmcal._progress.Progress, optional
        The run's progress display (default: ``auto``, on stderr).
    report : callable, optional
        ``report(study_dir, out_dir, workers=) -> {"html", "pdf", ...}``: writes the report
        at the end (`filmcal.report.write_report`; the study stages do not import
        the report, which reads studies); None: no report.
    films_file : str or Path, optional
        TOML file of user film types.
    dataset : str or Path, optional
        The calibration data: a CSV file of the documented format
        (`filmcal.calibration.load_dataset`) or a packaged dataset's name;
        default the study's dataset, Table 1 for a new study.
    run_store : str or Path, optional
        A folder of FE run stores shared with other studies (`Study`): runs of
        the same settings made there are reused, not run again.
    """
    from filmcal._parallel import keep_freed_memory, parallel_work
    from filmcal._progress import Progress

    settings = settings or PipelineSettings()
    progress = progress or Progress()
    keep_freed_memory()  # the stages that run in this process allocate as the workers do
    if seed < 0 or seed >= 2**32:
        raise InputError(f"seed must be in 0..{2**32 - 1}, got {seed}")
    # one pool for every stage, started by the first task (a rerun with nothing to do starts none), or the Dask
    # cluster, whose scheduler is reached before anything is written
    with parallel_work(workers, dask, shared=True) as pool:
        study = Study(study_dir, create=True, films_file=films_file, run_store=run_store)
        for f in films:
            study.film(f)  # unknown films, and data too few to calibrate or compare, are refused before any work
            study.dataset_rows(f, None, dataset, compared=len(_models_for(study, f, settings)) > 1)
        return _run_stages(study, settings, films, seed, pool, progress, report, dataset)


def _kept_design(study: Study, settings: PipelineSettings) -> PipelineSettings:
    """`settings`, or with no runs at the data's cases when the study was made before they existed (its record
    has no ``moduli_per_case``) with otherwise the same settings: such a study goes on with its own design and
    posteriors, said in one line; a new ``--study-dir`` gets the cases' runs."""
    recorded = (study.manifest.data.get("settings") or {}).get("pipeline")
    if recorded is None or "moduli_per_case" in recorded or settings.moduli_per_case == 0:
        return settings
    kept = replace(settings, moduli_per_case=0)
    if as_recorded(kept.record()) == recorded:
        warnings.warn(DesignKeptNote(
            f"study {study.root} was made before the surrogates' runs at the data's cases: it goes on with its own "
            "design and posteriors (a new --study-dir gets those runs)"), stacklevel=2)
        return kept
    return settings


class DesignKeptNote(UserWarning):
    """A study made before the runs at the data's cases goes on with its own design."""


def _run_stages(study: Study, settings: PipelineSettings, films, seed: int, pool, progress, report,
                dataset) -> dict:
    """The pipeline's stages in an opened study, every stage's parallel work on `pool`; the summary."""
    with study.writing("filmcal pipeline"):
        settings = _kept_design(study, settings)
        study.set_settings({"pipeline": settings.record(), "seed": seed})
        known = list(study.manifest.data.get("pipeline_films", []))
        kept = [f for f in known if f not in films]
        films = known + [f for f in films if f not in known]
        study.manifest.data["pipeline_films"] = films
        if kept:  # a study answers for every film it holds: its report and summary cover them all
            progress.log(f"the study also holds {', '.join(kept)} from earlier runs: kept in its summary and report "
                         "(read, not computed again); a study of other films alone needs another --study-dir")
        t0 = time.perf_counter()
        summary: dict = {"study_dir": str(study.root), "films": {}, "stages_s": {}}

        n_specs = sum(len(settings.specs(f, _models_for(study, f, settings), seed)) for f in films)
        progress.plan(planned_seconds(settings, len(films), n_specs, report is not None))

        def stage(name: str, fn, *args):
            t = time.perf_counter()
            with progress.stage(name) as st, warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                out, computed = fn(*args, st)
                _summarise_warnings(st, name, caught)
                if not computed:
                    progress.unplan(name)
            elapsed = time.perf_counter() - t
            summary["stages_s"][name] = elapsed
            if computed:
                study.stage_done(name, elapsed)
            return out

        stage("design", _design_stage, study, settings, seed)
        results = stage("calibration", _calibration_stage, study, settings, films, seed, pool, dataset)
        comparisons = stage("comparison", _comparison_stage, study, settings, results, seed, pool)
        chosen = {film: _preferred(results[film], comparisons.get(film)) for film in films}
        # the film each figure draws is the one its posterior was calibrated under: its E and kinematics
        medians = {film: {"modulus_mpa": float(r.modulus_mpa["median"]), "model": spec["model"],
                          "kinematics": spec["fe"]["kinematics"]} for film, (r, _, spec) in chosen.items()}
        stage("roughness", _roughness_stage, study, films, medians, seed, pool)
        stage("verification", _verification_stage, study, settings, seed, medians, pool)
        stage("curves", _curves_stage, study, settings, films, pool)
        stage("outlines", _outlines_stage, study, settings, medians)
        stage("crossval", _crossval_stage, study, settings, results, comparisons, seed, pool)
        if report is not None:
            summary["report"] = stage("report", _report_stage, study, report, pool)
        for film in films:
            result, path, spec = chosen[film]
            d = result.to_dict()
            s = {k: d[k] for k in ("modulus_mpa", "oedometric_modulus_mpa", "sigma_mm", "rhat", "ess", "n_data")}
            s.update(model=spec["model"], diagnostics_ok=bool(result.diagnostics_ok),
                     diagnostics_messages=list(result.diagnostics.messages),
                     posterior_file=study.layout.relative(path), predictive_hits=int(np.sum(~result.predictive.outside)),
                     n_cases=int(len(result.predictive.outside)),
                     modulus_mcse_mpa=dict(result.mcse.get("modulus_mpa", {})))
            weights = (comparisons.get(film) or {}).get("weights")
            if weights:
                # the answer to cite is the weighted mixture of the compared models, as `filmcal calibrate` gives
                # it; the preferred model's own summary stays under preferred_model
                from filmcal.calibration import combine_posteriors
                from filmcal.calibration.posterior import summarize

                models = results[film]
                s["preferred_model"] = {"model": spec["model"], "modulus_mpa": d["modulus_mpa"],
                                        "modulus_mcse_mpa": s.pop("modulus_mcse_mpa")}
                mixture = combine_posteriors({k: r.samples for k, (r, _, _) in models.items() if k in weights},
                                             {k: w for k, w in weights.items() if k in models},
                                             random_state=seed_for(seed, f"mixture-{film}"))
                s.update(model="mixture", imprint_weights=weights,
                         modulus_mpa=summarize(mixture.samples["modulus_mpa"]),
                         oedometric_modulus_mpa=summarize(mixture.samples["oedometric_modulus_mpa"]))
            summary["films"][film] = s
        summary["stage_timings_of_computing_runs"] = study.manifest.data["stages"]
        summary["elapsed_s"] = time.perf_counter() - t0
        atomic_write_json(study.layout.summary, summary, indent=1)
    return summary


#: Cost model of the pipeline's stages on a 2-core machine (s per unit), from the full and the quick run of
#: 26 Nov 2026 (docs/pipeline.md): the progress display's plan, corrected by the run's own speed as it goes.
STAGE_COSTS_S = {"design_per_run": 0.02, "fe_run": 0.25, "gp_fit_per_run2": 5e-4, "chain": 2.7,
                 "comparison_per_model": 2.1,
                 "curve": 2.0, "curve_per_offset": 1.4, "outline_per_offset": 0.4, "crossval_per_model": 1.5,
                 "report": 4.0, "report_per_model": 1.0, "verification": 1.0}


def _calibration_costs(settings: PipelineSettings, n_specs: int) -> tuple[float, float, float]:
    """Planned cost of the calibration stage (s), and the shares of its FE runs and its surrogate fits."""
    c = STAGE_COSTS_S
    # the runs at the data's cases: Table 1's ten cases, at most train_runs (a dataset's own are not known here)
    cases = min(10 * settings.moduli_per_case, settings.train_runs)
    fe = c["fe_run"] * (settings.train_runs + cases + settings.test_runs) * len(settings.kinematics)
    fits = c["gp_fit_per_run2"] * (settings.train_runs + cases) ** 2 * len(settings.kinematics)
    total = fe + fits + c["chain"] * n_specs
    return total, fe / total, fits / total


def planned_seconds(settings: PipelineSettings, n_films: int, n_specs: int, report: bool = True) -> dict:
    """Expected cost of each stage (s) from the settings and `STAGE_COSTS_S`: the progress display's plan."""
    c = STAGE_COSTS_S
    runs = settings.train_runs + settings.test_runs
    curves = n_films * (1 + (settings.rough_draws if settings.rough_ra_um else 0)) * len(settings.forces_kn)
    plan = {"design": c["design_per_run"] * runs,
            "calibration": _calibration_costs(settings, n_specs)[0],
            "comparison": c["comparison_per_model"] * n_specs, "verification": c["verification"],
            "curves": curves * (c["curve"] + c["curve_per_offset"] * len(settings.offsets_mm)),
            "outlines": c["outline_per_offset"] * len(settings.offsets_mm),
            "crossval": c["crossval_per_model"] * n_specs}
    if report:
        plan["report"] = c["report"] + c["report_per_model"] * n_specs
    return plan


def _summarise_warnings(st, name: str, caught: list) -> None:
    """A stage's own notes (a missing artefact made again, a design extended) one line each, then the
    libraries' warnings as one line (numerical notes, e.g. a GP restart that did not converge)."""
    from filmcal.study.core import DomainNote, RebuiltNote

    for w in caught:
        if isinstance(w.message, (RebuiltNote, DomainNote)):
            st.log(f"[{name}] note: {w.message}")
    caught = [w for w in caught if not isinstance(w.message, (RebuiltNote, DomainNote))]
    if not caught:
        return
    kinds = sorted({type(w.message).__name__ if isinstance(w.message, Warning) else w.category.__name__
                    for w in caught})
    first = str(caught[0].message).splitlines()[0][:160]
    st.log(f"[{name}] {len(caught)} library warning(s) ({', '.join(kinds)}), first: {first}")


def _preferred(models: dict, comparison: dict | None):
    """The film's posterior quoted alone (verification, outlines): the comparison's preferred model, or the first."""
    best = (comparison or {}).get("preferred")
    return models[best] if best in models else next(iter(models.values()))


# ------------------------------------------------------------------ stages
def _design_stage(study: Study, settings: PipelineSettings, seed: int, st):
    path = study.layout.design
    if study.verified(path):
        return None, False
    from scipy.stats import qmc

    from filmcal.doe import design_quality, latin_design
    from filmcal.surrogate.radius import SurrogateDomain

    st.log("[design] optimal Latin hypercubes and their quality")
    st.set_total(2)
    space = SurrogateDomain().space()
    out = {"names": list(space.names)}
    for name, n in (("train", settings.train_runs), ("test", settings.test_runs)):
        s = seed_for(seed, f"design-{name}")
        design = latin_design(space, n, seed=s)
        rng = np.random.default_rng(seed_for(seed, f"design-{name}-reference"))
        ref = [design_quality(space.to_unit(space.to_physical(qmc.LatinHypercube(d=space.d, seed=rng).random(n))))
               .as_dict() for _ in range(10)]
        out[name] = {"n": n, "seed": s, "quality": design.quality.as_dict(), "unit": design.unit,
                     "physical": design.points, "random_lhs_median": {k: float(np.median([r[k] for r in ref]))
                                                                      for k in ref[0] if k != "latin"}}
        st.advance(note=f"{name} design")
    atomic_write_json(path, out, indent=None)
    study.record(path, "design", {"train_runs": settings.train_runs, "test_runs": settings.test_runs, "seed": seed})
    return None, True


def _calibration_stage(study: Study, settings: PipelineSettings, films, seed: int, workers, dataset, st):
    """Every film under every model: FE campaigns, then the surrogates and the chains in parallel."""
    specs = [spec for film in films for spec in settings.specs(film, _models_for(study, film, settings), seed)]
    before = len(study.manifest.artefacts("posterior"))
    st.set_total(len(specs))
    _, fe_share, fit_share = _calibration_costs(settings, len(specs))

    def fe_progress(done, total, what="FE run"):  # the FE runs come first, then the fits, then the chains
        start, share = (0.0, fe_share) if what == "FE run" else (fe_share, fit_share)
        st.update(start + share * done / max(total, 1), note=f"{what} {done}/{total}")

    def finished(spec, result):
        st.log(f"[calibration] {spec.film} {spec.model_label}: E = {result.modulus_mpa['median']:.0f} MPa "
               f"[{result.modulus_mpa['ci90'][0]:.0f}, {result.modulus_mpa['ci90'][1]:.0f}]")
        st.advance(note=f"{spec.film} {spec.model_label}",
                   fraction=fe_share + fit_share + (1 - fe_share - fit_share) * (st.done + 1) / len(specs))

    done = study.calibrate_many(specs, dataset=dataset, workers=workers, progress=fe_progress, on_done=finished)
    results: dict = {}
    for spec, outcome in zip(specs, done):
        results.setdefault(spec.film, {})[spec.model_label] = outcome
    return results, len(study.manifest.artefacts("posterior")) > before


def _comparison_stage(study: Study, settings: PipelineSettings, results: dict, seed: int, workers, st):
    """Compare each film's models by leave-one-case-out accuracy, exact where PSIS is not, and weigh them by
    pseudo-BMA+ (``comparison-<film>.json``)."""
    out, computed = {}, False
    compared = [film for film, models in results.items() if len(models) >= 2]
    st.set_total(len(compared))
    for k, film in enumerate(compared):
        models = results[film]
        d, now = study.compare(film, models, workers=workers, max_steps=settings.max_steps, seed=seed,
                               progress=lambda done, total, k=k, film=film: st.update(
                                   (k + done / total) / len(compared), note=f"{film}: exact refit {done}/{total}"))
        computed |= now
        out[film] = d
        if now:  # a resumed run that finds the comparison says nothing
            st.log(f"[comparison] {film}: weights " + ", ".join(f"{m} {w:.2f}" for m, w in d["weights"].items()))
            st.advance(note=film, fraction=(k + 1) / len(compared))
    return out, computed


def _fe_solve(sphere_radius_mm: float, force_n: float, film: tuple[float, float] | None, options) -> dict:
    """One FE solve of the verification: the sphere on the flat, bare (`film` None) or with film ``(E, nu)``."""
    from filmcal.fem import Film, get_model

    res = get_model(sphere_radius_mm).solve(None if film is None else Film(*film), force_n, options)
    return {"fe_radius_mm": res.contact_radius_mm, "hertz_radius_mm": res.hertz_radius_mm,
            "fe_max_pressure_mpa": res.max_pressure_mpa, "converged": res.converged, "profile": _profile(res)}


#: Effective draws below which a study's re-conditioned roughness inputs come with a warning.
MIN_EFFECTIVE_DRAWS = 4.0


class RoughnessConditioningWarning(UserWarning):
    """A study's roughened-flat data leave few of the shipped draws of the roughness inputs."""


def _roughness_stage(study: Study, films, medians: dict, seed: int, workers, st):
    """The study's own roughened-flat data condition the shipped roughness inputs again
    (``roughness-inputs.json``, kind ``roughness-inputs``; `filmcal.calibration.roughness.reweighted_inputs`).

    Each rough case of a film that the dataset also measured on a smooth flat is an observation of the
    imprint's growth (`dataset_rough_flat_observations`); each shipped draw predicts it on sphere-on-flat
    with the flat roughened, the film at its posterior median under its preferred model. Nothing to do when
    the dataset has no such pairs."""
    from dataclasses import asdict

    from filmcal._parallel import run_tasks
    from filmcal.calibration.roughness import dataset_rough_flat_observations, reweighted_inputs
    from filmcal.contact.rough_imprint import load_roughness_inputs

    observations = [o for film in films for o in dataset_rough_flat_observations(study.dataset_rows(film, None)[0],
                                                                                   film)]
    if not observations:
        return None, False
    draws = load_roughness_inputs()
    used = {o.film: medians[o.film] for o in observations}
    spec = {"observations": [asdict(o) for o in observations], "films": used, "seed": seed,
            "draws": [d.to_dict() for d in draws]}
    path = study.layout.roughness_inputs
    if _current(study, path, spec):
        return None, False
    unique = list(dict.fromkeys(draws))
    models = [(_film_model(study, o.film, used[o.film]), used[o.film]["modulus_mpa"]) for o in observations]
    tasks = {k: (_sphere_growths, (models, d, observations)) for k, d in enumerate(unique)}
    st.set_total(len(tasks))
    st.log(f"[roughness] the dataset's {len(observations)} roughened-flat observation(s) condition the roughness "
           f"inputs again: {len(unique)} distinct draws")
    solved: dict = {}

    def keep(k, growths, _):
        solved[unique[k]] = growths
        st.advance(note=f"draw {k + 1}/{len(unique)}")

    run_tasks(tasks, workers, keep)
    growths = {j: np.array([solved[d][j] - 1.0 for d in draws]) for j in range(len(observations))}
    out = reweighted_inputs(draws, growths, observations, random_state=seed)
    st.log(f"[roughness] {out['effective_draws']:.1f} effective draws of {len(draws)} remain")
    if out["effective_draws"] < MIN_EFFECTIVE_DRAWS:
        warnings.warn(RoughnessConditioningWarning(
            f"the dataset's roughened-flat growths rest on {out['effective_draws']:.1f} effective draws of the "
            f"{len(draws)} shipped ones (predicted {100 * min(g.min() for g in growths.values()):.1f} to "
            f"{100 * max(g.max() for g in growths.values()):.1f} %, observed "
            + ", ".join(f"{100 * o.growth:+.1f} %" for o in observations)
            + "): the roughness bands of this study's corrections are narrower than the inputs' uncertainty; "
            "more roughened-flat imprints would tell the draws apart"), stacklevel=2)
    atomic_write_json(path, {"source": "the shipped conditioned draws, weighted by this study's roughened-flat data",
                             "observations": spec["observations"], "films": used,
                             "predicted_growth": {str(j): g.tolist() for j, g in growths.items()},
                             "weights": out["weights"], "effective_draws": out["effective_draws"],
                             "conditioned": [d.to_dict() for d in out["conditioned"]]}, indent=1)
    study.record(path, "roughness-inputs", spec)
    return None, True


def _film_model(study: Study, film: str, median: dict):
    from filmcal.contact.film import FilmModel

    return FilmModel(study.film(film), median["model"].split("/")[0], median["kinematics"])


def _sphere_growths(models: list, draw, observations: list) -> list[float]:
    """``g_f`` of one draw at each roughened-flat observation, each with its ``(FilmModel, modulus)`` (a worker's
    task: the draw's law against a film is built once for all of its observations)."""
    from filmcal.wheelrail.rough_growth import sphere_growth

    return [sphere_growth(model, modulus, draw, o.ra_um, sphere_radius_mm=o.sphere_radius_mm,
                          force_n=1e3 * o.force_kn) for (model, modulus), o in zip(models, observations)]


def _verification_stage(study: Study, settings: PipelineSettings, seed: int, medians: dict, workers, st):
    path = study.layout.verification
    if _current(study, path, {"films": medians}):
        return None, False
    from filmcal._parallel import run_tasks
    from filmcal.calibration import load_table1

    st.log("[verification] FE without film against Hertz; FE against the surrogate at the posterior medians")
    data = load_table1("HS")  # the ten (R, F) cases of Table 1
    cases = [(float(r), float(f)) for r, f in zip(data.sphere_radius_mm, data.force_n)]
    films = {film: (m["modulus_mpa"], study.film(film).poisson) for film, m in medians.items()}
    options = {film: settings.fe(m["kinematics"], seed).contact_options() for film, m in medians.items()}
    tasks = {(None, r, f): (_fe_solve, (r, f, None, None)) for r, f in [*cases, PROFILE_CASE]}
    tasks.update({(film, r, f): (_fe_solve, (r, f, films[film], options[film]))
                  for film in films for r, f in [*cases, PROFILE_CASE]})
    st.set_total(len(tasks))
    solved: dict = {}

    def keep(key, out, k):
        solved[key] = out
        film, r, f = key
        st.advance(note=f"{film or 'no film'}, R{r:.0f}/{f / 1e3:.0f} kN")

    run_tasks(tasks, workers, keep)
    hertz = [{"sphere_radius_mm": r, "force_n": f, **{k: v for k, v in solved[None, r, f].items() if k != "profile"}}
             for r, f in cases]
    out_films = {}
    for film, (e, nu) in films.items():
        kinematics = medians[film]["kinematics"]
        fe = study.as_calibrated(CalibrationSpec(film, fe=settings.fe(kinematics, seed))).fe
        model, _, _ = study.radius_model(fe, "contact_radius_mm", progress=False)
        rows = []
        for r, f in cases:
            mean, std = model.predict(e, nu, r, f)
            res = solved[film, r, f]
            rows.append({"sphere_radius_mm": r, "force_n": f, "fe_radius_mm": res["fe_radius_mm"],
                         "surrogate_mean_mm": float(mean), "surrogate_std_mm": float(std),
                         "converged": res["converged"]})
        out_films[film] = {"modulus_mpa": e, "kinematics": kinematics, "model": medians[film]["model"], "cases": rows}
    r, f = PROFILE_CASE
    profiles = {"no film": solved[None, r, f]["profile"]}
    profiles.update({f"{film} film ({medians[film]['model']}), E = {e:.0f} MPa": solved[film, r, f]["profile"]
                     for film, (e, _) in films.items()})
    atomic_write_json(path, {"hertz": hertz, "films": out_films, "profile_case": {"sphere_radius_mm": r, "force_n": f},
                             "profiles": profiles}, indent=None)
    study.record(path, "verification", {"films": medians})
    return None, True


def _profile(res) -> dict:
    return {"r_mm": res.r_mm, "pressure_mpa": res.pressure_profile_mpa, "contact_radius_mm": res.contact_radius_mm,
            "hertz_radius_mm": res.hertz_radius_mm}


def curve_spec(study: Study, film: str, settings: PipelineSettings, rough=None) -> dict:
    """Everything that sets a film's curves: its chosen posteriors and their weights, the grid of loads and
    offsets, the rough wheel's inputs (`rough`, a `RoughConfiguration`) and the shipped transfer term of each
    chosen model (its digest: curves made with another fit are made again), and the application model's
    revision (`filmcal.contact.names.APPLICATION_MODEL_REVISION`)."""
    from filmcal.contact import names
    from filmcal.contact.transfer import load_transfer_fit
    from filmcal.study.core import chosen_posteriors

    chosen = chosen_posteriors(study, film)
    transfer = load_transfer_fit()
    spec = {"posteriors": sorted(p.name for _, p, _ in chosen),
            "weights": {s["model"]: w for w, _, s in chosen}, "offsets_mm": list(settings.offsets_mm),
            "forces_kn": list(settings.forces_kn), "rough_ra_um": settings.rough_ra_um,
            "transfer": {s["model"]: transfer.digest(s["model"]) for _, _, s in chosen},
            "application_model_revision": names.APPLICATION_MODEL_REVISION}
    if rough is not None:  # the rough bodies' inputs (their spectra, hardnesses and reading levels)
        spec["rough_draws"] = [d.to_dict() for d in rough.draws]
    return spec


def _curves_stage(study: Study, settings: PipelineSettings, films, workers, st):
    """Curves of each film's combined models, smooth and on the rough wheel (``curves/curves-<film>.csv``).

    The rough wheel's growths come first: its laws (`_rough_laws`, each a study artefact), then one task per
    load and offset solving every missing film's growths there for every draw (``curves/part-<key>.json`` per
    film and cell, kind ``curves-growth``); then one task per film, load and offset (smooth and rough rows from the same
    posterior samples; a film's rows kept as ``curves/part-<key>.json`` as soon as they are all done). An
    interrupted run resumes with what is missing."""
    from filmcal._io import atomic_write_json
    from filmcal._parallel import run_tasks
    from filmcal.correction import RoughConfiguration, curve_rows, write_curves_csv
    from filmcal.correction.curves import transfer_note
    from filmcal.correction.roughness import growth_modulus_mpa
    from filmcal.study.core import curve_components
    from filmcal.study.layout import spec_key

    rough = None
    if settings.rough_ra_um:
        rough = RoughConfiguration(float(settings.rough_ra_um), None,
                                   tuple(study.roughness_inputs()[0][:settings.rough_draws]))
    specs, components, rows, earlier = {}, {}, {}, []
    for film in films:
        specs[film] = curve_spec(study, film, settings, rough)
        path = study.layout.curves(film)
        entry = study.manifest.entry(study.layout.relative(path)) if path.exists() else None
        if entry and entry["spec"] == specs[film] and study.verified(path):
            continue
        if entry and entry["spec"].get("application_model_revision") != specs[film]["application_model_revision"]:
            earlier.append(film)
        part = study.layout.curves_part(spec_key({**specs[film], "film": film}))
        if study.verified(part):
            rows[film] = read_json(part)["rows"]
        components[film] = curve_components(study, film)

    if earlier:
        st.log(f"[curves] {', '.join(earlier)}: the curves were made by an earlier revision of the wheel-rail model; "
               f"made again with revision {specs[earlier[0]]['application_model_revision']}")

    def finish(film: str) -> None:
        path = study.layout.curves(film)
        write_curves_csv(path, rows[film])
        study.record(path, "curves", specs[film])
        note = transfer_note(rows[film], components[film])
        if note:  # as `filmcal correct` and `filmcal curves` warn
            st.log(f"[curves] {film}: warning: {note}")

    for film in components:
        study.layout.curves(film).parent.mkdir(parents=True, exist_ok=True)
        if film in rows:
            finish(film)
    missing = [film for film in components if film not in rows]
    if not missing:
        return None, bool(components)
    points = [(force, eta) for force in settings.forces_kn for eta in settings.offsets_mm]
    growths: dict = {}
    if rough is not None:
        moduli = {film: growth_modulus_mpa(components[film]) for film in missing}
        models = [(film, model, moduli[film]) for film in missing for model, _, _ in components[film]]
        growths = _rough_growths(study, settings, rough, models, moduli, workers, st, len(missing) * len(points))
    else:
        st.set_total(len(missing) * len(points))
    # one task per film, load and offset (a few seconds each, so the display moves and the workers end together)
    tasks = {}
    for film in missing:
        for force, eta in points:
            cell = (1e3 * float(force), float(eta))
            wheels = [] if rough is None else [(rough.label, {cell: growths[film][cell]})]
            tasks[film, force, eta] = (curve_rows, (film, components[film], (eta,), (force,), wheels))
    st.log(f"[curves] {len(missing)} film(s), {len(settings.forces_kn)} loads x {len(settings.offsets_mm)} offsets "
           f"each, smooth{' and ' + rough.label if rough else ''}")
    by_point: dict = {}

    def done(key, result, k):
        film, force, eta = key
        by_point.setdefault(film, {})[force, eta] = result
        st.advance(note=f"{film}, {force:g} kN, eta {eta:+g} mm")
        if len(by_point[film]) < len(points):
            return
        n = 1 if rough is None else 2
        rows[film] = [r for w in range(n) for point in points for r in by_point[film][point][w::n]]
        part = study.layout.curves_part(spec_key({**specs[film], "film": film}))
        atomic_write_json(part, {"film": film, "rows": rows[film]}, indent=None)
        study.record(part, "curves-part", {**specs[film], "film": film})
        finish(film)

    run_tasks(tasks, workers, done)
    return None, True


def _rough_growths(study: Study, settings: PipelineSettings, rough, models: list, moduli: dict, workers, st,
                   cells: int) -> dict:
    """The rough wheel's growths of every film at every curve cell: ``{film: {(force_n, offset): {model label:
    RoughGrowth}}}``. First each distinct draw's laws (`_rough_laws`), then one task per load and offset
    solving there, for every draw, the growths of the films whose part of that cell is missing; each film's
    part is kept as soon as its cell is done (``curves/part-<key>.json``, kind ``curves-growth``, with the
    contact without film's growths), so that an interrupted run resumes with the missing ones only."""
    from filmcal._io import atomic_write_json
    from filmcal._parallel import run_tasks
    from filmcal.contact import names
    from filmcal.wheelrail.settings import FILM_MIN_CELLS_ACROSS
    from filmcal.contact.waviness import WAVINESS_CUTOFF_CELLS
    from filmcal.correction import curve_growths, growth_task
    from filmcal.study.layout import spec_key

    draws = rough.distinct()
    films = {film: (study.film(film), m) for film, m in moduli.items()}
    specs, solved = {}, {}
    for force in settings.forces_kn:
        for eta in settings.offsets_mm:
            cell = (1e3 * float(force), float(eta))
            for film, (film_type, m) in films.items():
                specs[film, cell] = {"film": film_type.to_dict(), "modulus_mpa": m,
                                     "models": [model.label for f, model, _ in models if f == film],
                                     "draws": [d.to_dict() for d in draws], "rough_ra_um": settings.rough_ra_um,
                                     "waviness_cutoff_cells": WAVINESS_CUTOFF_CELLS,
                                     "film_min_cells_across": FILM_MIN_CELLS_ACROSS, "force_kn": force,
                                     "offset_mm": eta, "application_model_revision": names.APPLICATION_MODEL_REVISION}
                part = study.layout.curves_part(spec_key(specs[film, cell]))
                if study.verified(part, kind="curves-growth", spec=specs[film, cell]):
                    solved[film, cell] = read_json(part)["growths"]
    todo = {}
    for film, cell in specs:
        if (film, cell) not in solved:
            todo.setdefault(cell, []).append(film)
    laws = _rough_laws(study, rough, films, draws if todo else [], workers, st, len(todo) + cells)
    tasks = {}
    for cell, missing in todo.items():
        mine = [entry for entry in models if entry[0] in missing]
        tasks[cell] = (growth_task, (mine, draws, _sent_laws(laws, missing), cell[1], cell[0], {}))
    if tasks:
        st.log(f"[curves] rough wheel ({rough.label}): growths of {len(draws)} distinct draws of the roughness "
               f"inputs at {len(tasks)} loads and offsets")

    def keep(cell, result, k):
        mine = [entry for entry in models if entry[0] in todo[cell]]
        for film in todo[cell]:
            cols = [j for j, entry in enumerate(mine) if entry[0] == film]
            growths = [[result[d][0], [result[d][1][j] for j in cols]] for d in draws]
            part = study.layout.curves_part(spec_key(specs[film, cell]))
            atomic_write_json(part, {"growths": growths}, indent=None)
            study.record(part, "curves-growth", specs[film, cell])
            solved[film, cell] = growths
        st.advance(note=f"rough growths, {cell[0] / 1e3:g} kN, eta {cell[1]:+g} mm")

    run_tasks(tasks, workers, keep)
    out = {}
    for film in moduli:
        mine = [(k, entry) for k, entry in enumerate(entry for entry in models if entry[0] == film)]
        by_cell = {cell: dict(zip(draws, (tuple(g) for g in solved[f, cell]))) for f, cell in specs if f == film}
        out[film] = curve_growths(mine, rough, by_cell)
    return out


def _sent_laws(laws: dict, films: list) -> dict:
    """Each draw's laws (`_rough_laws`) for these films and without film."""
    return {d: {name: law for name, law in by_name.items() if name is None or name in films}
            for d, by_name in laws.items()}


def _rough_laws(study: Study, rough, films: dict, draws: list, workers, st, after: int) -> dict:
    """The rough wheel's pressure-closure laws (BEM) of each of ``draws``: against each film at its growth
    modulus and steel on steel, as `filmcal.correction.curves.rough_law_files` gives them. Each law is a study
    artefact (``roughlaws/<key>.npz``, kind ``rough-law``; `_RecordedRoughLaws`), recorded as soon as it is
    computed, so an interrupted run resumes with the missing laws only; the laws are computed in parallel and
    read back from their files by the tasks that use them (the same law to the bit)."""
    from filmcal.correction.curves import rough_law_files

    def started(solving: int, found: int) -> None:
        st.set_total(solving + after)
        if solving:
            st.log(f"[curves] rough wheel: {solving} pressure-closure laws (BEM) of {len(draws)} draws "
                   f"({found} kept from an earlier run)")

    return rough_law_files(replace(rough, draws=tuple(draws)), films, workers, None, _RecordedRoughLaws(study, st),
                           started)


class _RecordedRoughLaws:
    """The pipeline's store of rough laws for `filmcal.correction.curves.rough_law_files` (it holds the writer
    lock): a law is the study's when `StudyRoughLaws.held` (its own, or one `filmcal correct` or `filmcal
    curves` kept, taken over), and each law solved is recorded as an artefact."""

    def __init__(self, study: Study, st) -> None:
        from filmcal.study.core import StudyRoughLaws

        self.laws, self.st = StudyRoughLaws(study, command="filmcal pipeline"), st

    def kept(self, bodies, film, modulus_mpa) -> Path | None:
        spec, path = self.laws.spec_path(bodies, film, modulus_mpa)
        return path if self.laws.held(path, spec) else None

    def add(self, bodies, film, modulus_mpa, law) -> Path:
        from filmcal.contact.rough_law_file import save_rough_law
        from filmcal.study.core import StudyRoughLaws

        study = self.laws.study
        spec, path = self.laws.spec_path(bodies, film, modulus_mpa)
        path.parent.mkdir(parents=True, exist_ok=True)
        save_rough_law(law, path)
        study.manifest.data.get("caches", {}).pop(study.layout.relative(path), None)  # one changed since kept
        study.record(path, StudyRoughLaws.KIND, spec)
        self.st.advance(note=f"rough law, {'without film' if film is None else film.name}")
        return path


def _crossval_stage(study: Study, settings: PipelineSettings, results: dict, comparisons: dict, seed: int, workers,
                    st):
    """Leave-one-case-out cross-validation of the combined correction (``crossval/crossval-<film>.json``).

    Pareto-smoothed importance sampling of the full posteriors for each left-out
    case (`filmcal.correction.crossval.psis_leave_one_case_out`), with an exact
    recalibration only where the Pareto k exceeds 0.7.
    """
    from functools import partial

    from filmcal.correction.crossval import psis_leave_one_case_out

    computed = False
    chosen = [f for f in results if settings.crossval_films is None or f in settings.crossval_films]
    st.set_total(len(chosen))
    for film, models in results.items():
        if film not in chosen:
            continue
        path = study.layout.crossval(film)
        weights = (comparisons.get(film) or {}).get("weights") or {label: 1.0 for label in models}
        spec = {"film": film, "posteriors": sorted(p.name for _, p, _ in models.values()), "weights": weights}
        entry = study.manifest.entry(study.layout.relative(path)) if path.exists() else None
        if entry and entry["spec"] == spec and study.verified(path):
            continue
        pairs = {label: (study.problem(p), r.samples) for label, (r, p, _) in models.items() if weights.get(label, 0) > 0}
        refit = partial(refit_without_case, {label: problem for label, (problem, _) in pairs.items()}, film,
                        settings.max_steps, seed_for(seed, f"crossval-{film}"))
        st.log(f"[crossval] {film}: leave-one-case-out by PSIS over {len(pairs)} model(s)")
        cv = psis_leave_one_case_out(pairs, {k: weights[k] for k in pairs}, refit, film=film,
                                     random_state=seed_for(seed, f"crossval-{film}"),
                                     log=lambda msg: st.log(f"[crossval] {film}: {msg}"), workers=workers)
        path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_json(path, cv.to_dict(), indent=1)
        study.record(path, "crossval", spec)
        computed = True
        st.advance(note=film)
        st.log(f"[crossval] {film}: Hertz area inside the corrected 90 % interval in {cv.hits}/{len(cv.inside)} "
            f"cases, {cv.n_refits} exact refit(s)")
    return None, computed


def _outlines_stage(study: Study, settings: PipelineSettings, medians: dict, st):
    from filmcal.contact import names

    path = study.layout.outlines
    spec = {"films": medians, "force_kn": settings.outline_force_kn,
            "application_model_revision": names.APPLICATION_MODEL_REVISION}
    if _current(study, path, spec):
        return None, False
    from filmcal.contact.film import FilmModel
    from filmcal.wheelrail import solve_wheel_rail

    # each film as its preferred model was calibrated: small-strain springs or the large-strain film law
    laws = {film: FilmModel(study.film(film), m["model"].split("/")[0], m["kinematics"]).interface(m["modulus_mpa"])
            for film, m in medians.items()}

    force = settings.outline_force_kn * 1e3
    st.log(f"[outlines] wheel-rail contact outlines at {settings.outline_force_kn:g} kN")
    cases = []
    st.set_total(len(settings.offsets_mm))
    for eta in settings.offsets_mm:
        st.advance(note=f"eta {eta:+g} mm")
        bare = solve_wheel_rail(eta, force)
        case = {"offset_mm": eta, "contact_y_mm": bare.placement.contact.y_mm,
                "no film": {"area_mm2": bare.area_mm2, "outline_mm": bare.outline_mm}}
        for film, (layer, law, _) in laws.items():
            res = solve_wheel_rail(eta, force, film=layer, roughness=law)
            case[film] = {"area_mm2": res.area_mm2, "outline_mm": res.outline_mm}
        cases.append(case)
    atomic_write_json(path, {"force_n": force, "films": medians, "cases": cases}, indent=None)
    study.record(path, "outlines", spec)
    return None, True


def _current(study: Study, path, spec: dict) -> bool:
    """Whether `path` is recorded, intact, with this spec (else its stage computes it again)."""
    entry = study.manifest.entry(study.layout.relative(path)) if path.exists() else None
    return bool(entry and entry["spec"] == spec and study.verified(path))


def _report_stage(study: Study, write_report, workers, st):
    out = study.layout.report_dir
    current = study.manifest.data.get("report")
    inputs = {rel: e["sha256"] for rel, e in study.manifest.data["artefacts"].items()}
    html, pdf = out / "report.html", out / "report.pdf"
    if current and current.get("inputs") == inputs and html.exists() and pdf.exists():
        return {"html": str(html), "pdf": str(pdf)}, False
    st.log("[report] HTML and PDF")
    study.manifest.data.pop("report", None)
    study.manifest.write()
    paths = write_report(study.root, out, workers=workers,
                         progress=lambda done, total: st.update(0.9 * done / total, note=f"section {done}/{total}"))
    study.manifest.data["report"] = {"inputs": inputs}  # current only once both HTML and PDF are written
    study.manifest.write()
    return {"html": str(paths["html"]), "pdf": str(paths["pdf"]), "figures": paths.get("figures")}, True
