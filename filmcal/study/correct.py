"""One correction of a measured imprint against a study's calibrated film: what ``filmcal correct`` calls.

A measurement is a sphere-on-flat imprint (`SphereMeasurement`) or a wheel-rail imprint
(`WheelRailMeasurement`); its measured value may come from a scanned sheet instead (`ScanReading`). The
answer pools the study's correctors of the film (its mixture of calibrated models, or the one the options
pin), after the correctors' plausibility rules, and is returned as a JSON-ready dict.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from filmcal._errors import InputError
from filmcal.hertz import ELASTIC_LIMIT_MPA
from filmcal._validation import FORCE_KN_BOUNDS, OFFSET_MM_BOUNDS, SPHERE_RADIUS_MM_BOUNDS
from filmcal.contact.names import MIXTURE
from filmcal.wheelrail.settings import NOMINAL_RADIUS_MM, RAIL, RAIL_INCLINATION, WHEEL

__all__ = ["SphereMeasurement", "WheelRailMeasurement", "ScanReading", "BodyRoughness", "correct_measurement",
           "ELASTIC_LIMIT_MPA", "CorrectionWarning", "ElasticLimitWarning", "OutsideDomainWarning"]


@dataclass(frozen=True)
class SphereMeasurement:
    """A sphere-on-flat imprint: its radius (None: read from a scan), the sphere and the force."""

    measured_radius_mm: float | None
    sphere_radius_mm: float
    force_kn: float
    measurement_std_mm: float = 0.0

    def __post_init__(self) -> None:
        _check_value("measured_radius_mm", self.measured_radius_mm, "measurement_std_mm", self.measurement_std_mm)
        _check_bounds("sphere_radius_mm", self.sphere_radius_mm, SPHERE_RADIUS_MM_BOUNDS)
        _check_bounds("force_kn", self.force_kn, FORCE_KN_BOUNDS)


@dataclass(frozen=True)
class WheelRailMeasurement:
    """A wheel-rail imprint: its area (None: read from a scan), the lateral offset, the load and the track."""

    measured_area_mm2: float | None
    offset_mm: float
    force_kn: float
    measured_area_std_mm2: float = 0.0
    wheel: str = WHEEL
    rail: str = RAIL
    rail_inclination: float = RAIL_INCLINATION
    nominal_radius_mm: float = NOMINAL_RADIUS_MM
    offset_std_mm: float = 0.0

    def __post_init__(self) -> None:
        _check_value("measured_area_mm2", self.measured_area_mm2, "measured_area_std_mm2", self.measured_area_std_mm2)
        _check_bounds("offset_mm", self.offset_mm, OFFSET_MM_BOUNDS)
        _check_bounds("force_kn", self.force_kn, FORCE_KN_BOUNDS)
        if not (math.isfinite(self.offset_std_mm) and 0.0 <= self.offset_std_mm <= 10.0):
            raise ValueError(f"offset_std_mm must be finite and in [0, 10] mm, got {self.offset_std_mm}")


@dataclass(frozen=True)
class ScanReading:
    """A scanned imprint and how to read it (`filmcal.correction.read_imprint`); optionally where to write the
    outline without film (CSV) and which way the rail's field side points in the scan."""

    path: str
    dpi: float | None = None
    mm_per_pixel: float | None = None
    threshold: float | None = None
    min_region_mm2: float = 1.0
    outline_out: str | None = None
    field_side: str = "right"


