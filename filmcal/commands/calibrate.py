"""`filmcal calibrate`: Bayesian calibration of the film modulus for one film type."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from filmcal.commands._common import print_json, simulator_from_args
from filmcal.commands._options import (
    STUDY_IMPRINT_MODELS, add, add_contact_options, add_simulator_options, bounds_text, force_range, local, renamed,
)
from filmcal._validation import arg_int_in
from filmcal.contact.names import DEFAULT_KINEMATICS, MIXTURE
from filmcal.surrogate.radius import MAX_MODULI_PER_CASE, MODULI_PER_CASE


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate", help="calibrate a film type's modulus E (MS, HS, HHS or a lab's own) against Table 1 or a lab's data (emcee)",
        description="Bayesian calibration of the film's Young's modulus against the paper's Table 1 "
                    "(measured radius = Hertz radius + tabulated error): measured radius = FE radius(E, nu, R, F) "
                    "+ noise, with the noise level sigma inferred and the surrogate's uncertainty in the "
                    "likelihood. The FE model is seen through a Gaussian-process surrogate trained on an optimal "
                    "Latin hypercube of FE runs (kept in the run store and reused by every study with the same FE settings). Prints E and the oedometric "
                    "modulus M = E(1-nu)/((1+nu)(1-2nu)) with 90 %% intervals and the sampler's diagnostics.")
    add(p, "film", required=True)
    add(p, "films_file", extra="; recorded in the study")
    local(p, "--data", metavar="CSV", help="your own sphere-on-flat dataset (columns film, sphere_radius_mm, "
          "force_kn and one of measured_radius_mm, measured_area_mm2, radius_error_mm; optional repeat, "
          "measurement_std_mm, flat_ra_um); default: the paper's Table 1")
    add(p, "imprint_model", choices=STUDY_IMPRINT_MODELS, default=MIXTURE,
        extra=f"; or {MIXTURE} (default): every model the film allows, compared by PSIS-LOO and combined by "
              "their weights (imprint_weights)")
    add(p, "forces_kn", help="calibrate on the cases whose force lies in this range in kN, e.g. 50-100 (the "
                             "paper's choice); all forces by default", metavar="RANGE", type=force_range)
    local(p, "--poisson", choices=["fixed", "free"], default="fixed",
          help="nu fixed at the film's nominal value (default, 0.33 as the paper) or uniform over "
               "0.29-0.37 (then only M is identified)")
    local(p, "--discrepancy", choices=["none", "load"], default="none",
          help="'load': an offset per load level (normal prior, 0.2 mm)")
    add_simulator_options(p)
    add_contact_options(p, prefix="FE ")
    add(p, "kinematics", default=DEFAULT_KINEMATICS, extra=f"of the FE model (default {DEFAULT_KINEMATICS})")
    add(p, "study_dir", default="filmcal-study",
        extra="of the surrogates and chains, recording the FE runs it used (default ./filmcal-study; created when "
              "missing); artefacts made with other settings are kept beside, never reused")
    add(p, "run_store")
    local(p, "--train-runs", type=int, default=200, help="FE runs to train the surrogate (default 200)")
    local(p, "--test-runs", type=int, default=100, help="held-out FE runs to validate it (default 100)")
    local(p, "--moduli-per-case", type=arg_int_in(0, MAX_MODULI_PER_CASE), default=MODULI_PER_CASE, metavar="N",
          help=f"FE runs added to the training design at each of the data's (R, F) cases, at moduli spread over "
               f"the prior's range at the film's nu, so that the surrogate is exact where the calibration asks it (with "
               f"--poisson free: along its nominal nu) (default "
               f"{MODULI_PER_CASE}; at most --train-runs in all; 0: the Latin hypercube alone)"
               + bounds_text(0, MAX_MODULI_PER_CASE, True))
    where = p.add_mutually_exclusive_group()
    add(where, "workers", extra="(default: all cores)")
    add(where, "dask", extra="; the command's parallel work runs there (FE or simulator runs, fits, calibrations)")
    add(p, "seed", default=0, extra="(default 0)")
    from filmcal._validation import MIN_MCMC_STEPS

    local(p, "--max-steps", type=arg_int_in(MIN_MCMC_STEPS, 10**7), default=None,
          help=f"cap on MCMC steps per walker (default: until converged) [allowed {MIN_MCMC_STEPS} to {10**7}]")
    local(p, "--plots", metavar="DIR", help="write trace, corner, per-case (Fig. 3) and predictive plots")
    add(p, "json", action="store_true")
    add(p, "progress", default="auto")
    renamed(p, "--imprint", "--imprint-model", type=lambda t: MIXTURE if t == "stacked" else t)
    renamed(p, "--loads", "--forces-kn", type=force_range)
    renamed(p, "--large-strain", "--kinematics large", "kinematics", flag_value="large")
    p.set_defaults(func=run)


def _spec(args: argparse.Namespace):
    """The calibration spec of the command's options (validated before any work)."""
    from filmcal.study import CalibrationSpec, FESettings

    fe = FESettings(sphere_contact=args.sphere_contact, flat_contact=args.flat_contact,
                    friction_coefficient=args.friction_coefficient,
                    kinematics=args.kinematics, n_train=args.train_runs,
                    n_test=args.test_runs, seed=args.seed, moduli_per_case=args.moduli_per_case,
                    simulator=simulator_from_args(args))
    imprint = "edge" if args.imprint_model == MIXTURE else args.imprint_model
    return CalibrationSpec(args.film, imprint=imprint, fe=fe, loads=args.forces_kn, poisson=args.poisson,
                           discrepancy=None if args.discrepancy == "none" else args.discrepancy,
                           max_steps=args.max_steps)


