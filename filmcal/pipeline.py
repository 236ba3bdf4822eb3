"""The whole job on the embedded default: FE designs -> campaign -> surrogate ->
calibration of MS, HS and HHS -> wheel-rail correction curves, in one study folder.

Every stage keeps its results in the folder (campaign store, surrogate arrays +
JSON, HDF5 chains, posterior JSON, curve CSVs) and reuses them, so an
interrupted run loses no finished work and a second run only reads.
"""
from __future__ import annotations

import csv
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from filmcal._json import json_safe
from filmcal.films import FILM_TYPES

__all__ = ["PipelineSettings", "run_pipeline"]


@dataclass(frozen=True)
class PipelineSettings:
    """Sizes of the pipeline's stages (`quick` is a small version for tests)."""

    train_runs: int = 200
    test_runs: int = 100
    offsets_mm: tuple[float, ...] = tuple(np.arange(-7.0, 2.01, 1.0))
    forces_kn: tuple[float, ...] = (50.0, 100.0)
    max_steps: int | None = None

    @classmethod
    def quick(cls) -> "PipelineSettings":
        return cls(train_runs=40, test_runs=12, offsets_mm=(-6.0, -3.0, 0.0), forces_kn=(50.0,), max_steps=3000)


def run_pipeline(study_dir: str | Path, settings: PipelineSettings | None = None, films=FILM_TYPES,
                 seed: int = 0, workers: int | None = None, log=print) -> dict:
    """Run (or resume) the pipeline; returns the summary also written to ``summary.json``."""
    from filmcal.correction import correction_curves
    from filmcal.study import calibrate_from_study

    settings = settings or PipelineSettings()
    study = Path(study_dir)
    study.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    summary: dict = {"study_dir": str(study), "settings": settings.__dict__, "seed": seed, "films": {}}
    for film in films:
        log(f"[{film}] surrogate and calibration")
        result, validation, _, path = calibrate_from_study(study, film, None, seed=seed, n_train=settings.train_runs,
                                                           n_test=settings.test_runs, workers=workers,
                                                           max_steps=settings.max_steps)
        summary["surrogate_validation"] = validation.to_dict()
        curves_csv = study / f"curves-{film}.csv"
        if not curves_csv.exists():
            log(f"[{film}] wheel-rail correction curves")
            samples = np.asarray(result.samples["modulus_mpa"], dtype=float)
            c = correction_curves(samples, settings.offsets_mm, np.asarray(settings.forces_kn) * 1e3)
            _write_curves(curves_csv, c)
        d = result.to_dict()
        summary["films"][film] = {k: d[k] for k in ("modulus_mpa", "oedometric_modulus_mpa", "sigma_mm", "rhat",
                                                    "ess", "n_data")}
        summary["films"][film]["diagnostics_ok"] = bool(result.diagnostics_ok)
        summary["films"][film]["posterior_file"] = str(path)
        summary["films"][film]["curves_file"] = str(curves_csv)
    summary["elapsed_s"] = time.perf_counter() - t0
    (study / "summary.json").write_text(json.dumps(json_safe(summary), indent=2) + "\n")
    return summary


def _write_curves(path: Path, c) -> None:
    tmp = path.with_suffix(".tmp")
    with open(tmp, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["force_kn", "offset_mm", "area_no_film_mm2", "delta_area_median_mm2", "delta_area_lo_mm2",
                    "delta_area_hi_mm2", "ratio_median", "ratio_lo", "ratio_hi", "interpolation_error_rel"])
        for i, force in enumerate(c.forces_n):
            for j, eta in enumerate(c.offsets_mm):
                w.writerow([force / 1e3, eta, c.area_no_film_mm2[i, j], c.delta_area_median_mm2[i, j],
                            *c.delta_area_ci90_mm2[i, j], c.ratio_median[i, j], *c.ratio_ci90[i, j],
                            c.interpolation_error_rel[i, j]])
    tmp.replace(path)  # written whole or not at all