@dataclass(frozen=True)
class BodyRoughness:
    """The bodies' roughness of a wheel-rail measurement and how many draws of the roughness law's conditioned
    inputs (`filmcal.contact.rough_imprint.load_roughness_inputs`) the band takes.

    Each body is smooth (None or Ra 0), an Ra in um (a synthetic surface per draw) or a measured surface
    file (`filmcal.contact.surface_files.read_surface_file`: x3p, a CSV line profile across the lay, or a
    CSV height map with ``pixel_um`` and ``height_scale``, or a greyscale image with ``pixel_um`` and
    ``height_range_um``); not both for one body.
    """

    wheel_ra_um: float | None = None
    rail_ra_um: float | None = None
    n_draws: int = 8
    wheel_map: str | None = None
    rail_map: str | None = None
    pixel_um: float | None = None
    height_scale: float = 1.0
    height_range_um: float | None = None

    def __post_init__(self) -> None:
        from filmcal._validation import check_ra
        from filmcal.contact.rough_imprint import load_roughness_inputs

        for name in ("wheel", "rail"):
            value = getattr(self, f"{name}_ra_um")
            if value is not None:
                check_ra(f"{name}_roughness_ra_um", value)
                if getattr(self, f"{name}_map") is not None:
                    raise ValueError(f"give the {name}'s roughness as an Ra or as a map, not both")
        available = len(load_roughness_inputs())
        if isinstance(self.n_draws, bool) or not isinstance(self.n_draws, int) or not 1 <= self.n_draws <= available:
            raise ValueError(f"roughness_draws must be an integer in [1, {available}] (the shipped conditioned "
                             f"draws), got {self.n_draws!r}")
        surfaces = {name: self._read(getattr(self, f"{name}_map")) for name in ("wheel", "rail")}
        object.__setattr__(self, "_surfaces", surfaces)

    def _read(self, path: str | None):
        if path is None:
            return None
        from filmcal.contact.surface_files import read_surface_file

        return read_surface_file(path, self.pixel_um, self.height_scale, self.height_range_um)

    def wheel(self):
        """The wheel as `RoughnessInputs.bodies` takes it: a measured surface, an Ra or None."""
        return self._surfaces["wheel"] or self.wheel_ra_um

    def rail(self):
        return self._surfaces["rail"] or self.rail_ra_um

    @property
    def smooth(self) -> bool:
        return not self.wheel() and not self.rail()

    def fingerprint(self) -> dict[str, Any]:
        """What the rough solves depend on: each body's Ra, or its measured surface's fingerprint."""
        out: dict[str, Any] = {}
        for name in ("wheel", "rail"):
            surface = self._surfaces[name]
            out[name] = surface.fingerprint() if surface is not None else float(getattr(self, f"{name}_ra_um") or 0.0)
        return out

    def describe(self) -> dict[str, Any]:
        """Each body's Ra (um; measured from its map when given) and its map file, JSON-ready."""
        out: dict[str, Any] = {}
        for name in ("wheel", "rail"):
            surface = self._surfaces[name]
            out[f"{name}_ra_um"] = surface.ra_um if surface is not None else (getattr(self, f"{name}_ra_um") or 0.0)
            if surface is not None:
                out[f"{name}_map"] = {"file": str(getattr(self, f"{name}_map")), "surface": surface.description,
                                      "rms_um": surface.rms_um}
        return out


def _check_bounds(name: str, value: float, bounds: tuple[float, float]) -> None:
    if not (math.isfinite(value) and bounds[0] <= value <= bounds[1]):
        raise ValueError(f"{name} {value:g} outside [{bounds[0]:g}, {bounds[1]:g}]")


def _check_value(name: str, value: float | None, std_name: str, std: float) -> None:
    if value is not None and not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be finite and > 0, got {value}")
    if not std >= 0:
        raise ValueError(f"{std_name} must be >= 0, got {std}")




class CorrectionWarning(UserWarning):
    """An answer stands, with a reason to doubt it (also in its ``warnings``)."""


class ElasticLimitWarning(CorrectionWarning):
    """The corrected contact's peak pressure exceeds the steel's elastic limit: the elastic model is outside its
    validity."""


class OutsideDomainWarning(CorrectionWarning):
    """The film's transfer to the wheel-rail model is extrapolated: the contact is smaller or larger than every
    sphere-on-flat contact it was fitted and verified on, or the film's thickness, Poisson's ratio, modulus or
    activation pressure against the peak lies beyond the fitted films' (`outside_fit`)."""


#: What a smooth wheel-rail answer does not carry: the bodies' roughness.
ROUGHNESS_NOT_INCLUDED = ("the bodies' roughness: wheel and rail are taken as smooth; a service wheel's roughness can "
                          "enlarge an imprint by several percent (give --wheel-roughness-ra-um / "
                          "--rail-roughness-ra-um)")


#: What an answer from a measured value given without its uncertainty does not carry (a scan reads its own).
AREA_READING_NOT_INCLUDED = ("the measured area's own uncertainty: it is taken as exact; reading an imprint's "
                             "outline costs a few percent of its area (give --measured-area-std-mm2, or --scan)")
SPHERE_READING_NOT_INCLUDED = ("the measured radius's own uncertainty: it is taken as exact (give "
                               "--measurement-std-mm, or --scan)")


#: What an answer with an exact offset does not carry.
OFFSET_NOT_INCLUDED = ("the offset's uncertainty: eta is taken as exact; a ruler or gauge reads it to about 0.5-1 mm "
                       "(give --offset-std-mm)")


