"""The calibration report of a study folder: what was computed, figure by figure, and why it can be trusted.

`build_report` only reads the study's files (written by `filmcal.pipeline`)
and draws them; a stage whose files are missing gets a section that says so.
`write_report` renders the report as self-contained HTML and as PDF.
"""
from __future__ import annotations

import datetime as _dt
import hashlib
import json
import platform
import subprocess
from importlib import metadata
from pathlib import Path

import numpy as np

from filmcal.report import figures as F
from filmcal.report.document import FigureBlock, Report, Section, Table, render_html, write_pdf

__all__ = ["build_report", "write_report"]

_PACKAGES = ("numpy", "scipy", "scikit-learn", "scikit-fem", "emcee", "matplotlib", "h5py", "pyDOE")


def _read_json(path: Path) -> dict | None:
    return json.loads(path.read_text(encoding="utf-8")) if path.exists() else None


def _missing(section: Section, *names: str) -> Section:
    return section.add(f"Not available: {', '.join(names)} missing in the study folder (run `filmcal pipeline`).")


def _ci(d: dict, fmt: str = "{:.0f}") -> str:
    lo, hi = d["ci90"]
    return f"{fmt.format(d['median'])} [{fmt.format(lo)}, {fmt.format(hi)}]"


def _study_config(study: Path) -> dict:
    settings = _read_json(study / "settings.json")
    if settings is None:
        raise FileNotFoundError(f"study_dir {study} has no settings.json: not a study folder made by "
                                "`filmcal pipeline`")
    return settings


def _posteriors(study: Path, films: list[str], seed: int) -> dict:
    from filmcal.calibration import load_result
    from filmcal.study import posterior_path

    out = {}
    for film in films:
        path = posterior_path(study, film, seed=seed)
        if path.exists():
            out[film] = (load_result(path), path)
    return out


# --------------------------------------------------------------- sections
def _summary(posteriors: dict, curves: dict, config: dict) -> Section:
    s = Section("Summary")
    s.add("Prescale film between two bodies prints a contact patch larger than the contact without film. This "
          "report calibrates a finite-element model of the film (its Young's modulus E, with Poisson's ratio fixed "
          "at 0.33) against the Hertzian sphere-on-flat experiments of Table 1 for each film type, and propagates "
          "the posterior through a wheel-rail model (S1002 wheel on a 60E2 rail inclined 1:40) into correction "
          "curves with 90 % credible bands.")
    rows = []
    for film, (r, _) in posteriors.items():
        p = r.predictive
        rows.append([film, _ci(r.modulus_mpa), _ci(r.oedometric_modulus_mpa), f"{r.sigma_mm['median']:.3f}",
                     f"{r.rhat_max:.4f}", f"{r.ess_min:.0f}", "yes" if r.diagnostics_ok else "NO",
                     f"{int(np.sum(~p.outside))}/{len(p.outside)}"])
    s.add(Table(["film", "E (MPa), median [90 %]", "M (MPa), median [90 %]", "sigma (mm)", "worst R-hat",
                 "worst bulk ESS", "diagnostics pass", "Table 1 cases in 90 % PPI"], rows,
                "Posterior per film type (all loads of Table 1)"))
    rows = []
    for film, c in curves.items():
        for wheel in dict.fromkeys(r["wheel"] for r in c):
            for force in sorted({r["force_kn"] for r in c}):
                sel = [r for r in c if r["wheel"] == wheel and r["force_kn"] == force]
                rows.append([film, wheel, f"{force:g}",
                             f"{min(r['delta_area_median_mm2'] for r in sel):.1f} - "
                             f"{max(r['delta_area_median_mm2'] for r in sel):.1f}",
                             f"{min(r['ratio_median'] for r in sel):.3f} - {max(r['ratio_median'] for r in sel):.3f}",
                             f"{max(r['ratio_hi'] - r['ratio_lo'] for r in sel):.3f}",
                             f"{100 * max(r['interpolation_error_rel'] for r in sel):.3f}"])
    if rows:
        s.add(Table(["film", "wheel", "F (kN)", "Delta A median (mm2)", "A0/A median", "widest 90 % band of A0/A",
                     "propagation error (% of A)"], rows, "Wheel-rail corrections over the offsets computed"))
    s.add("E and nu are not separately identifiable from contact areas: a thin film held laterally is compressed "
          "nearly oedometrically, so the radius depends on (E, nu) through M = E(1-nu)/((1+nu)(1-2nu)). With nu "
          "fixed, the calibrated E stands for M; any (E, nu) pair with the same M gives the same correction.")
    return s


