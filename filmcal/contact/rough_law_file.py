"""A rough contact's boundary-element law as a file: what a study keeps of the laws it computed.

A `filmcal.contact.roughness.RoughContactLaw` (or a `SeriesLaw` of them: a
rough wheel on a rough rail) is written whole: the surface's heights, every
solved load step with its local pressure map, and the law's parameters, in
one compressed ``.npz`` whose metadata is a JSON document (format
``filmcal-rough-law/1``). Read back, the law is the same law to the last
bit: the same closures, contact fractions and pressure distributions, so
that a study resumed after an interrupt answers what an uninterrupted one
answers. Reading never executes code from the file (no pickle).
"""
from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np

from filmcal._errors import damaged
from filmcal._io import atomic_open

__all__ = ["save_rough_law", "load_rough_law", "ROUGH_LAW_FORMAT"]

ROUGH_LAW_FORMAT = "filmcal-rough-law/1"

_STEP_FIELDS = ("nominal_pressure_mpa", "closure_mm", "contact_fraction", "plastic_fraction", "iterations",
                "converged")
_LAW_FIELDS = ("film_modulus_mpa", "film_poisson", "film_thickness_mm", "hardness_mpa")


def save_rough_law(law, path: str | Path) -> Path:
    """Write a rough contact law (or a series of them) to `path` (``.npz``, atomically); return the path.

    Raises
    ------
    TypeError
        If `law` is not a `RoughContactLaw` or a `SeriesLaw` of them.
    """
    from filmcal.contact.laws import SeriesLaw
    from filmcal.contact.roughness import RoughContactLaw

    parts = law.laws if isinstance(law, SeriesLaw) else (law,)
    if not parts or not all(isinstance(p, RoughContactLaw) for p in parts):
        raise TypeError(f"a rough law file holds boundary-element laws, not {type(law).__name__}")
    arrays: dict[str, np.ndarray] = {}
    meta = {"format": ROUGH_LAW_FORMAT, "series": isinstance(law, SeriesLaw), "laws": []}
    for i, part in enumerate(parts):
        arrays[f"law{i}_heights_um"] = np.asarray(part.surface.heights_um)
        for j, step in enumerate(part.steps):
            arrays[f"law{i}_step{j}_pressure_mpa"] = np.asarray(step.pressure_mpa)
        meta["laws"].append({
            "pixel_um": part.surface.pixel_um, "description": part.surface.description,
            **{k: float(getattr(part, k)) for k in _LAW_FIELDS},
            "steps": [{k: (bool(getattr(s, k)) if k == "converged" else int(getattr(s, k)) if k == "iterations"
                           else float(getattr(s, k))) for k in _STEP_FIELDS} for s in part.steps]})
    arrays["meta_json"] = np.frombuffer(json.dumps(meta).encode("utf-8"), dtype=np.uint8)
    with atomic_open(path, "wb") as fh:
        np.savez_compressed(fh, **arrays)
    return Path(path)


def load_rough_law(path: str | Path):
    """Read a law written by `save_rough_law`: a `RoughContactLaw`, or a `SeriesLaw` of them.

    Raises
    ------
    filmcal._errors.DamagedFileError
        If the file is not a readable rough law of this format.
    """
    from filmcal.contact.laws import SeriesLaw
    from filmcal.contact.roughness import PeriodicContact, RoughContactLaw, RoughSurface

    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(bytes(data["meta_json"]).decode("utf-8"))
            if meta.get("format") != ROUGH_LAW_FORMAT:
                raise ValueError(f"format {meta.get('format')!r}, expected {ROUGH_LAW_FORMAT!r}")
            laws = []
            for i, d in enumerate(meta["laws"]):
                # the heights as written (their mean already removed): set, not rebuilt, so that not one bit moves
                surface = object.__new__(RoughSurface)
                heights = np.array(data[f"law{i}_heights_um"], dtype=float)
                heights.setflags(write=False)
                object.__setattr__(surface, "heights_um", heights)
                object.__setattr__(surface, "pixel_um", float(d["pixel_um"]))
                object.__setattr__(surface, "description", str(d["description"]))
                steps = [PeriodicContact(pressure_mpa=np.array(data[f"law{i}_step{j}_pressure_mpa"]),
                                         **{k: s[k] for k in _STEP_FIELDS})
                         for j, s in enumerate(d["steps"])]
                laws.append(RoughContactLaw(surface, steps, **{k: float(d[k]) for k in _LAW_FIELDS}))
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
        if isinstance(exc, FileNotFoundError):
            raise
        raise damaged(path, exc, recomputable=True) from exc
    return SeriesLaw(*laws) if meta["series"] else laws[0]