def _provenance(study, parts, measurement, sphere: bool, seed: int, options: dict) -> dict[str, Any]:
    """Where an answer came from: the study, each posterior (file and SHA-256), the filmcal version, the
    measurement's options, the seed and, for a wheel-rail answer, the transfer fit."""
    from dataclasses import asdict

    from filmcal._versions import __version__

    out: dict[str, Any] = {
        "filmcal": __version__, "study": str(Path(study.root).resolve()), "manifest_sha256": study.manifest_sha256,
        "posteriors": {s["model"]: {"file": s.get("posterior_file"), "sha256": s.get("posterior_sha256")}
                       for _, _, s in parts},
        "measurement": asdict(measurement), "options": options,
        "seed": seed}  # no clock: the same inputs give the same bytes
    if not sphere:
        from filmcal.contact.transfer import TRANSFER_FILE, load_transfer_fit

        fit = load_transfer_fit()
        out["transfer_fit"] = {"file": f"filmcal/data/{TRANSFER_FILE}", "made": fit.provenance.get("made"),
                               "sha256": {s["model"]: fit.digest(s["model"]) for _, _, s in parts}}
    return out


def correct_measurement(study, film: str, measurement: SphereMeasurement | WheelRailMeasurement, *,
                        imprint_model: str = MIXTURE, kinematics: str | None = None, poisson: str | None = None,
                        calibration_forces_kn: str | None = None, scan: ScanReading | None = None,
                        roughness: BodyRoughness | None = None, seed: int = 0,
                        progress=None, elastic_limit_mpa: float = ELASTIC_LIMIT_MPA,
                        cache: dict | None = None) -> tuple[dict[str, Any], Any]:
    """Correct one measured imprint with a study's calibrated film; return ``(answer, scan reading)``.

    Parameters
    ----------
    study : filmcal.study.Study
        An existing study (never calibrated again: its recorded posteriors are read).
    film : str
        The film type.
    measurement : SphereMeasurement or WheelRailMeasurement
    imprint_model, kinematics, poisson, calibration_forces_kn : optional
        Which posteriors: ``mixture`` (default) pools the models the study compared by their weights.
    scan : ScanReading, optional
        Read the measured value from a scanned imprint (its uncertainty adds in quadrature).
    roughness : BodyRoughness, optional
        Wheel-rail: the bodies' roughness; the answer and its band then include the rough/smooth growth of
        the contact without film over the film's (`filmcal.correction.roughness`), and ``roughness`` reports
        the smooth answer, each model's growths with their Monte-Carlo error and the roughness share of the
        band's variance.
    seed : int
        Seed of the scatter draws.
    progress : callable, optional
        ``progress(done, total)`` while the rough solves run.
    cache : dict, optional
        Correctors kept between calls (a batch): the posteriors are read and their solves shared once.
    elastic_limit_mpa : float
        Above this peak pressure of the contact without film the answer carries a warning (``warnings`` in
        the dict, and an `ElasticLimitWarning`): the elastic model is outside its validity.

    Returns
    -------
    (dict, ImprintReading or None)
        ``area_mm2``, ``area_std_mm2``, ``area_ci90_mm2`` and the rest of `CorrectedArea.to_dict`, with
        ``film``, ``form`` and ``models`` (each pooled model's weight and answer); with a scan also
        ``measured_area_mm2``, ``measured_area_std_mm2``, ``scan`` and, when asked, ``outline_file``.
    """
    sphere = isinstance(measurement, SphereMeasurement)
    m = measurement
    value = m.measured_radius_mm if sphere else m.measured_area_mm2
    if (value is None) == (scan is None):
        raise ValueError("give either a measured " + ("radius" if sphere else "area") + " or a scan, not both "
                         "and not neither")
    study.film(film)
    reading = None
    if scan is not None:
        from filmcal.correction import read_imprint

        reading = read_imprint(scan.path, dpi=scan.dpi, mm_per_pixel=scan.mm_per_pixel, threshold=scan.threshold,
                               min_region_mm2=scan.min_region_mm2)
    match = {"imprint": None if imprint_model == MIXTURE else imprint_model, "kinematics": kinematics,
             "poisson": poisson, "loads": calibration_forces_kn}
    force_n = m.force_kn * 1e3
    if sphere:
        if reading is not None:
            radius = reading.equivalent_radius_mm
            radius_std = math.hypot(m.measurement_std_mm, reading.area_std_mm2 / (2.0 * math.pi * radius))
        else:
            radius, radius_std = m.measured_radius_mm, m.measurement_std_mm
        parts = _correctors(cache, study, film, "sphere", seed, None, match)
        _plausible(parts[0][1], reading, scan, radius, m.sphere_radius_mm, force_n)
        results = [c.correct(radius, m.sphere_radius_mm, force_n, radius_std) for _, c, _ in parts]
    else:
        if reading is not None:
            area, area_std = reading.area_mm2, math.hypot(m.measured_area_std_mm2, reading.area_std_mm2)
        else:
            area, area_std = m.measured_area_mm2, m.measured_area_std_mm2
        parts = _correctors(cache, study, film, "wheel-rail", seed,
                            dict(wheel=m.wheel, rail=m.rail, rail_inclination=m.rail_inclination,
                                 nominal_radius_mm=m.nominal_radius_mm), match)
        _plausible(parts[0][1], reading, scan, area, m.offset_mm, force_n)
        results = [c.correct(area, m.offset_mm, force_n, area_std, offset_std_mm=m.offset_std_mm)
                   for _, c, _ in parts]
    if sphere and roughness is not None and not roughness.smooth:
        raise ValueError("roughness applies to the wheel-rail form (sphere-on-flat corrections are calibrated on "
                         "the paper's smooth spheres)")
    result = _pool(results, parts, seed)
    rough_out, kept = None, None
    if not sphere and roughness is not None and not roughness.smooth:
        smooth = result
        growths, draws, inputs_source, kept = _rough_growths(study, parts, m, force_n, roughness, progress)
        results = [c.correct(area, m.offset_mm, force_n, area_std, rough=growths[c.film.label],
                             offset_std_mm=m.offset_std_mm)
                   for _, c, _ in parts]
        result = _pool(results, parts, seed)
        var_rough, var_smooth = float(result.area_std_mm2) ** 2, float(smooth.area_std_mm2) ** 2
        rough_out = {
            **roughness.describe(),
            "inputs": inputs_source,
            "n_draws": len(draws), "smooth_area_mm2": float(smooth.area_mm2),
            "smooth_area_std_mm2": float(smooth.area_std_mm2),
            "smooth_area_ci90_mm2": [float(v) for v in smooth.area_ci90_mm2],
            "share_of_variance": max(0.0, 1.0 - var_smooth / var_rough) if var_rough > 0 else 0.0,
            "models": {s["model"]: growths[c.film.label].summary() for _, c, s in parts}}
    out = result.to_dict()
    out.update(film=film, form="sphere-on-flat" if sphere else "wheel-rail",
               models={s["model"]: {"weight": w, "area_mm2": float(r.area_mm2), "area_ci90_mm2": r.area_ci90_mm2}
                       for (w, _, s), r in zip(parts, results)})
    if not sphere:  # the calibrated film against the applied one: included in every model's answer and band
        for w, c, s in parts:
            out["models"][s["model"]]["transfer"] = c.transfer(m.offset_mm, force_n)
    out["provenance"] = _provenance(study, parts, measurement, sphere, seed,
                                    {"imprint_model": imprint_model, "kinematics": kinematics, "poisson": poisson,
                                     "calibration_forces_kn": calibration_forces_kn,
                                     "elastic_limit_mpa": elastic_limit_mpa})
    if not sphere:
        out["patch"] = _patch(m, parts, result)
    peak = _no_film_peak_mpa(measurement, parts, sphere)
    out["max_pressure_no_film_mpa"] = peak
    if peak > elastic_limit_mpa:
        _warn(out, f"the contact without film reaches a peak pressure of {peak:.0f} MPa, above the steel's elastic "
                   f"limit of {elastic_limit_mpa:.0f} MPa (--elastic-limit-mpa): the elastic model is outside its "
                   "validity and the real contact is larger (plastic)")
    if not sphere:
        from filmcal.contact.transfer import load_transfer_fit
        from filmcal.correction.transfer import outside_fit

        a0 = math.sqrt(_no_film(measurement, parts)["area_mm2"] / math.pi)
        reasons = list(dict.fromkeys(r for _, c, _ in parts for r in outside_fit(
            load_transfer_fit(), c.film.film, c.film.imprint, a0, peak, c.modulus_mpa_)))
        if reasons:
            _warn(out, "the film's transfer to the wheel-rail model is extrapolated: " + "; ".join(reasons)
                  + "; the transfer term, and so the answer and its band, are extrapolated", OutsideDomainWarning)
    if rough_out is not None:
        from filmcal.correction.roughness import waviness_peak_mpa
        from filmcal.study.core import StudyRoughLaws

        crest = waviness_peak_mpa(draws[0], m.offset_mm, force_n, parts[0][1].settings, wheel=roughness.wheel(),
                                  rail=roughness.rail(), keep=StudyRoughLaws(study).law)
        if crest is not None and crest > elastic_limit_mpa:
            _warn(out, f"the measured surface's waviness (wavelengths over the contact grid's few cells) stripes the "
                       f"contact: without film its crests carry up to {crest:.0f} MPa, above the steel's elastic "
                       f"limit of {elastic_limit_mpa:.0f} MPa (--elastic-limit-mpa); the real crests flatten, so the "
                       "contact without film is larger than solved and the corrected area is a lower bound")
        rough_out["waviness_peak_pressure_mpa"] = crest
        out["roughness"] = rough_out
        out["provenance"]["roughness"] = {**roughness.describe(), "n_draws": rough_out["n_draws"]}
    elif not sphere:  # what the band does not hold, said with the answer
        out["not_included"] = [ROUGHNESS_NOT_INCLUDED]
    if not sphere and not m.offset_std_mm:
        out.setdefault("not_included", []).append(OFFSET_NOT_INCLUDED)
    if reading is None and not (m.measurement_std_mm if sphere else m.measured_area_std_mm2):
        out.setdefault("not_included", []).append(SPHERE_READING_NOT_INCLUDED if sphere else AREA_READING_NOT_INCLUDED)
    if reading is not None:
        out.update(_scanned(reading, scan, result, None if sphere else (parts, m.offset_mm, force_n)))
    if not sphere:  # the answer stands: the study keeps its solves (a refused input keeps nothing)
        for cache_ in {id(c.supports.cache): c.supports.cache for _, c, _ in parts}.values():
            if cache_ is not None:
                cache_.flush()
        if kept is not None:
            kept.flush()
    return out, reading