def _verification(study: Path) -> Section:
    s = Section("FE model verification")
    v = _read_json(study / "fe-verification.json")
    if v is None:
        return _missing(s, "fe-verification.json")
    rows = [[f"R{r['radius_mm']:g}", f"{r['force_n'] / 1e3:g}", f"{r['hertz_radius_mm']:.4f}",
             f"{r['fe_radius_mm']:.4f}", f"{100 * (r['fe_radius_mm'] / r['hertz_radius_mm'] - 1):+.3f}"]
            for r in v["hertz"]]
    s.add("Without film the axisymmetric FE model (steel on steel, E = 210000 MPa, nu = 0.3) must reproduce "
          "Hertz's contact radius a = (3FR/(4E*))^(1/3) at the ten (R, F) cases of Table 1.",
          Table(["sphere", "F (kN)", "a Hertz (mm)", "a FE (mm)", "error (%)"], rows, "FE without film against Hertz"),
          FigureBlock(F.plot_hertz_verification(v["hertz"]), "Relative error of the FE contact radius without "
                      "film against Hertz."))
    case = v["profile_case"]
    s.add(FigureBlock(F.plot_pressure_profiles(v["profiles"], case["radius_mm"], case["force_n"]),
                      "Contact pressure without film (against Hertz) and with each film at its posterior median E: "
                      "the film lowers the peak and widens the patch."))
    worst, inside, n = 0.0, 0, 0
    for d in v["films"].values():
        for r in d["cases"]:
            diff = abs(r["surrogate_mean_mm"] - r["fe_radius_mm"])
            worst = max(worst, diff)
            inside += diff <= F.Z90 * r["surrogate_std_mm"]
            n += 1
    s.add(f"The surrogate used by the calibration is checked against new FE solves at each film's posterior "
          f"median: largest difference {1e3 * worst:.1f} um in radius, {inside}/{n} FE radii inside the "
          "surrogate's 90 % interval.",
          FigureBlock(F.plot_surrogate_at_medians(v["films"]), "Surrogate minus FE radius at the posterior medians, "
                      "with the surrogate's 90 % interval, per case and film."))
    return s


def _preliminary(study: Path) -> Section:
    from filmcal.fem import ContactOptions
    from filmcal.study import SurrogateDomain, SurrogateRadiusModel, surrogate_path
    from filmcal.surrogate import load_surrogate

    s = Section("Preliminary study: E and nu (Fig. 2)")
    path = surrogate_path(study, ContactOptions())
    if not path.with_name(path.name + ".json").exists():
        return _missing(s, path.name + ".json")
    domain = SurrogateDomain()
    model = SurrogateRadiusModel(load_surrogate(path), domain)
    s.add("As in the paper's Fig. 2, the contact area of the film model over the film's Young's modulus for "
          "several Poisson's ratios, at R300 / 25 kN and R600 / 100 kN (from the validated surrogate, 90 % "
          "bands). Over the oedometric modulus M the curves of different nu fall on one another: M is what the "
          "areas identify.",
          FigureBlock(F.plot_preliminary_study(model, modulus_range_mpa=domain.modulus_mpa),
                      "Contact area against E (left) and M (right) for nu = 0.29, 0.33, 0.37."))
    return s


def _design(study: Path) -> Section:
    s = Section("Design of the FE campaign")
    d = _read_json(study / "design.json")
    if d is None:
        return _missing(s, "design.json")
    rows = []
    for key, label in (("min_distance", "min. distance (larger is better)"), ("phi_p", "phi_50 (smaller is better)"),
                       ("centered_l2", "centered L2 discrepancy (smaller is better)"),
                       ("max_abs_correlation", "max. |correlation| (smaller is better)")):
        rows.append([label] + [f"{d[part][src][key]:.4g}" for part in ("train", "test")
                               for src in ("quality", "random_lhs_median")])
    s.add(f"Optimal Latin hypercubes (enhanced stochastic evolutionary search on phi_p) over log E, nu, the five "
          f"sphere radii (discrete levels) and F: {d['train']['n']} training and {d['test']['n']} held-out FE runs, "
          "each compared with the median of ten plain random Latin hypercubes of the same size.",
          Table(["metric (unit cube)", "training", "random LHS", "held out", "random LHS"], rows),
          FigureBlock(F.plot_design(d["names"], np.asarray(d["train"]["unit"]), np.asarray(d["test"]["unit"])),
                      "Pairwise projections of the training (dots) and held-out (crosses) designs."))
    return s