def run(args: argparse.Namespace) -> int:
    from filmcal._parallel import parallel_work
    from filmcal.study import Study

    spec = _spec(args)
    from filmcal.calibration.data import parse_load_range
    from filmcal.calibration.datasets import load_dataset

    if args.forces_kn is not None:
        parse_load_range(args.forces_kn)  # refused before the study folder is written
    if args.data is not None:
        load_dataset(args.data)
    with parallel_work(args.workers, args.dask) as workers:  # a Dask scheduler is reached before anything is written
        study = Study(args.study_dir, create=True, films_file=args.films_file, run_store=args.run_store)
        film = study.film(args.film)
        if args.plots:
            from filmcal._io import check_output_dir

            check_output_dir(args.plots, "--plots")
        from dataclasses import replace

        from filmcal.contact.imprint import imprint_models_for

        spec = replace(spec, fe=replace(spec.fe, film_thickness_mm=film.thickness_mm))
        mixture = args.imprint_model == MIXTURE
        imprints = list(imprint_models_for(film)) if mixture else [args.imprint_model]
        # enough data? refused before anything is written
        study.dataset_rows(film.name, args.forces_kn, args.data, compared=mixture and len(imprints) > 1)
        from filmcal._progress import Progress

        with study.writing("filmcal calibrate"), Progress(args.progress).stage("calibrate") as stage:
            calibrated = {}
            for imprint in imprints:
                one = replace(spec, imprint=imprint)
                # nothing shown before the FE runs start: a refusal before any work stays one line
                calibrated[one.model_label] = study.calibrate(one, dataset=args.data, workers=workers,
                                                              progress=_fe_runs(stage))
            if mixture and len(calibrated) > 1:
                comparison, _ = study.compare(film.name, calibrated, workers=workers, max_steps=spec.max_steps,
                                              seed=args.seed)
                label = comparison["preferred"]
                assessment = comparison["models"][label]
            else:
                comparison = None
                label = next(iter(calibrated))
                assessment = study.assess(calibrated[label][1], calibrated[label][0]).to_dict()
            result, path, full = calibrated[label]
            validation = study.surrogate_validation(path)
    if args.plots:
        _plots(result, Path(args.plots), path.stem)
    from filmcal.calibration.pipeline import scatter_warning

    said = [f"{label}: {w}" for label, (r, _, _) in calibrated.items()
            if (w := scatter_warning(r.sigma_mm["median"], r.n_data))]
    for line in said:  # beside a number that is not a finding: said on stderr, kept in --json
        sys.stderr.write(f"filmcal calibrate: warning: {line}\n")
    out = result.to_dict()
    out["warnings"] = said
    out.update(rms_residual_mm=assessment["rms_residual_mm"], ppc_inside_90=assessment["ppc_inside_90"],
               elpd_loo=assessment["elpd_loo"], elpd_loo_se=assessment["elpd_loo_se"])
    out["imprint_model"] = MIXTURE if mixture and comparison is not None else full["imprint"]
    if comparison is not None:
        from filmcal.calibration import combine_posteriors
        from filmcal.calibration.posterior import summarize

        weights = comparison["weights"]
        mixture = combine_posteriors({k: r.samples for k, (r, _, _) in calibrated.items()}, weights)
        out.update(modulus_mpa=summarize(mixture.samples["modulus_mpa"]),
                   oedometric_modulus_mpa=summarize(mixture.samples["oedometric_modulus_mpa"]),
                   imprint_weights=weights, preferred_model=label,
                   models={k: {key: v[key] for key in ("modulus_mpa", "rms_residual_mm", "ppc_inside_90",
                                                       "elpd_loo", "elpd_loo_se", "pareto_k_max")}
                           for k, v in comparison["models"].items()})
    out["surrogate_validation"] = validation.to_dict()
    out["fe_options"] = full["fe"]
    out["film"] = film.to_dict()
    out["dataset"] = full["dataset"]
    out["prior_modulus_range_mpa"] = list(spec.fe.domain.modulus_mpa)
    out["posterior_file"] = str(path)
    if args.json:
        print_json(out)
    else:
        m, ci = out["modulus_mpa"]["median"], out["modulus_mpa"]["ci90"]
        om, oci = out["oedometric_modulus_mpa"]["median"], out["oedometric_modulus_mpa"]["ci90"]
        print(f"film {film.name}, imprint model {out['imprint_model']}, forces {args.forces_kn or 'all'} kN, "
              f"{out['n_data']} cases")
        if "imprint_weights" in out:
            print("weights " + ", ".join(f"{k} {v:.2f}" for k, v in out["imprint_weights"].items()))
        print(f"E  = {m:.0f} MPa   90 % [{ci[0]:.0f}, {ci[1]:.0f}]")
        print(f"M  = {om:.0f} MPa   90 % [{oci[0]:.0f}, {oci[1]:.0f}]")
        error = result.mcse.get("modulus_mpa", {}).get("median")
        print(f"sigma = {out['sigma_mm']['median']:.3f} mm; R-hat {out['rhat']:.4f}, ESS {out['ess']:.0f}, "
              + (f"Monte Carlo error of {label}'s median E {error:.2g} MPa, " if error is not None else "")
              + f"diagnostics {'ok' if out.get('diagnostics_ok', True) else 'NOT ok'}")
        print(f"surrogate: held-out area error RMS {100 * validation.area_rms_relative_error:.3f} %, "
              f"max {100 * validation.area_max_relative_error:.3f} %, 90 % coverage {validation.coverage90:.2f}")
        print(f"rms residual {out['rms_residual_mm']:.3f} mm, {out['ppc_inside_90']}/{out['n_data']} inside their 90 % "
              f"predictive interval, ELPD-LOO {out['elpd_loo']:.1f} +/- {out['elpd_loo_se']:.1f}")
        print(f"posterior saved to {path}")
    return 0


def _fe_runs(stage):
    """``progress(done, total, what)`` of one calibration's FE runs (`Study.calibrate`), shown on `stage`."""
    last = 0

    def show(done: int, total: int, what: str = "FE run") -> None:
        nonlocal last
        if done < last:  # another model's campaign
            last = 0
        stage.set_total(total)
        stage.advance(done - last, note=f"{what}s")
        last = done

    return show


def _plots(result, folder: Path, tag: str) -> None:
    from filmcal.calibration import plots

    folder.mkdir(parents=True, exist_ok=True)
    plots.plot_trace(result, folder / f"trace-{tag}.png")
    plots.plot_corner(result, folder / f"corner-{tag}.png")
    plots.plot_case_intervals(result, folder / f"cases-{tag}.png")
    plots.plot_predictive(result, folder / f"predictive-{tag}.png")