def _rough_growths(study, parts, m: WheelRailMeasurement, force_n: float, roughness: BodyRoughness, progress):
    """Each pooled model's rough/smooth growths at the measurement, as the study kept them or solved now.

    Returns ``(growths by film label, draws, the draws' source, the study's store of growths)``; the store is
    flushed once the answer stands."""
    from filmcal.correction.roughness import RoughGrowth, corrector_growths
    from filmcal.study.core import StudyGrowths, StudyRoughLaws, growth_modulus_of

    inputs, inputs_source = study.roughness_inputs()
    draws = inputs[:roughness.n_draws]
    kept = StudyGrowths(study, parts)
    modulus = growth_modulus_of(study, parts)
    spec = kept.spec(m.offset_mm, force_n, roughness.fingerprint(), draws, modulus)
    stored = kept.get(spec)
    if stored is not None:  # solved before for these posteriors, bodies and draws
        w = np.full(len(draws), 1.0 / len(draws))
        growths = {c.film.label: RoughGrowth(np.asarray(stored[s["model"]]["film"], float),
                                             np.asarray(stored[s["model"]]["no_film"], float), w, draws)
                   for _, c, s in parts}
    else:  # each law kept as soon as it is solved: run again after an interrupt, only the missing are solved
        growths = corrector_growths([c for _, c, _ in parts], [w for w, _, _ in parts], m.offset_mm, force_n,
                                    draws, wheel=roughness.wheel(), rail=roughness.rail(), progress=progress,
                                    keep=StudyRoughLaws(study).law, modulus_mpa=modulus)
        kept.put(spec, {s["model"]: {"film": growths[c.film.label].film.tolist(),
                                     "no_film": growths[c.film.label].no_film.tolist()} for _, c, s in parts})
    return growths, draws, inputs_source, kept


