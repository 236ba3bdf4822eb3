"""The calibration report of a study folder: the answer, what was computed, figure by figure, and why it can be trusted.

Two layers:

- **Reading** (`read_study`): the only code here that knows the study folder's
  file names. It returns a `StudyData` of plain data (dicts, arrays,
  calibration results); a file that is missing is None, a file that cannot be
  read is None with a line in ``StudyData.problems``.
- **Sections**: one function per section, each taking plain data and returning a
  `Section`. `SECTION_BUILDERS` lists them in order; adding a section is one
  function plus one line there.

`build_report` composes the title page and the sections; `write_report`
writes the self-contained HTML and the A4 PDF printed from the same page.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import platform
import re
import subprocess
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import numpy as np

from filmcal._errors import UntrustedArtefactError
from filmcal._io import atomic_write_text
from filmcal._versions import NUMERIC_PACKAGES, software_versions, version_note
from filmcal.report import figures as F
from filmcal.report.document import Definitions, FigureBlock, Report, Section, Table, render_html
from filmcal.report.typeset import write_pdf

__all__ = ["build_report", "write_report", "read_study", "StudyData", "DesignData", "SECTION_BUILDERS",
           "GLOSSARY", "answer_table", "summary_section", "calibration_sections", "verification_section",
           "preliminary_section", "design_section", "surrogate_section", "calibration_section", "film_records_section",
           "crossval_section", "wheel_rail_section", "glossary_section", "provenance_section",
           "REFERENCE_OFFSET_MM"]

#: Offset of the reference case quoted on the title page (the paper's centred position).
REFERENCE_OFFSET_MM = 0.0


# ================================================================ reading
@dataclass
class DesignData:
    """The FE campaign's designs in physical units, with their quality metrics."""

    labels: list[str]
    train: np.ndarray
    test: np.ndarray
    log_scale: list[bool]
    levels: list[tuple[float, ...] | None]
    metrics: dict  # {"train"|"test": {"n", "quality", "random_lhs_median"}}


@dataclass
class StudyData:
    """Everything the report shows, read from one study folder (None: not in the folder)."""

    folder: Path
    films: list[str]
    seed: int | None
    settings_hash: str
    settings: dict
    software: dict | None = None  # versions that made the study (None: not recorded)
    software_later: list = field(default_factory=list)  # versions of later writers that differed
    posteriors: dict = field(default_factory=dict)  # film -> (CalibrationResult, file name, model label), preferred
    other_posteriors: dict = field(default_factory=dict)  # film -> [(CalibrationResult, file name, model label)]
    curves: dict = field(default_factory=dict)  # film -> list of row dicts
    verification: dict | None = None
    design: DesignData | None = None
    surrogate_validation: dict | None = None
    radius_model: object | None = None  # predict(E, nu, R, F) -> (mean, std)
    modulus_range_mpa: tuple[float, float] = (400.0, 20000.0)
    crossval: dict = field(default_factory=dict)  # film -> CaseCrossValidation
    outlines: dict | None = None
    earlier_application: list = field(default_factory=list)  # files the wheel-rail model made at an earlier revision
    transfer_notes: dict = field(default_factory=dict)  # film -> where its curves' film transfer is extrapolated
    imprint_comparison: dict | None = None  # film -> comparison dict
    files: list[tuple[str, int, str]] = field(default_factory=list)  # relative path, bytes, SHA-256
    problems: list[str] = field(default_factory=list)


def _earlier_application(study, paths) -> list[str]:
    """The files among `paths` that the wheel-rail model made at an earlier revision than this filmcal's
    (`filmcal.contact.names.APPLICATION_MODEL_REVISION`; none recorded: made before revisions were)."""
    from filmcal.contact.names import APPLICATION_MODEL_REVISION

    out = []
    for path in paths:
        entry = study.manifest.entry(study.layout.relative(path)) if path is not None and path.exists() else None
        if entry is not None and entry["spec"].get("application_model_revision") != APPLICATION_MODEL_REVISION:
            out.append(path.name)
    return out


def _transfer_note(study, film: str, rows: list[dict]) -> str | None:
    """What the pipeline's curves stage and `filmcal curves` warn of a film's curves whose transfer is
    extrapolated (`filmcal.correction.curves.transfer_note`), from the curves' rows and the film's posteriors."""
    from filmcal.correction import CURVE_COLUMNS
    from filmcal.correction.curves import transfer_note
    from filmcal.study.core import curve_components

    if not rows or "max_pressure_no_film_mpa" not in rows[0]:  # curves made before peaks were kept
        return None
    return transfer_note([[r[c] for c in CURVE_COLUMNS] for r in rows], curve_components(study, film))


def _read_json(path: Path | None) -> dict | None:
    from filmcal._io import read_json

    return read_json(path) if path is not None and path.exists() else None


def _domain():
    from filmcal.surrogate.radius import SurrogateDomain

    return SurrogateDomain()


def _ordered_posteriors(study, film: str) -> list[tuple[Path, str]]:
    """(file, model label) of a film's recorded posteriors, the preferred one first.

    Preferred: the comparison's ``preferred`` model, else the highest weight.
    When the film's models were compared, those with zero weight (not used by
    the correction) are left out; the comparison table still lists them.
    """
    from filmcal.study.core import comparison_weights

    found = study.posteriors(film)
    weights = comparison_weights(study, film)
    comparison = _read_json(study.verified(study.layout.comparison(film))) or {}
    preferred = comparison.get("preferred")
    order = list(weights)
    ranked = sorted(found, key=lambda f: (f[1]["model"] != preferred, -weights.get(f[1]["model"], 0.0),
                                          order.index(f[1]["model"]) if f[1]["model"] in order else len(order),
                                          f[1].get("loads") is not None, f[0].name))
    out = [(path, spec["model"]) for path, spec in ranked]
    if weights:
        out = out[:1] + [c for c in out[1:] if weights.get(c[1], 0.0) > 0]
    return out


def _read_design(path: Path | None) -> DesignData | None:
    d = _read_json(path)
    if d is None:
        return None
    from filmcal.calibration.plots import PARAMETER_LABELS

    space = _domain().space()
    params = list(space.parameters)
    labels = {"sphere_radius_mm": "sphere radius R (mm)", "force_kn": "load F (kN)", **PARAMETER_LABELS}
    train = np.asarray(space.to_physical(np.asarray(d["train"]["unit"])))
    test = np.asarray(space.to_physical(np.asarray(d["test"]["unit"])))
    return DesignData([labels.get(p.name, p.name) for p in params], train, test,
                      [p.scale == "log" for p in params], [p.levels for p in params],
                      {k: d[k] for k in ("train", "test")})


def read_study(study_dir: str | Path) -> StudyData:
    """Read a study folder into plain data, through its `filmcal.study.Study` (which knows the file names).

    Every file is checked against the SHA-256 the study recorded: a changed or
    unreadable file is left out with a line in ``StudyData.problems``.

    Raises
    ------
    ValueError
        If `study_dir` is not a study folder.
    """
    from filmcal.calibration import load_result
    from filmcal.correction import read_curves_csv
    from filmcal.correction.crossval import CaseCrossValidation
    from filmcal.study import Study
    from filmcal.study.core import report_view
    from filmcal.surrogate import load_surrogate
    from filmcal.surrogate.radius import SurrogateRadiusModel

    study = Study(study_dir)
    view = report_view(study)
    config = view["config"]
    data = StudyData(study.root, config["films"], config["seed"], config["hash"], config["settings"],
                     config["software"], config["software_later"])

    def attempt(what: str, read: Callable[[], object]):
        try:
            return read()
        except UntrustedArtefactError:
            raise  # a changed or foreign file is refused, not reported around
        except Exception as err:  # noqa: BLE001 (one unreadable file must not hide the rest of the report)
            data.problems.append(f"{what}: {err}")
            return None

    def verified(path: Path | None) -> Path | None:
        return None if path is None else study.verified(path)

    for film in data.films:
        results = []
        for path, model in attempt(f"posteriors of {film}", lambda film=film: _ordered_posteriors(study, film)) or []:
            result = attempt(path.name, lambda path=path: load_result(verified(path)))
            if result is not None:
                results.append((result, path.name, model))
        if results:
            data.posteriors[film] = results[0]
            if len(results) > 1:
                data.other_posteriors[film] = results[1:]
    data.curves = {film: r for film, path in view["curves"].items()
                   if (r := attempt(path.name, lambda path=path: read_curves_csv(verified(path)))) is not None}
    data.verification = attempt("fe-verification.json", lambda: _read_json(verified(view["verification"])))
    data.design = attempt("design.json", lambda: _read_design(verified(view["design"])))
    data.surrogate_validation = attempt("surrogate validation",
                                        lambda: _read_json(verified(view["surrogate_validation"])))
    stem = view["surrogate"]
    data.radius_model = None if stem is None else attempt("surrogate", lambda: SurrogateRadiusModel(
        load_surrogate(verified(stem.with_name(stem.name + ".json")).with_suffix("")), _domain()))
    data.modulus_range_mpa = tuple(_domain().modulus_mpa)
    data.crossval = {film: cv for film, path in view["crossval"].items()
                     if (cv := attempt(path.name, lambda path=path: CaseCrossValidation.from_dict(
                         _read_json(verified(path))))) is not None}
    data.outlines = attempt("wheelrail-outlines.json", lambda: _read_json(verified(view["outlines"])))
    data.earlier_application = _earlier_application(study, [*view["curves"].values(), view["outlines"]])
    data.transfer_notes = {film: note for film, rows in data.curves.items()
                           if (note := attempt(f"the film transfer of {film}'s curves",
                                               lambda film=film, rows=rows: _transfer_note(study, film, rows)))}
    comparisons = {film: d for film, path in view["comparison"].items()
                   if (d := attempt(path.name, lambda path=path: _read_json(verified(path)))) is not None}
    data.imprint_comparison = comparisons or None
    data.files = [(rel, (study.root / rel).stat().st_size, entry["sha256"])
                  for rel, entry in sorted(study.manifest.data["artefacts"].items()) if (study.root / rel).exists()]
    return data


