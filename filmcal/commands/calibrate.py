"""`filmcal calibrate`: Bayesian calibration of the film modulus for one film type."""
from __future__ import annotations

import argparse
from pathlib import Path

from filmcal.commands._common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "calibrate", help="calibrate the film modulus E of MS, HS or HHS against Table 1 (emcee)",
        description="Bayesian calibration of the film's Young's modulus against the paper's Table 1 "
                    "(measured radius = Hertz radius + tabulated error): measured radius = FE radius(E, nu, R, F) "
                    "+ noise, with the noise level sigma inferred and the surrogate's uncertainty in the "
                    "likelihood. The FE model is seen through a Gaussian-process surrogate trained on an optimal "
                    "Latin hypercube of FE runs (kept in --study-dir and reused). Prints E and the oedometric "
                    "modulus M = E(1-nu)/((1+nu)(1-2nu)) with 90 %% intervals and the sampler's diagnostics.")
    p.add_argument("--film", required=True, help="film type: MS, HS or HHS")
    p.add_argument("--loads", help="load range in kN, e.g. 50-100 (the paper's choice); all loads by default")
    p.add_argument("--poisson", choices=["fixed", "free"], default="fixed",
                   help="nu fixed at 0.33 (default, as the paper) or uniform over 0.29-0.37 "
                        "(then only M is identified)")
    p.add_argument("--discrepancy", choices=["none", "load"], default="none",
                   help="'load': an offset per load level (normal prior, 0.2 mm)")
    p.add_argument("--sphere-contact", choices=["frictionless", "tied", "friction"], default="frictionless",
                   help="FE sphere-film interface (default frictionless)")
    p.add_argument("--flat-contact", choices=["frictionless", "tied", "friction"], default="tied",
                   help="FE film-flat interface (default tied)")
    p.add_argument("--friction-coefficient", type=float, default=0.4, help="for 'friction' interfaces (0.4)")
    p.add_argument("--large-strain", action="store_true", help="neo-Hookean large-strain film in the FE model")
    p.add_argument("--study-dir", default="filmcal-study",
                   help="folder of the FE runs (SQLite), surrogates and chains (default ./filmcal-study); "
                        "reused and resumed when present")
    p.add_argument("--train-runs", type=int, default=200, help="FE runs to train the surrogate (default 200)")
    p.add_argument("--test-runs", type=int, default=100, help="held-out FE runs to validate it (default 100)")
    p.add_argument("--workers", type=int, default=None, help="FE worker processes (default: all cores)")
    p.add_argument("--seed", type=int, default=0, help="seed of designs, surrogate and chains (default 0)")
    p.add_argument("--max-steps", type=int, default=None, help="cap on MCMC steps per walker")
    p.add_argument("--plots", metavar="DIR", help="write trace, corner, per-case (Fig. 3) and predictive plots")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.fem import ContactOptions
    from filmcal.study import SurrogateDomain, calibrate_from_study, posterior_tag

    options = ContactOptions(sphere_contact=args.sphere_contact, flat_contact=args.flat_contact,
                             friction_coefficient=args.friction_coefficient, large_strain=args.large_strain)
    if args.train_runs < 20 or args.test_runs < 5:
        raise ValueError("train_runs must be >= 20 and test_runs >= 5")
    discrepancy = None if args.discrepancy == "none" else args.discrepancy
    result, validation, _, path = calibrate_from_study(
        args.study_dir, args.film, args.loads, options, args.poisson, discrepancy, args.seed, args.train_runs,
        args.test_runs, args.workers, args.max_steps, progress=not args.json)
    if args.plots:
        _plots(result, Path(args.plots), posterior_tag(args.film, args.loads, options, args.poisson, discrepancy,
                                                        args.seed))
    out = result.to_dict()
    out["surrogate_validation"] = validation.to_dict()
    out["fe_options"] = {"sphere_contact": options.sphere_contact, "flat_contact": options.flat_contact,
                         "friction_coefficient": options.friction_coefficient, "large_strain": options.large_strain}
    out["prior_modulus_range_mpa"] = list(SurrogateDomain().modulus_mpa)
    out["posterior_file"] = str(path)
    if args.json:
        print_json(out)
    else:
        m, ci = out["modulus_mpa"]["median"], out["modulus_mpa"]["ci90"]
        om, oci = out["oedometric_modulus_mpa"]["median"], out["oedometric_modulus_mpa"]["ci90"]
        print(f"film {args.film.upper()}, loads {args.loads or 'all'}, {out['n_data']} cases")
        print(f"E  = {m:.0f} MPa   90 % [{ci[0]:.0f}, {ci[1]:.0f}]")
        print(f"M  = {om:.0f} MPa   90 % [{oci[0]:.0f}, {oci[1]:.0f}]")
        print(f"sigma = {out['sigma_mm']['median']:.3f} mm; R-hat {out['rhat']:.4f}, ESS {out['ess']:.0f}, "
              f"diagnostics {'ok' if out.get('diagnostics_ok', True) else 'NOT ok'}")
        print(f"surrogate: held-out area error RMS {100 * validation.area_rms_relative_error:.3f} %, "
              f"max {100 * validation.area_max_relative_error:.3f} %, 90 % coverage {validation.coverage90:.2f}")
        print(f"posterior saved to {path}")
    return 0


def _plots(result, folder: Path, tag: str) -> None:
    from filmcal.calibration import plots

    folder.mkdir(parents=True, exist_ok=True)
    plots.plot_trace(result, folder / f"trace-{tag}.png")
    plots.plot_corner(result, folder / f"corner-{tag}.png")
    plots.plot_case_intervals(result, folder / f"cases-{tag}.png")
    plots.plot_predictive(result, folder / f"predictive-{tag}.png")