def _warn(out: dict, text: str, category: type[CorrectionWarning] = ElasticLimitWarning) -> None:
    """Add `text` to the answer's ``warnings`` and issue it as a `category` warning (to the caller's caller)."""
    import warnings

    out.setdefault("warnings", []).append(text)
    warnings.warn(category(text), stacklevel=3)


def _plausible(corrector, reading, scan: ScanReading | None, value: float, *where: float) -> None:
    """The corrector's plausibility check of the measured value; one read from a scan is said of the scan."""
    try:
        corrector.check_plausible(value, *where)
    except ValueError as exc:
        if reading is None:
            raise
        raise InputError(f"--scan {scan.path}: the imprint read from it: {exc}") from None


def _scanned(reading, scan: ScanReading, result, wheel_rail: tuple | None) -> dict[str, Any]:
    """What the answer says of a scanned imprint, and its corrected outline written when asked.

    ``wheel_rail`` is ``(parts, offset_mm, force_n)`` of a wheel-rail answer, None for a sphere."""
    details = {k: v for k, v in reading.to_dict().items() if k not in ("area_mm2", "area_std_mm2")}
    out = dict(measured_area_mm2=reading.area_mm2, measured_area_std_mm2=reading.area_std_mm2,
               scan={"file": str(scan.path), **details})
    if scan.outline_out is not None:
        from filmcal.correction import correct_outline

        model = None
        if wheel_rail is not None:  # the outline's shift round the patch comes from the weightiest model
            parts, offset_mm, force_n = wheel_rail
            corrector = max(parts, key=lambda part: part[0])[1]
            model = corrector.outline_model(offset_mm, force_n)
        outline = correct_outline(reading.outlines_mm, result, model, field_side=scan.field_side)
        outline.write_csv(Path(scan.outline_out))
        out.update(outline_file=str(scan.outline_out), outline_rule=outline.rule)
    return out