# =============================================================== helpers
def _missing(section: Section, *names: str) -> Section:
    return section.add(f"Not available: {', '.join(names)} missing in the study folder (run `filmcal pipeline`).")


def _ci(d: dict, fmt: str = "{:.0f}") -> str:
    lo, hi = d["ci90"]
    return f"{fmt.format(d['median'])} [{fmt.format(lo)}, {fmt.format(hi)}]"


def _fixed_poisson(posteriors: dict) -> float | None:
    values = {r.poisson.get("fixed") for r, *_ in posteriors.values() if isinstance(r.poisson, dict)}
    values.discard(None)
    return values.pop() if len(values) == 1 else None


def _reference_row(rows: list[dict]) -> dict | None:
    """The smooth-wheel row at the largest load and the offset nearest `REFERENCE_OFFSET_MM`."""
    smooth = [r for r in rows if r["wheel"] == "smooth"] or rows
    if not smooth:
        return None
    force = max(r["force_kn"] for r in smooth)
    at_force = [r for r in smooth if r["force_kn"] == force]
    return min(at_force, key=lambda r: abs(r["offset_mm"] - REFERENCE_OFFSET_MM))


def _span(values, fmt: str) -> str:
    lo, hi = min(values), max(values)
    return fmt.format(lo) if fmt.format(lo) == fmt.format(hi) else f"{fmt.format(lo)} to {fmt.format(hi)}"


# =============================================================== sections
#: Models with at least this weight are quoted by their own median beside the mixture's (the span a user should know).
QUOTED_WEIGHT = 0.1


def mixture_quantiles(samples: list[np.ndarray], weights: list[float], q=(0.05, 0.5, 0.95)) -> list[float]:
    """Quantiles of the mixture of models' posterior samples, each model carrying its weight.

    Every sample of model m weighs ``w_m / n_m``; the quantile is the smallest
    sample where the cumulative weight reaches ``q`` (the mixture's inverse CDF).
    """
    x = np.concatenate([np.ravel(np.asarray(v, dtype=float)) for v in samples])
    w = np.concatenate([np.full(np.size(v), wm / np.size(v)) for v, wm in zip(samples, weights)])
    order = np.argsort(x, kind="stable")
    cdf = np.cumsum(w[order]) / w.sum()
    return [float(x[order][min(int(np.searchsorted(cdf, qk)), x.size - 1)]) for qk in q]


def _film_models(film: str, posteriors: dict, others: dict, comparison: dict) -> list[tuple[object, str, float]]:
    """(result, model label, weight) of a film's recorded models; one model without a comparison weighs 1."""
    chosen = [posteriors[film], *others.get(film, [])]
    weights = (comparison.get(film) or {}).get("weights") or {}
    if not weights:
        return [(chosen[0][0], chosen[0][2], 1.0)]
    return [(r, model, float(weights.get(model, 0.0))) for r, _, model in chosen if weights.get(model, 0.0) > 0]


def _preference(film: str, models: list, comparison: dict) -> str:
    """Which model the data prefer and by how much: its weight and its ELPD lead over the next best model."""
    c = comparison.get(film) or {}
    table = c.get("table") or []
    if len(table) < 2:
        return f"{models[0][1]} (the only model)" if models[0][1] else "one model"
    best, nxt = table[0], table[1]
    preferred = c.get("preferred") or best["name"]
    weight = float((c.get("weights") or {}).get(preferred, 0.0))
    if preferred != best["name"]:
        return f"{preferred} ({weight:.2f})"
    return f"{preferred} ({weight:.2f}; {nxt['elpd_diff']:+.1f} ± {nxt['dse']:.1f})"


def answer_table(posteriors: dict, curves: dict, others: dict | None = None,
                 comparison: dict | None = None) -> tuple[Table, list[str]]:
    """The title page's answer per film: the mixture's E with the weighted models' span, the preferred model
    and by how much, and the correction factor at the reference case (the curves combine the models)."""
    others, comparison = others or {}, comparison or {}
    rows, ref_case, failed = [], None, []
    for film in dict.fromkeys([*posteriors, *curves]):
        cells = [film]
        if film in posteriors:
            models = _film_models(film, posteriors, others, comparison)
            lo, med, hi = mixture_quantiles([r.samples["modulus_mpa"] for r, _, _ in models],
                                            [w for _, _, w in models])
            quoted = [r.modulus_mpa["median"] for r, _, w in models if w >= QUOTED_WEIGHT] or \
                [models[0][0].modulus_mpa["median"]]
            bad = [label or film for r, label, _ in models if not r.diagnostics_ok]
            failed += [film] if bad else []
            cells += [f"{med:.0f} [{lo:.0f}, {hi:.0f}]", _span(quoted, "{:.0f}"),
                      _preference(film, models, comparison)]
        else:
            cells += ["not calibrated", "", ""]
        ref = _reference_row(curves.get(film, []))
        if ref is None:
            cells += ["not computed", ""]
        else:
            ref_case = ref
            cells += [f"{ref['ratio_median']:.3f} [{ref['ratio_lo']:.3f}, {ref['ratio_hi']:.3f}]",
                      f"{ref['delta_area_median_mm2']:.1f} [{ref['delta_area_lo_mm2']:.1f}, "
                      f"{ref['delta_area_hi_mm2']:.1f}]"]
        rows.append(cells)
    where = ("the reference case" if ref_case is None else
             f"S1002 wheel ({ref_case['wheel']}) on 60E2 rail, F = {ref_case['force_kn']:g} kN, "
             f"η = {F.signed_offset(ref_case['offset_mm'])} mm")
    table = Table(["film", "E (MPa), models combined: median [90 %]",
                   f"E medians of the models weighing ≥ {QUOTED_WEIGHT:g} (MPa)",
                   "preferred imprint model (weight; ELPD lead ± SE)",
                   "correction factor A(no film)/A(film), median [90 %]",
                   "area added by the film ΔA (mm²), median [90 %]"], rows,
                  f"The answer per film type: calibrated film modulus E, and the correction at {where}")
    remarks = ["Multiply a measured imprint area by the correction factor to obtain the contact area without "
               "film. Cite the combined E and the correction factor: where the study compared imprint models "
               "(what the film records), each enters with its weight, and the 90 % interval is the posterior "
               "uncertainty of E carried through the wheel-rail model (section 'Wheel-rail correction curves' "
               "gives every offset and load computed). The span of the models' medians shows how much the "
               "choice of model would move E; the preferred model's weight and its lead in ELPD-LOO over the "
               "next best model (with the standard error of the difference) say how clearly the data choose it "
               "(section 'What the film records')."]
    if posteriors and not failed:
        remarks.append("The sampler's diagnostics (R-hat, effective sample sizes) passed for every model combined.")
    if failed:
        remarks.append(f"Sampler diagnostics FAILED for {', '.join(failed)}: the chains are too short or not "
                       "mixed (see the calibration sections and the glossary); the numbers are provisional and "
                       "a longer run is needed before they are used.")
    return table, remarks