def _surrogate(study: Path) -> Section:
    s = Section("Surrogate validation")
    v = _read_json(study / "surrogate-validation.json")
    if v is None:
        return _missing(s, "surrogate-validation.json")
    m = v["summary"]
    s.add("A Gaussian process (Matern kernel, fitted FE noise) of the film's radius excess over Hertz, in log "
          "inputs and log output, checked on held-out FE runs of the second design.",
          Table(["held-out runs", "RMS radius error (mm)", "max radius error (mm)", "RMS area error (%)",
                 "max area error (%)", "90 % coverage", "Q2"],
                [[str(m["n"]), f"{m['radius_rms_error_mm']:.4f}", f"{m['radius_max_error_mm']:.4f}",
                  f"{100 * m['area_rms_relative_error']:.3f}", f"{100 * m['area_max_relative_error']:.3f}",
                  f"{m['coverage90']:.2f}", f"{m['q2']:.4f}"]]),
          FigureBlock(F.plot_surrogate_validation(v["points"]), "Held-out FE radius excess against the surrogate "
                      "(left) and the standardised errors (right)."))
    return s


def _calibration(film: str, result, path: Path) -> Section:
    from filmcal.calibration.plots import plot_case_intervals, plot_corner, plot_predictive, plot_trace

    s = Section(f"Calibration of {film} film")
    rows = [[name, f"{np.median(v):.4g}", f"{np.quantile(v, 0.05):.4g}", f"{np.quantile(v, 0.95):.4g}",
             f"{result.rhat.get(name, np.nan):.4f}", f"{result.ess_bulk.get(name, np.nan):.0f}",
             f"{result.ess_tail.get(name, np.nan):.0f}"]
            for name, v in ((k, np.asarray(v).ravel()) for k, v in result.samples.items())]
    s.add(f"emcee ensemble sampler, {result.n_walkers} walkers x {result.n_steps} steps (burn-in {result.burn_in}, "
          f"thinning {result.thin}), acceptance {result.acceptance_fraction:.2f}; {result.n_data} measured radii of "
          f"Table 1; noise sigma inferred. Diagnostics "
          f"{'pass' if result.diagnostics_ok else 'FAIL: ' + '; '.join(result.diagnostics.messages)} "
          f"(R-hat <= {result.diagnostics.max_rhat}, bulk ESS >= {result.diagnostics.min_ess:.0f}).",
          Table(["parameter", "median", "5 %", "95 %", "R-hat", "bulk ESS", "tail ESS"], rows,
                f"Posterior of {film} ({path.name})"))
    for note in result.notes:
        s.add(note)
    s.add(FigureBlock(plot_trace(result), f"{film}: traces of the kept samples per walker and their histograms."),
          FigureBlock(plot_corner(result), f"{film}: pairwise posterior samples."))
    p = result.predictive
    rows = [[f"R{r:g}", f"{f / 1e3:g}", f"{m - h:+.3f}", f"{mu - h:+.3f}", f"[{lo - h:+.3f}, {hi - h:+.3f}]",
             "no" if out else "yes"]
            for r, f, m, h, mu, lo, hi, out in zip(p.sphere_radius_mm, p.force_n, p.measured_radius_mm,
                                                   p.hertz_radius_mm, p.mean_mm, p.lower_mm, p.upper_mm, p.outside)]
    s.add(Table(["sphere", "F (kN)", "Table 1 error (mm)", "predicted (mm)", "90 % PPI (mm)", "inside"], rows,
                f"Posterior predictive check of {film} against Table 1 (radius errors a - a Hertz)"),
          FigureBlock(plot_predictive(result), f"{film}: Table 1's radius errors against the posterior predictive "
                      "90 % intervals."),
          FigureBlock(plot_case_intervals(result), f"{film}: the paper's Fig. 3 in kind: per case, the range of E "
                      "that reproduces the measured radius within the inferred noise, beside the pooled posterior."))
    return s


