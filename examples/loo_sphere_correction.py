"""Leave-one-case-out cross-validation of the sphere-on-flat correction on Table 1.

For each film type and each of its 10 (R, F) cases: calibrate the film modulus
without that case (FE surrogate, emcee), correct the case's measured radius
(Hertz + Table 1 error) into a contact area without film with its 90 %
interval, and check whether the Hertz area (the truth of these experiments)
falls inside. Prints one table per film and the count of hits.

The radius surrogate (edge of contact, small-strain film) is the study
folder's (`filmcal.study.Study.radius_model`; trained there when missing; a
folder made by `filmcal pipeline` keeps its FE sizes and seed, so its
surrogate is the one used). ``--method exact`` (default) calibrates anew for
every fold (`filmcal.correction.leave_one_case_out`, 10 calibrations per
film); ``--method psis`` reweights the posterior calibrated on all cases
(`Study.calibrate`, reused when recorded) by Pareto-smoothed importance
sampling and recalibrates only the folds whose Pareto k exceeds 0.7
(`filmcal.correction.psis_leave_one_case_out`, what `filmcal pipeline` puts
in its report).

    python examples/loo_sphere_correction.py [--study-dir filmcal-study] [--films MS,HS,HHS]
        [--method exact|psis] [--out out/loo.md]
"""
from __future__ import annotations

import argparse
from pathlib import Path

from filmcal.calibration import Priors, SamplerSettings, calibrate
from filmcal.correction import leave_one_case_out, psis_leave_one_case_out
from filmcal.study import FESettings, Study, seed_for


def psis_folds(problem, result, film: str, fe: FESettings, max_steps: int | None):
    """Leave-one-case-out by PSIS from the posterior of `film` on all cases (exact refits where k > 0.7)."""
    def refit(label, data):
        sampler = SamplerSettings() if max_steps is None else SamplerSettings(max_steps=max_steps)
        return calibrate(data, problem.model, film=film, poisson=problem.poisson_mode, priors=problem.priors,
                         seed=seed_for(fe.seed, f"crossval-{film}-{label}"), settings=sampler).samples

    return psis_leave_one_case_out({"edge/small": (problem, result.samples)}, refit=refit, film=film,
                                   random_state=seed_for(fe.seed, f"crossval-{film}"),
                                   log=lambda msg: print(f"{film}: {msg}", flush=True))


def table(cv, psis: bool) -> list[str]:
    """The folds of one film as a Markdown table and its count of hits."""
    lines = [f"### {cv.film} ({'PSIS' if psis else 'exact refits'})", "",
             "| R (mm) | F (kN) | measured r (mm) | corrected area (mm2) | 90 % interval | Hertz area | inside |"
             + (" Pareto k |" if psis else ""), "|---|---|---|---|---|---|---|" + ("---|" if psis else "")]
    for i, (r, f, m, a, sd, (lo, hi), h, ok) in enumerate(zip(cv.sphere_radius_mm, cv.force_n, cv.measured_radius_mm,
                                                              cv.area_mm2, cv.area_std_mm2, cv.area_ci90_mm2,
                                                              cv.hertz_area_mm2, cv.inside)):
        lines.append(f"| {r:g} | {f / 1e3:g} | {m:.3f} | {a:.1f} +/- {sd:.1f} | [{lo:.1f}, {hi:.1f}] | {h:.1f} | "
                     f"{'yes' if ok else 'NO'} |"
                     + (f" {cv.pareto_k[i]:.2f}{' (refit)' if cv.refit[i] else ''} |" if psis else ""))
    refits = f", {cv.n_refits} exact refit(s)" if psis else ""
    lines += ["", f"{cv.film}: Hertz area inside the 90 % interval in {cv.hits} of {len(cv.inside)} cases{refits}", ""]
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--study-dir", default="filmcal-study", help="study folder (created when missing)")
    ap.add_argument("--films", default="MS,HS,HHS")
    ap.add_argument("--method", choices=("exact", "psis"), default="exact",
                    help="exact: one calibration per fold (default); psis: importance sampling of the full posterior")
    ap.add_argument("--out", default="out/loo.md")
    args = ap.parse_args()
    films = [f.strip() for f in args.films.split(",")]
    study = Study(args.study_dir, create=True)
    specs, models, full = {}, {}, {}
    with study.writing("examples/loo_sphere_correction.py"):
        for film in films:  # an unknown film is refused before any work
            # the FE sizes, seed and step cap of the study's pipeline (its posteriors are then reused), else
            # those of `filmcal calibrate`; the surrogate the calibration on Table 1 is made with
            specs[film] = study.spec_like_pipeline(film, "edge", "small")
            models[film], _, _ = study.radius_model(study.as_calibrated(specs[film]).fe, "contact_radius_mm")
            if args.method == "psis":
                result, path, _ = study.calibrate(specs[film])
                full[film] = (study.problem(path), result)
    lines = []
    for film in films:
        spec = specs[film]
        if args.method == "psis":
            cv = psis_folds(*full[film], film, spec.fe, spec.max_steps)
        else:
            priors = Priors.for_film(study.film(film), modulus_range_mpa=spec.fe.domain.modulus_mpa)
            cv = leave_one_case_out(models[film], film, priors=priors, log=lambda msg: print(msg, flush=True))
        lines += table(cv, args.method == "psis")
        print(lines[-2], flush=True)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