def summary_section(posteriors: dict, curves: dict) -> Section:
    """Posterior per film and the range of the wheel-rail corrections over the offsets."""
    s = Section("Summary")
    nu = _fixed_poisson(posteriors)
    nu_text = f", with Poisson's ratio fixed at {nu:g}" if nu is not None else ""
    s.add("A Prescale film between two bodies prints a contact patch larger than the contact without film. This "
          f"report calibrates a finite-element model of the film (its Young's modulus E{nu_text}) against the "
          "Hertzian sphere-on-flat experiments of Table 1 for each film type, and propagates the posterior "
          "through a wheel-rail model (S1002 wheel on a 60E2 rail inclined 1:40) into correction curves with "
          "90 % credible bands.")
    rows = []
    for film, (r, *_) in posteriors.items():
        p = r.predictive
        rows.append([film, _ci(r.modulus_mpa), _ci(r.oedometric_modulus_mpa), f"{r.sigma_mm['median']:.3f}",
                     f"{r.rhat_max:.4f}", f"{r.ess_min:.0f}", "pass" if r.diagnostics_ok else "FAILED",
                     f"{int(np.sum(~p.outside))} of {len(p.outside)}"])
    if rows:
        s.add(Table(["film", "E (MPa), median [90 %]", "M (MPa), median [90 %]", "scatter σ (mm), median",
                     "worst R-hat", "worst bulk ESS", "diagnostics", "Table 1 cases inside the 90 % PPI"], rows,
                    "Posterior per film type (all loads of Table 1); PPI: posterior predictive interval"))
    rows = []
    for film, c in curves.items():
        for wheel in dict.fromkeys(r["wheel"] for r in c):
            for force in sorted({r["force_kn"] for r in c}):
                sel = [r for r in c if r["wheel"] == wheel and r["force_kn"] == force]
                rows.append([film, wheel, f"{force:g}", _span([r["offset_mm"] for r in sel], "{:+g}"),
                             _span([r["delta_area_median_mm2"] for r in sel], "{:.1f}"),
                             _span([r["ratio_median"] for r in sel], "{:.3f}"),
                             f"{max(r['ratio_hi'] - r['ratio_lo'] for r in sel):.3f}",
                             f"{100 * max(r['interpolation_error_rel'] for r in sel):.3f}"])
    if rows:
        s.add(Table(["film", "wheel", "F (kN)", "offsets η (mm), range", "ΔA median (mm²), range over offsets",
                     "A0/A median, range over offsets", "widest 90 % band of A0/A", "propagation error (% of A)"],
                    rows, "Wheel-rail corrections: the smallest to the largest posterior median over the offsets "
                          "computed (ranges over offsets, not credible intervals)"))
    s.add("E and ν are not separately identifiable from contact areas: a thin film held laterally is compressed "
          "nearly oedometrically, so the radius depends on (E, ν) through M = E(1-ν)/((1+ν)(1-2ν)). With ν "
          "fixed, the calibrated E stands for M; any (E, ν) pair with the same M gives the same correction.")
    return s