def _crossval(study: Path, films: list[str]) -> Section:
    from filmcal.correction.crossval import CaseCrossValidation

    s = Section("Leave-one-case-out cross-validation on Table 1")
    results = {film: CaseCrossValidation.from_dict(_read_json(study / f"crossval-{film}.json")) for film in films
               if (study / f"crossval-{film}.json").exists()}
    if not results:
        return _missing(s, "crossval-<film>.json")
    s.add("Can the correction be trusted on a case it has not seen? Each (R, F) case of Table 1 is held out in "
          "turn: the film is calibrated on the other cases, the held-out case's measured radius is corrected, "
          "and the Hertz area (the truth of these experiments) should lie in the corrected 90 % interval in "
          "about 9 of 10 cases.",
          FigureBlock(F.plot_crossval(results), "Corrected area of each held-out case relative to the Hertz area, "
                      "with its 90 % interval."))
    for film, cv in results.items():
        s.add(Table(["sphere", "F (kN)", "measured r (mm)", "E of fold (MPa)", "corrected A (mm2)", "90 % interval",
                     "Hertz A (mm2)", "inside"],
                    [[f"R{r:g}", f"{f / 1e3:g}", f"{m:.3f}", f"{e:.0f}", f"{a:.1f} +/- {sd:.1f}",
                      f"[{ci[0]:.1f}, {ci[1]:.1f}]", f"{h:.1f}", "yes" if ok else "NO"]
                     for r, f, m, e, a, sd, ci, h, ok in zip(cv.sphere_radius_mm, cv.force_n, cv.measured_radius_mm,
                                                             cv.modulus_median_mpa, cv.area_mm2, cv.area_std_mm2,
                                                             cv.area_ci90_mm2, cv.hertz_area_mm2, cv.inside)],
                    f"{film}: Hertz area inside the corrected 90 % interval in {cv.hits} of {len(cv.inside)} cases"))
    return s


def _wheel_rail(study: Path, curves: dict, posteriors: dict) -> Section:
    s = Section("Wheel-rail correction curves (Figs. 6 and 7)")
    if not curves:
        return _missing(s, "curves-<film>.csv")
    s.add("Each film's posterior of E is propagated through the wheel-rail model (boundary elements on "
          "half-spaces, the film as springs in series, areas read as in the FE calibration model): the film "
          "area is interpolated in log E from solves at five posterior quantiles and checked by two more; the "
          "largest relative error of that interpolation is printed beside the bands (it includes the area "
          "reading's own numerical jitter of a few tenths of a percent between neighbouring E). Rough wheel: a "
          "Greenwood-Williamson law from Ra at the film-wheel interface. At Ra 1.5 um it changes the area by "
          "well under 1 %, whereas the paper's rough-wheel simulations, with an experimentally obtained "
          "pressure-overclosure law, found a considerable increase: the rough-wheel curves here are not a "
          "substitute for that measured law, and a rough wheel should be corrected only after its roughness "
          "law has been measured.")
    for film, rows in curves.items():
        s.add(FigureBlock(F.plot_area_curves(rows, film), f"{film}: contact area over the lateral offset without "
                          "film and with film (posterior median, 90 % band), smooth and rough wheel."))
    s.add(FigureBlock(F.plot_correction_factor(curves), "Correction factor A(no film) / A(film) that turns a "
                      "measured imprint area into the contact area, posterior medians and 90 % bands."))
    for film, rows in curves.items():
        s.add(Table(["wheel", "F (kN)", "eta (mm)", "A0 (mm2)", "Delta A median", "Delta A 90 %", "A0/A median",
                     "A0/A 90 %", "prop. error (%)"],
                    [[r["wheel"], f"{r['force_kn']:g}", f"{r['offset_mm']:+g}", f"{r['area_no_film_mm2']:.1f}",
                      f"{r['delta_area_median_mm2']:.1f}", f"[{r['delta_area_lo_mm2']:.1f}, {r['delta_area_hi_mm2']:.1f}]",
                      f"{r['ratio_median']:.4f}", f"[{r['ratio_lo']:.4f}, {r['ratio_hi']:.4f}]",
                      f"{100 * r['interpolation_error_rel']:.3f}"] for r in rows],
                    f"{film}: correction curves"))
    outlines = _read_json(study / "wheelrail-outlines.json")
    if outlines is None:
        return _missing(s, "wheelrail-outlines.json")
    for film in outlines["films"]:
        s.add(FigureBlock(F.plot_outlines(outlines, film), f"The paper's Fig. 7 in kind: contact outlines at "
                          f"{outlines['force_n'] / 1e3:g} kN without film (solid) and with {film} film at its "
                          f"posterior median E = {outlines['films'][film]:.0f} MPa (dashed)."))
    return s