def _correctors(cache: dict | None, study, film: str, kind: str, seed: int, wheel_rail: dict | None, match: dict):
    """`filmcal.study.core.correctors`, kept in `cache` by their options."""
    from filmcal.study.core import correctors

    key = (film, kind, seed, tuple(sorted((wheel_rail or {}).items())), tuple(sorted(match.items())))
    if cache is not None and key in cache:
        return cache[key]
    parts = correctors(study, film, kind, random_state=seed, wheel_rail=wheel_rail, **match)
    if cache is not None:
        cache[key] = parts
    return parts


def _no_film(m, parts, offset_mm: float | None = None) -> dict:
    """The wheel-rail contact without film of the measured configuration (area, peak pressure, outline length
    and width, centroid on the rail), from the correctors' shared solves (kept in the study)."""
    supports = parts[0][1].supports(m.offset_mm if offset_mm is None else offset_mm, 1e3 * m.force_kn)
    return {"area_mm2": supports["area_no_film_mm2"], **supports["no_film"]}


def _no_film_peak_mpa(m, parts, sphere: bool) -> float:
    """Peak pressure (MPa) of the measured configuration's contact without film (Hertz, or the wheel-rail solve)."""
    if sphere:
        from filmcal.hertz import hertz_max_pressure_mpa

        return float(hertz_max_pressure_mpa(m.sphere_radius_mm, 1e3 * m.force_kn))
    return float(_no_film(m, parts)["max_pressure_mpa"])


def _band(samples: np.ndarray) -> dict[str, Any]:
    lo, hi = np.quantile(samples, [0.05, 0.95])
    return {"mean": float(np.mean(samples)), "std": float(np.std(samples, ddof=1)), "ci90": [float(lo), float(hi)]}


def _patch(m, parts, result) -> dict[str, Any]:
    """The corrected patch's length and width (mm) and its lateral position on the rail (mm), with bands.

    The patch without film keeps its shape: each sample of the corrected area scales the solved contact's
    length and width by sqrt(A / A_0). Its lateral position is the solved contact's centroid on the rail;
    with an uncertain offset, moved along its slope in the offset (solves at eta -/+ u).
    """
    bare = _no_film(m, parts)
    length, width = bare["length_mm"], bare["width_mm"]
    scale = np.sqrt(np.clip(np.asarray(result.samples_mm2, dtype=float).ravel(), 0.0, None) / bare["area_mm2"])
    position = np.full(scale.size, bare["centroid_rail_y_mm"])
    u = float(m.offset_std_mm)
    if u > 0:
        lo, hi = (_no_film(m, parts, m.offset_mm + sign * u) for sign in (-1.0, 1.0))
        slope = (hi["centroid_rail_y_mm"] - lo["centroid_rail_y_mm"]) / (2.0 * u)
        position = position + slope * u * np.random.default_rng(1).standard_normal(scale.size)
    return {"length_mm": _band(length * scale), "width_mm": _band(width * scale),
            "lateral_position_mm": _band(position), "no_film_length_mm": length, "no_film_width_mm": width,
            "rule": "the contact without film's outline, scaled by sqrt(corrected area / its area); x rolling, "
                    "y lateral; position: its centroid on the rail"}


def _pool(results, parts, seed: int):
    """One model's answer, or the models' mixture by their weights."""
    if len(parts) == 1:
        return results[0]
    from filmcal.correction.sphere import pool_corrected

    return pool_corrected(results, [w for w, _, _ in parts], random_state=seed)