def _reference_checks(doc: dict | None = None) -> list:
    """The shipped summary of `bench/verification.py` (or `doc`, one of its form): every model against its
    independent reference."""
    from importlib import resources

    from filmcal.contact.names import APPLICATION_MODEL_REVISION, FE_MODEL_REVISION

    try:
        if doc is None:
            doc = json.loads((resources.files("filmcal.data") / "verification.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return ["The summary of the independent references (filmcal/data/verification.json) is missing or "
                "unreadable: run python bench/verification.py --summary."]
    def small(value: float, unit: str, signed: bool) -> str:  # below the table's last digit: said so, unsigned
        return (f"< 0.0001 {unit}" if abs(value) < 5e-5 else f"{value:+.4f} {unit}" if signed
                else f"{value:.4f} {unit}")

    rows = [[c["check"], c["reference"], str(c["n"]), small(c["mean"], c["unit"], True),
             small(c["max_abs"], c["unit"], False),
             "< 0.001" if c["max_abs_rel_pct"] < 5e-4 else f"{c['max_abs_rel_pct']:.3f}"] for c in doc["checks"]]
    rows += _transfer_check_rows(doc.get("transfer", []))
    for i, g in enumerate(doc.get("grid", [])):
        rows.append([f"grid convergence, {g['reading']}",
                     ("the reading's own limit in the grid (Richardson, from 0.1 / 0.05 / 0.025 mm, each the mean of "
                      "four phases of the grid): the HS film's solutions on S1002/60E2, 50/100 kN, η -5..+2 mm, "
                      "E 800-6300 MPa; a level reading at the named film's levels; in the mean's column the median "
                      "observed order" if i == 0 else "as above"), str(g["n"]),
                     f"order {g['order_median']:.2f} ({g['orders_in_1.5_2.5']} of {g['n_fine']} in 1.5-2.5)", "",
                     f"{g['max_error_at_0.1_pct']:.3f} at 0.1 mm"])
    for i, t in enumerate(doc.get("table1", [])):
        film, model, modulus = (str(t.get("case", "")).split() + ["?", "?", "?"])[:3]  # "MS edge/large E539"
        rows.append([f"Table 1 through the application, {film}",
                     ("the paper's Table 1: the measured radius minus the application's at the film's median E and "
                      "preferred model of a full study on the paper's data; in brackets in the next columns, the "
                      "calibration's FE at that E" if i == 0 else "as above")
                     + f" (here {model}, {modulus.removeprefix('E')} MPa)", "10",
                     f"{t['mean_residual_mm']:+.4f} mm (FE {t['calibration_mean_residual_mm']:+.4f})",
                     f"rms {t['rms_mm']:.4f} mm (FE {t['calibration_rms_mm']:.4f})", ""])
    stale = [name for name, key, now in (("FE", "fe_model_revision", FE_MODEL_REVISION),
                                         ("wheel-rail", "application_model_revision", APPLICATION_MODEL_REVISION))
             if doc.get(key) != now]
    text = (f"Every contact model against an independent reference, as python bench/verification.py --summary "
            f"measured it on {doc['made']}"
            + (f" for an earlier revision of the {' and the '.join(stale)} model: run it again." if stale else
               f" (FE revision {FE_MODEL_REVISION} and wheel-rail revision {APPLICATION_MODEL_REVISION}, this "
               "report's).")
            + " Differences are the model's minus the reference's, in radius (mm) or area (mm²); but the transfer "
              "rows give the calibrated FE film's radius minus the applied film's, with the readings' rms beside the "
              "band that the wheel-rail answers carry as their transfer term's spread, and the Table 1 rows the "
              "measured radius minus the application's, with the rms in the column of the largest difference.")
    table = Table(["check", "reference", "cases", "mean difference", "largest |difference|", "largest |rel.| (%)"],
                  rows, "Every model against its independent reference")
    if per_film := doc.get("transfer_per_film"):
        table = [table, "The transfer's systematic term left per film, at the 0.09 mm films' points of both designs "
                 "(the mean residual of each reading and kinematics, the signed term a band would have to carry): "
                 + "; ".join(f"{f['film']} {f['mean_min_mm']:+.4f}..{f['mean_max_mm']:+.4f} mm over {f['n']} readings "
                             f"(the largest miss {f['max_mm']:.4f} mm)" for f in per_film)
                 + (f". The largest mean, {worst:.4f} mm, is below the narrowest band the answers carry "
                    f"({band:.4f} mm), as a spread: there is no shift to add."
                    if (worst := max(max(abs(f["mean_min_mm"]), abs(f["mean_max_mm"])) for f in per_film))
                    < (band := min((t["std_mm"] for t in doc.get("transfer", [])), default=0.0)) else
                    f". The largest mean, {worst:.4f} mm, exceeds the narrowest band the answers carry ({band:.4f} "
                    "mm): a shift the bands do not hold.")]
    else:
        table = [table]
    if not (factor := doc.get("correction_factor")):
        return [text + " Table 1 through the application and the correction factor are given by a summary made "
                "with --study-dir; this one was not.", *table]
    return [text, *table, "The correction factor A0/A at S1002/60E2, 100 kN, η 0, in the same full study (each "
            "film's preferred model at its median E), before the film-aware readings and the transfer term and after "
            "them: "
            + "; ".join(f"{(str(c.get('case', '')).split() or ['?'])[0]} {c['before']:.4f} → {c['after']:.4f} (reading "
                        f"{c['reading_change_mm2']:+.2f} mm², transfer {c['transfer_shift_mm2']:+.2f} ± "
                        f"{c['transfer_std_mm2']:.2f} mm²)" for c in factor) + "."]


def _transfer_check_rows(transfer: list[dict]) -> list[list[str]]:
    """The transfer rows of the shipped summary, one row per set of points (Table 1's region, the whole domain,
    each film thickness) over its readings: the rows per reading, the range of their means, the largest miss, and in the
    reference the range of their rms against that of the band the answers carry, naming any reading whose rms
    is above its band."""
    from filmcal.contact.transfer import load_transfer_fit

    groups: dict[str, list[dict]] = {}
    for t in transfer:  # t["check"]: "transfer <model>[, whole domain | , <thickness> mm]"
        groups.setdefault(t["check"].partition(", ")[2] or "Table 1's region", []).append(t)
    fit = load_transfer_fit()
    (t0, t1) = fit.domain["thickness_mm"]

    def span(values, signed: bool) -> str:
        lo, hi = (0.0 if abs(v) < 5e-5 else v for v in (min(values), max(values)))  # no "-0.0000"
        f = "{:+.4f}" if signed else "{:.4f}"
        return f.format(lo) if f.format(lo) == f.format(hi) else f"{f.format(lo)}..{f.format(hi)}"

    rows = []
    for name, ts in groups.items():
        where = "the whole supported domain" if name == "whole domain" else name
        if found := re.fullmatch(r"([0-9.]+) mm", name):
            where = (f"a film of {name}, Table 1's region, " + (f"inside the fitted {t0:g}-{t1:g} mm"
                     if fit.fits_thickness(float(found.group(1))) else
                     f"beyond the fitted {t0:g}-{t1:g} mm: its answers say so"))
        reference = ("the calibrated FE film, sphere-on-flat off the fit's designs (raw: without the term), "
                     f"{len(ts)} readings; {where}" if not rows else f"as above; {where}")
        reference += (f"; rms {span([t['rms_mm'] for t in ts], False)}, band "
                      f"{span([t['std_mm'] for t in ts], False)} mm")
        if above := [t["check"].split()[1].rstrip(",") for t in ts if t["rms_mm"] > t["std_mm"]]:
            reference += f"; above its band: {', '.join(above)}"
        n = sorted({t["n"] for t in ts})  # rows per reading (points x films), over the readings
        rows.append([f"transfer, {name}", reference, f"{n[0]}{f'-{n[-1]}' if len(n) > 1 else ''} × {len(ts)}",
                     f"{span([t['mean_mm'] for t in ts], True)} mm (raw {span([t['raw_mean_mm'] for t in ts], True)})",
                     f"{max(t['max_mm'] for t in ts):.4f} mm", ""])
    return rows


def verification_section(v: dict | None) -> Section:
    """FE without film against Hertz, pressure profiles, and the surrogate against new FE solves."""
    s = Section("FE model verification")
    if v is None:
        return _missing(s, "fe-verification.json")
    rows = [[f"R{r['sphere_radius_mm']:g}", f"{r['force_n'] / 1e3:g}", f"{r['hertz_radius_mm']:.4f}",
             f"{r['fe_radius_mm']:.4f}", f"{100 * (r['fe_radius_mm'] / r['hertz_radius_mm'] - 1):+.3f}"]
            for r in v["hertz"]]
    s.add("Without film the axisymmetric FE model (two steel bodies) must reproduce Hertz's contact radius "
          "a = (3FR/(4E*))^(1/3) at the ten (R, F) cases of Table 1.",
          Table(["sphere", "F (kN)", "a Hertz (mm)", "a FE (mm)", "error (%)"], rows, "FE without film against Hertz"),
          FigureBlock(F.plot_hertz_verification(v["hertz"]), "Relative error of the FE contact radius without "
                      "film against Hertz, per Table 1 case.", "FE without film against Hertz"))
    s.add(*_reference_checks())
    case = v["profile_case"]
    s.add(FigureBlock(F.plot_pressure_profiles(v["profiles"], case["sphere_radius_mm"], case["force_n"]),
                      "Contact pressure without film (against Hertz) and with each film at its posterior median E: "
                      "the film lowers the peak and widens the patch.",
                      "Contact pressure without and with film"))
    worst, inside, n = 0.0, 0, 0
    for d in v["films"].values():
        for r in d["cases"]:
            diff = abs(r["surrogate_mean_mm"] - r["fe_radius_mm"])
            worst = max(worst, diff)
            inside += diff <= F.Z90 * r["surrogate_std_mm"]
            n += 1
    s.add(f"The surrogate used by the calibration is checked against new FE solves at each film's posterior "
          f"median: largest difference {1e3 * worst:.1f} µm in radius, {inside} of {n} FE radii inside the "
          "surrogate's 90 % interval.",
          FigureBlock(F.plot_surrogate_at_medians(v["films"]), "Surrogate minus FE radius at the posterior medians, "
                      "with the surrogate's 90 % interval, per case and film.",
                      "Surrogate against new FE solves at the posterior medians"))
    return s.add(*_transfer_blocks())


def _transfer_blocks() -> list:
    """The shipped transfer fit's held-out check (filmcal/data/film_transfer.json)."""
    from filmcal.contact.transfer import load_transfer_fit
    from filmcal.correction.transfer import RMS_BOUND_CONFIDENCE

    fit = load_transfer_fit()
    held = fit.provenance.get("held_out") or {}
    rows = [[key, f"{r['n']}", f"{1e3 * r['raw_mean_mm']:+.1f}", f"{1e3 * r['raw_max_mm']:.1f}",
             f"{1e3 * r['mean_mm']:+.1f}", f"{1e3 * r['rms_mm']:.1f}", f"{1e3 * r['max_mm']:.1f}",
             f"{1e3 * fit.std_mm[key]:.1f}"] for key, r in sorted(held.items())]
    text = ("From calibration to application. The calibration runs the continuum FE film; every wheel-rail "
            "answer runs the film as springs in series with the half-spaces. Both solve the same sphere on a "
            "flat at equal film parameters at held-out points over E 400-20000 MPa, ν 0.25-0.45 and the supported "
            "spheres and forces (R 250-600 mm at 20-110 kN, Table 1's region, and R 150-1500 mm at 9-165 kN within "
            "the steel's elastic limit; MS, HS and HHS thresholds; made "
            f"{fit.provenance.get('made', '?')} by scripts/fit-transfer). Without the transfer term the springs' "
            "imprint lies outside the calibrated film's; with it the two agree to the residual shown, which "
            "every wheel-rail band carries as the term's standard deviation.")
    if by_t := fit.thickness_rms_mm:
        edges = by_t["edges_mm"]
        raised = [(by_t[key][k], key, edges[k], edges[k + 1]) for key in sorted(fit.std_mm)
                  for k in range(len(edges) - 1) if by_t[key][k] > fit.std_mm[key]]
        if raised:
            top = max(raised)
            text += (f" The std carried holds every third of the fitted film thicknesses "
                     f"({edges[0]:g}-{edges[-1]:g} mm); a film off the built-in films' thickness whose ninth of "
                     f"them was missed by more carries the {100 * RMS_BOUND_CONFIDENCE:.0f} % upper bound of that "
                     f"ninth's rms from its points instead ({len(raised)} of the {len(fit.std_mm)} models' "
                     f"{(len(edges) - 1) * len(fit.std_mm)} ninths; the largest {1e3 * top[0]:.1f} µm: {top[1]} on "
                     f"films of {top[2]:.3f}-{top[3]:.3f} mm).")
    return [text, Table(["model", "points", "raw mean (µm)", "raw max |d| (µm)", "with term: mean (µm)", "rms (µm)",
                         "max |d| (µm)", "std carried (µm)"], rows,
                        "Transfer term: calibrated FE film minus applied film springs, imprint radius, held out")]


def preliminary_section(model, modulus_range_mpa: tuple[float, float]) -> Section:
    """The paper's Fig. 2: contact area over E and over M for several Poisson's ratios."""
    s = Section("Preliminary study: E and ν (Fig. 2)")
    if model is None:
        return _missing(s, "the radius surrogate")
    s.add("As in the paper's Fig. 2, the contact area of the film model over the film's Young's modulus for "
          "several Poisson's ratios, at R300 / 25 kN and R600 / 100 kN (from the validated surrogate, 90 % "
          "bands). Over the oedometric modulus M the curves of different ν fall on one another: M is what the "
          "areas identify.",
          FigureBlock(F.plot_preliminary_study(model, modulus_range_mpa=modulus_range_mpa),
                      "Contact area against E (left) and M (right) for ν = 0.29, 0.33, 0.37.",
                      "Contact area against E and M (Fig. 2)"))
    return s


def design_section(design: DesignData | None, config_settings: dict | None = None) -> Section:
    """Design quality metrics and the pairs plot of the FE campaign in physical units."""
    s = Section("Design of the FE campaign")
    if design is None:
        return _missing(s, "design.json")
    m = design.metrics
    rows = []
    for key, label in (("min_distance", "smallest distance between points (larger is better)"),
                       ("phi_p", "φp space-filling criterion, p = 50 (smaller is better)"),
                       ("centered_l2", "centred L2 discrepancy (smaller is better)"),
                       ("max_abs_correlation", "largest |correlation| between columns (smaller is better)")):
        rows.append([label] + [f"{m[part][src][key]:.4g}" for part in ("train", "test")
                               for src in ("quality", "random_lhs_median")])
    s.add(f"Optimal Latin hypercubes (enhanced stochastic evolutionary search on φp) over log E, ν, the five "
          f"sphere radii (discrete levels) and F: {m['train']['n']} training and {m['test']['n']} held-out FE "
          "runs, each compared with the median of ten plain random Latin hypercubes of the same size"
          + (f"; the training runs are joined by {cases} at each of the data's (R, F) cases, at moduli spread "
             "over the prior's range (not shown)" if (cases := (config_settings or {}).get("moduli_per_case"))
             else "") + ". The "
          "metrics are computed in the unit cube (each input scaled to 0-1, E in log); the figure shows the "
          "points in physical units.",
          Table(["metric (unit cube)", "training", "random LHS", "held out", "random LHS"], rows,
                "Design quality against plain random Latin hypercubes"),
          FigureBlock(F.plot_design(design.labels, design.train, design.test, design.log_scale, design.levels),
                      "Pairwise projections of the training (dots) and held-out (crosses) FE runs in physical "
                      "units; diagonal: number of runs per bin (stacked: training, held out).",
                      "Design points in physical units"))
    return s


def surrogate_section(v: dict | None, radius_model=None) -> Section:
    """Held-out validation of the Gaussian-process surrogate (`radius_model`: the same surrogate, for its output
    transform)."""
    s = Section("Surrogate validation")
    if v is None:
        return _missing(s, "surrogate-validation.json")
    m = v["summary"]
    surrogate = getattr(radius_model, "surrogate", None)
    transform = getattr(surrogate, "output_transform_", None)
    kind = {"log": "in log", "standardize": "standardised"}.get(transform.kind if transform else None, "")
    rule = ("whichever gives the excesses the larger evidence" if surrogate is not None
            and surrogate.get_params().get("output_transform") == "auto" else "log while every excess is positive")
    s.add("A Gaussian process (Matérn kernel, fitted FE noise) of the film's radius excess over Hertz, over log "
          f"inputs, its output in log or standardised ({rule}{': here ' + kind if kind else ''}); checked on "
          "held-out FE runs of the second design.",
          Table(["held-out runs", "RMS radius error (mm)", "max radius error (mm)", "RMS area error (%)",
                 "max area error (%)", "inside the 90 % interval", "Q2"],
                [[str(m["n"]), f"{m['radius_rms_error_mm']:.4f}", f"{m['radius_max_error_mm']:.4f}",
                  f"{100 * m['area_rms_relative_error']:.3f}", f"{100 * m['area_max_relative_error']:.3f}",
                  f"{100 * m['coverage90']:.0f} %", f"{m['q2']:.6f}" if m["q2"] > 0.999 else f"{m['q2']:.4f}"]],
                "Surrogate against held-out FE runs"),
          FigureBlock(F.plot_surrogate_validation(v["points"]), "Held-out FE runs against the surrogate: parity of "
                      "the radius excess over Hertz (top left), the surrogate's error with its 90 % interval (top "
                      "right) and the standardised errors against the standard normal density (bottom).",
                      "Surrogate against held-out FE runs"))
    return s


def calibration_section(film: str, result, source: str, model: str = "") -> Section:
    """Posterior, diagnostics, traces, pairs, predictive check and per-case E ranges of one film."""
    from filmcal.calibration.plots import (parameter_label, plot_case_intervals, plot_corner, plot_predictive,
                                           plot_trace)

    s = Section(f"Calibration of {film} film" + (f" (imprint model {model})" if model else ""))
    who = f"{film} ({model})" if model else film
    def with_error(value: float, name: str, key: str) -> str:
        error = result.mcse.get(name, {}).get(key)
        return f"{value:.4g}" if error is None else f"{value:.4g} ± {error:.2g}"

    rows = [[parameter_label(name), with_error(np.median(v), name, "median"),
             with_error(np.quantile(v, 0.05), name, "q05"), with_error(np.quantile(v, 0.95), name, "q95"),
             f"{result.rhat.get(name, np.nan):.4f}",
             f"{result.ess_bulk.get(name, np.nan):.0f}", f"{result.ess_tail.get(name, np.nan):.0f}"]
            for name, v in ((k, np.asarray(v).ravel()) for k, v in result.samples.items())]
    verdict = ("pass" if result.diagnostics_ok else "FAIL: " + "; ".join(result.diagnostics.messages))
    s.add(f"emcee ensemble sampler, {result.n_walkers} walkers × {result.n_steps} steps (burn-in {result.burn_in}, "
          f"thinning {result.thin}), acceptance {result.acceptance_fraction:.2f}; {result.n_data} measured radii of "
          f"Table 1; the scatter σ is inferred. Diagnostics {verdict} (required: R-hat ≤ "
          f"{result.diagnostics.max_rhat}, bulk ESS ≥ {result.diagnostics.min_ess:.0f}). Each quantile is given "
          "± its Monte Carlo standard error: how far it could move if the chain were run again, not the "
          "posterior's width.",
          Table(["parameter", "median", "5 %", "95 %", "R-hat", "bulk ESS", "tail ESS"], rows,
                f"Posterior of {film} (file {source})"))
    for note in result.notes:
        s.add(note)
    s.add(FigureBlock(plot_trace(result), f"{film}: traces of the kept samples per walker and their histograms.",
                      f"{who}: posterior traces"),
          FigureBlock(plot_corner(result), f"{film}: pairwise posterior samples and marginal histograms.",
                      f"{who}: posterior pairs"))
    p = result.predictive
    rows = [[f"R{r:g}", f"{f / 1e3:g}", f"{m - h:+.3f}", f"{mu - h:+.3f}", f"[{lo - h:+.3f}, {hi - h:+.3f}]",
             "no" if out else "yes"]
            for r, f, m, h, mu, lo, hi, out in zip(p.sphere_radius_mm, p.force_n, p.measured_radius_mm,
                                                   p.hertz_radius_mm, p.mean_mm, p.lower_mm, p.upper_mm, p.outside)]
    s.add(Table(["sphere", "F (kN)", "Table 1 error (mm)", "predicted (mm)", "90 % PPI (mm)", "inside"], rows,
                f"Posterior predictive check of {film} against Table 1 (radius errors a − a Hertz)"),
          FigureBlock(plot_predictive(result), f"{film}: Table 1's radius errors against the posterior predictive "
                      "90 % intervals.", f"{who}: posterior predictive check against Table 1"),
          FigureBlock(plot_case_intervals(result), f"{film}: the paper's Fig. 3 in kind: per case, the range of E "
                      "that reproduces the measured radius within the inferred scatter, beside the pooled "
                      "posterior.", f"{who}: E reproducing each case (Fig. 3)"))
    return s


_IMPRINT_TEXT = (
    "A Prescale film colours where its microcapsules break, not where contact begins. Three readings of the "
    "same FE pressure field are calibrated and compared: edge, where the contact pressure falls to zero (read "
    "without the bias of the mesh); activation, the contour where the pressure equals the film type's "
    "activation pressure (the lower end of its measurement range: MS 10, HS 50, HHS 130 MPa); capsule, the "
    "expected coloured area when the capsules' burst strengths are spread log-normally over the measurement "
    "range (2 % of them break at its lower end, 98 % at its upper end). Each is calibrated with a small-strain "
    "(linear) and a large-strain (neo-Hookean) film. The same model reads the wheel-rail pressure field in "
    "the correction, and the transfer term (section on the wheel-rail model) adds what the wheel-rail model's "
    "film springs miss of the calibrated continuum film, so the film is read alike where it is calibrated and "
    "where it is used.")


def _case_verdict(v: dict, radius_mm: float = 600.0, force_kn: float = 25.0) -> str:
    """The standardised residual of one case (R600/25 kN) under a model, and whether it is inside 90 %."""
    cases = v.get("cases") or {}
    for r, f, z, inside in zip(cases.get("sphere_radius_mm", []), cases.get("force_kn", []),
                               cases.get("standardized_residual", []), cases.get("inside_90", [])):
        if abs(r - radius_mm) < 1e-6 and abs(f - force_kn) < 1e-6:
            return f"{z:+.2f} ({'in' if inside else 'out'})"
    return ""


def film_records_section(comparison: dict | None, curves: dict | None = None) -> Section:
    """What the film records: imprint models, their comparison by evidence, roughness and its effect.

    `comparison` is film -> the study's comparison of that film's models
    (``filmcal.calibration.compare_models`` with each model's posterior
    summary and per-case residuals), or None when the study did not compute
    it; `curves` are film -> curve rows (smooth and rough wheel).
    """
    s = Section("What the film records")
    s.add(_IMPRINT_TEXT)
    if comparison is None:
        return s.add("Not computed in this study: the film's imprint models were not compared (the pipeline "
                     "writes the comparison when more than one model is calibrated per film).")
    rows, verdicts = [], []
    for film, d in comparison.items():
        if not isinstance(d, dict):
            continue
        weights = d.get("weights") or {}
        stacking = d.get("stacking_weights") or {}
        elpd = d.get("elpd_loo") or {}
        refits = {row.get("name"): row.get("n_refit", 0) for row in d.get("table") or [] if isinstance(row, dict)}
        se = {row.get("name"): row.get("se") for row in d.get("table") or [] if isinstance(row, dict)}
        for model, v in (d.get("models") or {}).items():
            if not isinstance(v, dict):
                continue
            e = v.get("modulus_mpa")
            rows.append([film, model, _ci(e) if isinstance(e, dict) and "ci90" in e else "",
                         _fmt(v.get("rms_residual_mm"), "{:.3f}"),
                         f"{v.get('ppc_inside_90', '')}/{v.get('n_data', '')}",
                         _fmt(elpd.get(model, v.get("elpd_loo")), "{:.1f}")
                         + (f" ± {se.get(model, v.get('elpd_loo_se')):.1f}"
                            if isinstance(se.get(model, v.get("elpd_loo_se")), (int, float)) else ""),
                         _fmt(v.get("pareto_k_max"), "{:.2f}") + (f" ({refits[model]} refit)" if refits.get(model)
                                                                   else ""),
                         f"{_fmt(stacking.get(model), '{:.2f}')} / {_fmt(weights.get(model), '{:.2f}')}",
                         _case_verdict(v)])
        preferred = d.get("preferred", "")
        sharing = sorted((m for m, w in weights.items() if m != preferred and w >= 0.1), key=lambda m: -weights[m])
        p = (d.get("models") or {}).get(preferred, {})
        verdicts.append(
            f"{film}: the data prefer {preferred} (weight {weights.get(preferred, 0):.2f})"
            + (f"; {', '.join(f'{m} ({weights[m]:.2f})' for m in sharing)} keep a share the data cannot take "
               "from them" if sharing else "")
            + (f"; {d['n_refit']} leave-one-out term(s) refitted exactly" if d.get("n_refit") else "")
            + f". R600/25 kN under {preferred}: standardised residual {_case_verdict(p) or 'n/a'}."
            + _unused_models(d))
    if rows:
        s.add(Table(["film", "model", "E (MPa) [90 %]", "RMS (mm)", "in 90 % PPI", "ELPD-LOO ± se",
                     "max Pareto k", "weight: stacking / used (pseudo-BMA+)", "R600/25 kN z"], rows,
                    "Each film under each model (imprint model / film kinematics): fit (RMS residual, cases "
                    "inside their 90 % posterior predictive interval), leave-one-out predictive accuracy (cases "
                    "of Pareto k above 0.7 refitted exactly), the stacking weight and the weight the correction "
                    "uses, and the standardised residual of R600/25 kN"))
        s.add(" ".join(verdicts) + " The weights the correction uses are pseudo-BMA+ (Bayesian-bootstrap "
              "averaged exp(ELPD)): smooth in the ELPD differences, so models the data cannot tell apart share "
              "the weight and a model a little behind keeps a little, without a cut-off; stacking, whose "
              "optimum for indistinguishable models is a corner, is shown beside them. The correction uses "
              "the mixture, and its 90 % band contains the median of every model of weight 0.1 or more.")
    if curves:
        growth = []
        for film, rows_ in curves.items():
            smooth = {(r["force_kn"], r["offset_mm"]): r for r in rows_ if r["wheel"] == "smooth"}
            for r in rows_:
                k = (r["force_kn"], r["offset_mm"])
                if r["wheel"] != "smooth" and k in smooth:
                    growth.append([film, r["wheel"].replace("rough ", ""), f"{r['force_kn']:g}",
                                   f"{F.signed_offset(r['offset_mm'])}",
                                   f"{smooth[k]['area_film_median_mm2']:.1f}", f"{r['area_film_median_mm2']:.1f}",
                                   f"{100 * (r['area_film_median_mm2'] / smooth[k]['area_film_median_mm2'] - 1):+.1f}",
                                   f"{100 * (r['area_no_film_mm2'] / smooth[k]['area_no_film_mm2'] - 1):+.1f}",
                                   f"{100 * (r['ratio_median'] / smooth[k]['ratio_median'] - 1):+.1f}",
                                   f"[{r['ratio_lo']:.3f}, {r['ratio_hi']:.3f}]" if "ratio_lo" in r else "-",
                                   _share(r, "roughness_share", 1.0, 2)])
        if growth:
            s.add("Roughness acts through the film-wheel interface: a synthetic steel surface of the wheel's Ra "
                  "(self-affine) is pressed into the film by periodic FFT boundary elements, with asperity "
                  "pressures capped at the coating's hardness; its pressure-closure law acts in series with the "
                  "film and spreads the nominal pressure. The film records where the asperities colour it: the "
                  "imprint is read where the coloured fraction reaches the scan's reading level (real contact "
                  "for the edge model, local pressures above the activation pressure for the activation model). "
                  "A coating softer than a film's activation pressure cannot be stained by single asperities, so "
                  "HHS barely grows while MS and HS do, as the paper observed on its roughened flat. The "
                  "inputs (hardness, reading level, spectrum) are drawn from stated priors and conditioned on "
                  "that observation (filmcal/data/roughness_inputs.json); each posterior sample of the rough "
                  "curves is paired with one conditioned draw (its growths with and without film, solved at the "
                  "film's posterior median modulus), so their bands carry the draws' spread, as "
                  "filmcal correct --wheel-roughness-ra-um does. The table gives the growth of the medians "
                  "the curves show.")
            s.add(Table(["film", "wheel", "F (kN)", "eta (mm)", "recorded area, smooth (mm²)", "rough (mm²)",
                         "imprint growth (%)", "growth without film (%)", "correction factor change (%)",
                         "rough A0/A 90 %", "roughness share"],
                        growth, "Recorded (imprint) area with film, posterior medians, smooth against rough wheel; "
                                "the growth of the contact without film (its nominal area) and what both do to the "
                                "correcting factor A(no film)/A(film), with the rough factor's 90 % band over the "
                                "posterior and the roughness draws and the roughness share of its variance"))
            s.add(_rough_flat_table())
    return s


def _share(row: dict, key: str, scale: float, digits: int) -> str:
    """A roughness column of a curve row ('-' on smooth bodies, or in curves written before the column)."""
    if row.get("wheel") == "smooth" or key not in row or row[key] in ("", None) or math.isnan(float(row[key])):
        return "-"  # smooth, written before the column, or not known (the MC error of one draw)
    return f"{scale * float(row[key]):.{digits}f}"


def _unused_models(d: dict) -> str:
    """The sentence that says why the models of zero weight have no calibration section (empty if none)."""
    weights = d.get("weights") or {}
    unused = [m for m in (d.get("models") or {}) if not weights.get(m, 0.0) > 0]
    if not unused:
        return ""
    return (f" {', '.join(unused)} {'has' if len(unused) == 1 else 'have'} no calibration section: weight 0 (the "
            "correction does not use them); their fit is in the table above.")


def _rough_flat_table():
    """The shipped roughness inputs' sphere-on-flat growth: prior-predictive against conditioned."""
    from filmcal.contact.rough_imprint import _shipped

    tables = _shipped()["tables"]
    rows = []
    for ra, by_film in tables["conditioned"].items():
        for film, cond in by_film.items():
            prior = tables["prior_predictive"][ra][film]
            rows.append([ra, film] + [f"{t['mean_pct']:+.1f} [{t['ci90_pct'][0]:+.1f}, {t['ci90_pct'][1]:+.1f}]"
                                      for t in (prior, cond)])
    return Table(["flat Ra (µm)", "film", "prior-predictive growth (%)", "conditioned growth (%)"], rows,
                 "Imprint growth on sphere-on-flat (R450, 50 kN) with the flat roughened, each film at its calibrated "
                 "median under its preferred model: mean and 90 % interval over the roughness inputs drawn from "
                 "their prior and after conditioning on the paper's observation (MS and HS grew, HHS did not)")


def _fmt(value, fmt: str) -> str:
    return fmt.format(value) if isinstance(value, (int, float)) and not isinstance(value, bool) else ""


def _crossval_method(cv) -> str:
    method = getattr(cv, "method", "refit")
    if method == "psis":
        return (f" (Pareto-smoothed importance sampling of the full posterior; {cv.n_refits} of {len(cv.inside)} "
                "folds refitted exactly where Pareto k > 0.7)")
    return " (every fold calibrated anew)"


def crossval_section(results: dict) -> Section:
    """Leave-one-case-out cross-validation of the sphere correction on Table 1."""
    s = Section("Leave-one-case-out cross-validation on Table 1")
    if not results:
        return _missing(s, "crossval-<film>.json")
    s.add("Can the correction be trusted on a case it has not seen? Each (R, F) case of Table 1 is held out in "
          "turn: the film is calibrated on the other cases, the held-out case's measured radius is corrected, "
          "and the Hertz area (the truth of these experiments) should lie in the corrected 90 % interval in "
          "about 9 of 10 cases.",
          FigureBlock(F.plot_crossval(results), "Corrected area of each held-out case relative to the Hertz area, "
                      "with its 90 % interval.", "Cross-validated corrections against Hertz"))
    for film, cv in results.items():
        s.add(Table(["sphere", "F (kN)", "measured r (mm)", "E of fold (MPa)", "corrected A (mm²)", "90 % interval",
                     "Hertz A (mm²)", "inside"],
                    [[f"R{r:g}", f"{f / 1e3:g}", f"{m:.3f}", f"{e:.0f}", f"{a:.1f} ± {sd:.1f}",
                      f"[{ci[0]:.1f}, {ci[1]:.1f}]", f"{h:.1f}", "yes" if ok else "NO"]
                     for r, f, m, e, a, sd, ci, h, ok in zip(cv.sphere_radius_mm, cv.force_n, cv.measured_radius_mm,
                                                             cv.modulus_median_mpa, cv.area_mm2, cv.area_std_mm2,
                                                             cv.area_ci90_mm2, cv.hertz_area_mm2, cv.inside)],
                    f"{film}: Hertz area inside the corrected 90 % interval in {cv.hits} of {len(cv.inside)} cases"
                    + _crossval_method(cv)))
    return s


def elastic_limit_note(curves: dict) -> str:
    """What the curves' contacts without film say about the elastic model's validity (as `filmcal correct`
    warns above the steel's elastic limit)."""
    from filmcal.hertz import ELASTIC_LIMIT_MPA

    rows = [r for rows in curves.values() for r in rows if "max_pressure_no_film_mpa" in r]
    if not rows:
        return ("These curves were computed before their contacts' peak pressures were kept: run `filmcal "
                "pipeline` again to check them against the steel's elastic limit.")
    top = max(rows, key=lambda r: r["max_pressure_no_film_mpa"])
    where = f"{top['max_pressure_no_film_mpa']:.0f} MPa at {top['force_kn']:g} kN, η = {F.signed_offset(top['offset_mm'])} mm"
    over = sorted({(r["force_kn"], r["offset_mm"]) for r in rows if r["max_pressure_no_film_mpa"] > ELASTIC_LIMIT_MPA})
    if not over:
        return (f"Validity: the contact without film stays below the steel's elastic limit of {ELASTIC_LIMIT_MPA:.0f} "
                f"MPa (a peak Hertz pressure the paper's specimens carried without plastic strain) in every row; "
                f"its highest peak is {where}.")
    cases = ", ".join(f"{f:g} kN / η = {F.signed_offset(e)} mm" for f, e in over)
    return (f"Warning: the contact without film exceeds the steel's elastic limit of {ELASTIC_LIMIT_MPA:.0f} MPa at "
            f"{cases} (highest {where}): there the elastic model is outside its validity and the real contact is "
            "larger (plastic); filmcal correct warns the same way.")


def wheel_rail_section(curves: dict, outlines: dict | None, earlier: list[str] = (),
                       transfer_notes: dict | None = None) -> Section:
    """Correction curves (Fig. 6), the correction factor, the tables per film and the outlines (Fig. 7);
    `earlier` names the files an earlier revision of the wheel-rail model made; `transfer_notes` (film -> text)
    where a film's transfer to the wheel-rail model is extrapolated."""
    from filmcal.contact.names import APPLICATION_MODEL_REVISION

    s = Section("Wheel-rail correction curves (Figs. 6 and 7)")
    if not curves:
        return _missing(s, "curves-<film>.csv")
    if earlier:
        s.add(f"{', '.join(earlier)} {'was' if len(earlier) == 1 else 'were'} made by an earlier revision of the "
              f"wheel-rail model than this filmcal's (revision {APPLICATION_MODEL_REVISION}): run filmcal pipeline "
              "again to make them with this one.")
    s.add("Each film's posterior of E is propagated through the wheel-rail model (boundary elements on "
          "half-spaces, the film as springs in series, each imprint model reading the solved pressure): the film "
          "area is interpolated in log E from solves at three moduli spanning the posterior and checked by one "
          "more; the largest relative error of that interpolation is printed beside the bands. The springs "
          "have no lateral coupling, so the film the calibration ran (the continuum FE film) records a slightly "
          "smaller imprint: that transfer term, an edge offset fitted over (E, ν, R, F) and checked on held-out "
          "sphere-on-flat points (FE model verification), shifts every film area by its signed size (a few tenths "
          "of a percent smaller) and widens every band by its spread. Rough wheel: the boundary-element pressure-closure law "
          "of the film-wheel interface (What the film records) and the rough contact without film, computed "
          "from synthetic surfaces of the stated Ra for each of the draws of the inputs conditioned on the "
          "paper's roughened flat; each posterior sample is multiplied by one draw's rough/smooth growths, so "
          "the rough bands hold the inputs' spread. The tables give the share of the correction factor's "
          "variance that the roughness adds and the Monte-Carlo error of the draws' mean.")
    for film, rows in curves.items():
        s.add(FigureBlock(F.plot_area_curves(rows, film), f"{film}: contact area over the lateral offset without "
                          "film and with film (posterior median, 90 % band), smooth and rough wheel.",
                          f"{film}: contact area over the offset (Fig. 6)"))
    s.add(FigureBlock(F.plot_correction_factor(curves), "Correction factor A(no film) / A(film) that turns a "
                      "measured imprint area into the contact area, posterior medians and 90 % bands.",
                      "Correction factor over the offset"))
    for film, rows in curves.items():
        s.add(Table(["wheel", "F (kN)", "η (mm)", "A0 (mm²)", "ΔA median (mm²)", "ΔA 90 % (mm²)", "A0/A median",
                     "A0/A 90 %", "prop. error (%)", "roughness share", "MC error (%)"],
                    [[r["wheel"], f"{r['force_kn']:g}", f"{F.signed_offset(r['offset_mm'])}", f"{r['area_no_film_mm2']:.1f}",
                      f"{r['delta_area_median_mm2']:.1f}", f"[{r['delta_area_lo_mm2']:.1f}, {r['delta_area_hi_mm2']:.1f}]",
                      f"{r['ratio_median']:.4f}", f"[{r['ratio_lo']:.4f}, {r['ratio_hi']:.4f}]",
                      f"{100 * r['interpolation_error_rel']:.3f}", _share(r, "roughness_share", 1.0, 2),
                      _share(r, "roughness_mc_error_rel", 100.0, 2)] for r in rows],
                    f"{film}: correction curves (A0: area without film; ΔA: area added by the film; roughness "
                    "share: of the factor's variance; MC error: of the draws' mean change of the factor)"))
    s.add(elastic_limit_note(curves))
    for film, note in (transfer_notes or {}).items():
        s.add(f"Warning ({film}): {note[0].upper()}{note[1:]}; filmcal correct warns the same way.")
    if outlines is None:
        return _missing(s, "wheelrail-outlines.json")
    for film, m in outlines["films"].items():
        drawn = (f"its posterior median E = {m:.0f} MPa" if not isinstance(m, dict) else
                 f"the posterior median E = {m['modulus_mpa']:.0f} MPa of its preferred model {m['model']} "
                 f"({m['kinematics']}-strain film, as calibrated)")
        s.add(FigureBlock(F.plot_outlines(outlines, film), f"The paper's Fig. 7 in kind: contact outlines at "
                          f"{outlines['force_n'] / 1e3:g} kN without film (solid) and with {film} film at {drawn} "
                          "(dashed).", f"Contact outlines without and with {film} film (Fig. 7)"))
    return s


#: Terms of the report, explained for a reader who is not a statistician.
GLOSSARY: list[tuple[str, str]] = [
    ("E, M, ν", "The film's Young's modulus E, its Poisson's ratio ν and its oedometric (constrained) modulus "
     "M = E(1-ν)/((1+ν)(1-2ν)), the stiffness of a layer squeezed without lateral expansion. Contact areas "
     "identify M; E is quoted for the stated ν."),
    ("η (lateral offset)", "Lateral position of the wheel on the rail: 0 when the wheel's tape circle lies in the "
     "rail's inclined symmetry plane, positive towards the flange."),
    ("Correction factor A(no film)/A(film), A0/A", "The number a measured imprint area is multiplied by to "
     "obtain the contact area the wheel and rail have without film."),
    ("R-hat", "Compares the spread within each part of the Markov chains with the spread between parts. Close "
     "to 1 (here at most 1.01) when the sampler has forgotten its starting points; larger values mean the chains "
     "have not yet mixed and the posterior is not to be trusted."),
    ("ESS bulk / ESS tail", "Effective sample size: how many independent draws the correlated chain is worth, "
     "for the centre of the distribution (bulk, governs the median) and for its 5 % and 95 % quantiles (tail, "
     "governs the interval ends). A few hundred suffice for a median; the pipeline asks for more."),
    ("φp (phi_p)", "Space-filling criterion of a design: a smooth version of the smallest distance between "
     "points (p = 50 makes it close to the smallest distance). Smaller is better."),
    ("Centred L2 discrepancy", "How far the points' spread departs from a uniform spread over every "
     "sub-box of the unit cube. Smaller is more uniform."),
    ("Q2", "Predictivity coefficient on held-out runs: 1 − (sum of squared prediction errors) / (sum of squared "
     "deviations from their mean). 1 is perfect; 0 is no better than the mean."),
    ("Posterior predictive interval (PPI)", "The range in which a new measurement is expected with the stated "
     "probability (here 90 %), given the calibrated model and its measurement scatter. About 9 of 10 cases "
     "should fall inside a 90 % interval."),
    ("90 % credible interval / band", "The range that holds the quantity with 90 % posterior probability (5 % "
     "below, 5 % above); a band is this interval drawn along a curve. A range over offsets (smallest to "
     "largest value along a curve) is something else and is labelled as such."),
    ("ELPD-LOO", "Expected log predictive density under leave-one-out: how well a model predicts each "
     "measurement when that measurement is left out, summed over measurements. Higher is better; differences "
     "are read against their standard error."),
    ("Pareto k", "Reliability of the importance-sampling shortcut behind ELPD-LOO, per measurement: below 0.7 "
     "the shortcut is reliable; above, that measurement needs an exact refit."),
    ("Stacking weight", "The weight of each model in the mixture of models that predicts left-out "
     "measurements best; weights are between 0 and 1 and sum to 1."),
    ("Pseudo-BMA+ weight", "Each model's weight proportional to exp(ELPD-LOO), averaged over Bayesian-bootstrap "
     "resamplings of the measurements: models the data cannot tell apart share the weight, a model a little "
     "behind keeps a little. The weights the correction uses."),
    ("Transfer term", "The difference between the imprint of the film the calibration ran (continuum FE) and "
     "of the film the wheel-rail model applies (springs), at equal film parameters: a signed shift and a "
     "spread, both carried by every wheel-rail answer."),
]


def glossary_section() -> Section:
    """The glossary of statistical and engineering terms used in the report."""
    return Section("Glossary").add(Definitions(GLOSSARY))


def _git_commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=Path(__file__).parent, capture_output=True,
                             text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return out.stdout.strip() if out.returncode == 0 else "unknown (not a git checkout)"


def _installed(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "not installed"


def provenance_section(folder: Path, settings_hash: str, seed: int | None, films: list[str], settings: dict,
                       files: list[tuple[str, int, str]], problems: list[str], software: dict | None = None,
                       software_later: list | None = None) -> Section:
    """Software versions, the settings and the study folder's files with their checksums."""
    from filmcal._versions import __version__

    s = Section("Provenance")
    now = software_versions()
    made = software or {}
    later = [entry.get("software", {}) for entry in software_later or []]
    header = ["software", "made the study", *(f"later writer {i + 1}" for i in range(len(later))), "this report"]
    versions = [["filmcal", "", *("" for _ in later), __version__],
                ["filmcal git commit", "", *("" for _ in later), _git_commit()],
                ["platform", "", *("" for _ in later), platform.platform()]]
    for name in ("python", *NUMERIC_PACKAGES, "matplotlib"):
        current = now.get(name) or _installed(name)
        versions.append([name, made.get(name, "not recorded"), *(w.get(name, "") for w in later), current])
    note = version_note(software, now)
    s.add(Table(header, versions, "Software: the versions that made the study's numbers, and this report's"))
    if note:
        s.add(f"This study was {note}.")
    rows = [["settings hash", settings_hash], ["seed", str(seed)], ["films", ", ".join(films)]]
    rows += [[k, json.dumps(v)] for k, v in settings.items()]
    s.add(Table(["setting", "value"], rows, "Pipeline settings (the hash is that of the recorded settings)"))
    s.add(Table(["file", "size (KiB)", "SHA-256 (first 16)"],
                [[name, f"{size / 1024:.1f}", sha[:16]] for name, size, sha in files], f"Study folder {folder}"))
    if problems:
        s.add("Files that could not be read (their sections say 'not available'): " + "; ".join(problems))
    return s


def calibration_sections(data: StudyData, films: list[str] | None = None) -> list[Section]:
    """The calibration sections of each film's posteriors (of `films`, default every film of the study)."""
    out = []
    for film in data.films if films is None else films:
        if film in data.posteriors:
            chosen = [data.posteriors[film], *data.other_posteriors.get(film, [])]
            out += [calibration_section(film, *p) for p in chosen]
        else:
            out.append(_missing(Section(f"Calibration of {film} film"), f"posterior of {film}"))
    return out


#: The report's sections in order: each entry turns the study's data into one section.
SECTION_BUILDERS: list[Callable[[StudyData], Section | list[Section]]] = [
    lambda d: summary_section(d.posteriors, d.curves),
    lambda d: verification_section(d.verification),
    lambda d: preliminary_section(d.radius_model, d.modulus_range_mpa),
    lambda d: design_section(d.design, d.settings),
    lambda d: surrogate_section(d.surrogate_validation, d.radius_model),
    calibration_sections,
    lambda d: film_records_section(d.imprint_comparison, d.curves),
    lambda d: crossval_section(d.crossval),
    lambda d: wheel_rail_section(d.curves, d.outlines, d.earlier_application, d.transfer_notes),
    lambda d: glossary_section(),
    lambda d: provenance_section(d.folder, d.settings_hash, d.seed, d.films, d.settings, d.files, d.problems,
                                 d.software, d.software_later),
]


def _build_sections(data: StudyData, job: tuple[int, str | None], draw: bool = False) -> list[Section]:
    """The sections of one unit of work ``(builder index, film or None)``; with `draw`, every figure drawn to
    PNG and released (`FigureBlock.drawn`), to be sent from a worker."""
    import matplotlib

    index, film = job
    build = SECTION_BUILDERS[index]
    with matplotlib.rc_context(F.REPORT_STYLE):
        out = build(data) if film is None else build(data, [film])
        sections = out if isinstance(out, list) else [out]
        if draw:
            for section in sections:
                section.blocks = [b.drawn() if isinstance(b, FigureBlock) else b for b in section.blocks]
    return sections


def _report_jobs(data: StudyData) -> list[tuple[int, str | None]]:
    """Units of work of the report in order: one per builder, the calibration sections one per film."""
    calibration = SECTION_BUILDERS.index(calibration_sections)
    return [(i, film) for i in range(len(SECTION_BUILDERS))
            for film in (data.films if i == calibration else [None])]


_study_cache: dict = {}


def _drawn_sections(study_dir: str, job: tuple[int, str | None]) -> list[Section]:
    """A worker's unit of the report: its sections with every figure drawn to PNG and released.

    The study is read once per process (again only when its manifest changes).
    """
    from filmcal.study.layout import StudyLayout

    manifest = StudyLayout(Path(study_dir)).manifest.stat()
    key = (str(Path(study_dir).resolve()), manifest.st_mtime_ns, manifest.st_size)
    if key not in _study_cache:
        _study_cache.clear()
        _study_cache[key] = read_study(study_dir)
    return _build_sections(_study_cache[key], job, draw=True)


def build_report(study_dir: str | Path, workers=1, progress: Callable[[int, int], None] | None = None) -> Report:
    """Compose the report of a study folder (reads its files; computes nothing expensive).

    Parameters
    ----------
    study_dir : str or Path
    workers : int, filmcal._parallel.Executor or None
        1 (default): build here, each figure drawn when first rendered.
        Otherwise the sections are built and their figures drawn in worker
        processes (this many, None: all cores, or this pool) and arrive drawn
        (`FigureBlock.drawn`).
    progress : callable, optional
        ``progress(done, total)`` after each part of the report is built.

    Raises
    ------
    FileNotFoundError
        If the folder has no settings (not made by the pipeline).
    """
    data = read_study(study_dir)
    jobs = _report_jobs(data)
    parts: dict = {}

    def built(job, sections, k=None) -> None:
        parts[job] = sections
        if progress is not None:
            progress(len(parts), len(jobs))

    if workers == 1:
        for job in jobs:
            built(job, _build_sections(data, job))
    else:
        from filmcal._parallel import run_tasks

        # the calibration sections (most figures) first, so that the workers end together
        order = sorted(jobs, key=lambda job: job[1] is None)
        run_tasks({job: (_drawn_sections, (str(study_dir), job)) for job in order}, workers, built)
    sections = [section for job in jobs for section in parts[job]]
    answer, remarks = answer_table(data.posteriors, data.curves, data.other_posteriors,
                                   data.imprint_comparison)
    stamp = _dt.datetime.fromtimestamp(recorded_epoch(study_dir), _dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return Report("Film calibration and wheel-rail correction report",
                  f"Study {data.folder.resolve()}, settings hash {data.settings_hash}, as recorded {stamp}.",
                  sections, answer=answer, remarks=remarks)


def recorded_epoch(study_dir: str | Path) -> int:
    """When the study's newest artefact was recorded (s since 1970 UTC; the manifest's time without artefacts).

    The report's date: a report of the same study is the same report, byte for byte in its PDF.
    """
    from filmcal.study.layout import StudyLayout

    manifest = StudyLayout(Path(study_dir)).manifest
    try:
        artefacts = json.loads(manifest.read_text(encoding="utf-8")).get("artefacts", {})
        return int(max(_dt.datetime.fromisoformat(e["written_utc"].replace("Z", "+00:00")).timestamp()
                       for e in artefacts.values()))
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return int(manifest.stat().st_mtime)


def write_report(study_dir: str | Path, out_dir: str | Path | None = None, workers=None,
                 progress: Callable[[int, int], None] | None = None) -> dict:
    """Write ``report.html`` (self-contained) and ``report.pdf`` (A4) into `out_dir` (default ``study_dir/report``).

    Each file is written atomically, the PDF first and the HTML once it is done: a failure (or Ctrl-C) while
    either is made leaves an earlier report's pair as it was.

    The figures are drawn in worker processes (`workers`: their number, default
    all cores, or a pool), or here with ``workers=1``; ``progress(done, total)`` is called as each part of the
    report is built.

    Returns
    -------
    dict
        ``{"html": Path, "pdf": Path, "figures": int, "pdf_engine": "typst"}``.
    """
    import matplotlib

    report = build_report(study_dir, workers=workers, progress=progress)
    out = Path(out_dir) if out_dir is not None else Path(study_dir) / "report"
    out.mkdir(parents=True, exist_ok=True)
    html_path = out / "report.html"
    # the pair changes together or not at all: the HTML is rendered first and written only once the PDF is
    with matplotlib.rc_context(F.REPORT_STYLE):
        html = render_html(report)
        pdf = write_pdf(report, out / "report.pdf", timestamp=recorded_epoch(study_dir))
    atomic_write_text(html_path, html)
    return {"html": html_path, "pdf": pdf.path, "figures": len(report.figures), "pdf_engine": pdf.engine}