def _git_commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=Path(__file__).parent, capture_output=True,
                             text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return out.stdout.strip() if out.returncode == 0 else "unknown (not a git checkout)"


def _provenance(study: Path, config: dict) -> Section:
    import filmcal

    s = Section("Provenance")
    versions = [["filmcal", filmcal.__version__], ["filmcal git commit", _git_commit()],
                ["python", platform.python_version()], ["platform", platform.platform()]]
    for name in _PACKAGES:
        try:
            versions.append([name, metadata.version(name)])
        except metadata.PackageNotFoundError:
            versions.append([name, "not installed"])
    s.add(Table(["software", "version"], versions))
    settings = [["settings hash", config["hash"]], ["seed", str(config["seed"])],
                ["films", ", ".join(config["films"])]] + [[k, json.dumps(v)] for k, v in config["settings"].items()]
    s.add(Table(["setting", "value"], settings, "Pipeline settings (the hash covers settings, films and seed)"))
    files = []
    for p in sorted(study.iterdir()):
        if p.is_file() and not p.name.endswith(".tmp"):
            files.append([p.name, f"{p.stat().st_size / 1024:.1f}", hashlib.sha256(p.read_bytes()).hexdigest()[:16]])
    s.add(Table(["file", "size (KiB)", "SHA-256 (first 16)"], files, f"Study folder {study}"))
    return s


def build_report(study_dir: str | Path) -> Report:
    """Compose the report of a study folder (reads its files; computes nothing expensive).

    Raises
    ------
    FileNotFoundError
        If the folder has no ``settings.json`` (not made by the pipeline).
    """
    from filmcal.correction import read_curves_csv

    study = Path(study_dir)
    if not study.is_dir():
        raise FileNotFoundError(f"study_dir {study} is not a folder")
    config = _study_config(study)
    posteriors = _posteriors(study, config["films"], config["seed"])
    curves = {film: read_curves_csv(study / f"curves-{film}.csv") for film in config["films"]
              if (study / f"curves-{film}.csv").exists()}
    sections = [_summary(posteriors, curves, config), _verification(study), _preliminary(study), _design(study),
                _surrogate(study)]
    for film in config["films"]:
        if film in posteriors:
            sections.append(_calibration(film, *posteriors[film]))
        else:
            sections.append(_missing(Section(f"Calibration of {film} film"), f"posterior of {film}"))
    sections += [_crossval(study, config["films"]), _wheel_rail(study, curves, posteriors),
                 _provenance(study, config)]
    stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return Report("Film calibration and wheel-rail correction report",
                  f"Study {study.resolve()}, settings hash {config['hash']}, generated {stamp}.", sections)


def write_report(study_dir: str | Path, out_dir: str | Path | None = None) -> dict[str, Path]:
    """Write ``report.html`` (self-contained) and ``report.pdf`` into `out_dir` (default ``study_dir/report``).

    Returns
    -------
    dict
        ``{"html": Path, "pdf": Path, "figures": int}``.
    """
    report = build_report(study_dir)
    out = Path(out_dir) if out_dir is not None else Path(study_dir) / "report"
    out.mkdir(parents=True, exist_ok=True)
    html_path = out / "report.html"
    tmp = html_path.with_name(html_path.name + ".tmp")
    tmp.write_text(render_html(report), encoding="utf-8")
    tmp.replace(html_path)
    pdf_path = write_pdf(report, out / "report.pdf")
    return {"html": html_path, "pdf": pdf_path, "figures": len(report.figures)}
