"""`filmcal pipeline`: the whole job on the embedded default, resumable."""
from __future__ import annotations

import argparse

from filmcal.commands._common import print_json, simulator_from_args
from filmcal.commands._options import add, add_simulator_options, local


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "pipeline", help="run the whole job: FE campaign, surrogate, calibration of MS/HS/HHS, correction curves, "
                         "report",
        description="Run (or resume) the whole job in one study folder: an optimal Latin hypercube of FE runs of "
                    "the Hertzian film experiments (local processes, SQLite store), a validated Gaussian-process "
                    "surrogate, the Bayesian calibration of MS, HS and HHS against Table 1, checks of the FE model "
                    "against Hertz and of the surrogate against FE, wheel-rail correction curves (S1002/60E2, 50 "
                    "and 100 kN, eta -7..2 mm, smooth and rough wheel) with 90 %% credible bands, contact outlines, "
                    "leave-one-case-out cross-validation of the correction on Table 1, and the HTML + PDF report (STUDY_DIR/report). Finished work is kept and reused: an interrupted "
                    "run resumes where it stopped, and a second run only reads. The full run takes a few minutes on "
                    "2 cores (docs/pipeline.md gives measured times). A folder keeps "
                    "the settings it was made with; other settings need another folder.")
    add(p, "study_dir", extra="(default ./filmcal-study, or ./filmcal-study-quick with --quick, "
                             "./filmcal-study-smoke with --smoke)")
    add(p, "run_store")
    local(p, "--quick", action="store_true",
          help="a small version for checks (40+12 FE runs, short chains, 3 offsets at 50 kN; "
               "./filmcal-study-quick)")
    local(p, "--smoke", action="store_true",
          help="the whole path at its smallest size (20+5 FE runs, one offset, short chains, no cross-validation; "
               "./filmcal-study-smoke): checks that an installation runs the job; its numbers are not a "
               "calibration")
    add(p, "films", extra="(default MS,HS,HHS, or the films of --data); added to the films an existing study "
                          "already holds, which its summary and report keep")
    local(p, "--data", metavar="CSV", help="your own sphere-on-flat dataset (the format of `filmcal calibrate "
                                           "--data`); default the paper's Table 1. --films then defaults to the "
                                           "dataset's films")
    add(p, "films_file", extra="; recorded in the study")
    add(p, "imprint_models", extra="(default all three; edge,activation with --quick and --smoke)")
    add(p, "kinematics", help="film kinematics of the FE model, each calibrated and compared: small, large or "
                              "small,large (default small,large; small with --quick and --smoke)",
        choices=None, metavar="KINEMATICS")
    add_simulator_options(p)
    where = p.add_mutually_exclusive_group()
    add(where, "workers", extra="; one pool shared by every stage (default: all cores)")
    add(where, "dask", extra="; every stage's parallel work runs there (FE or simulator runs, fits, calibrations, "
        "roughness laws, curve solves)")
    add(p, "seed", extra="(default 0)", default=0)
    local(p, "--no-report", action="store_true", help="skip the HTML/PDF report")
    add(p, "progress", default="auto")
    add(p, "json", action="store_true", help="print the summary as one JSON object (progress on stderr)")
    p.set_defaults(func=run)


def _write_report(*args, **kwargs):
    """`filmcal.report.write_report`, imported only when the report is written (a finished study's is not)."""
    from filmcal.report import write_report

    return write_report(*args, **kwargs)


def run(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from filmcal.films import FilmRegistry
    from filmcal.study import PipelineSettings, run_pipeline

    registry = FilmRegistry.from_file(args.films_file)
    if args.data is not None:
        from filmcal.calibration import load_dataset

        dataset_films = load_dataset(args.data).films
    else:
        dataset_films = ("MS", "HS", "HHS")
    films = [f for f in args.films.split(",") if f] if args.films is not None else list(dataset_films)
    for f in films:
        registry.get(f)
    if not films or len(set(films)) != len(films):
        raise ValueError(f"--films must be distinct film types, got {args.films!r}")
    if args.quick and args.smoke:
        raise ValueError("--quick and --smoke are two sizes: give one of them")
    size = "smoke" if args.smoke else "quick" if args.quick else None
    settings = getattr(PipelineSettings, size)() if size else PipelineSettings()
    if args.imprint_models is not None:
        settings = replace(settings, imprint_models=tuple(m.strip() for m in args.imprint_models.split(",")))
    if args.kinematics is not None:
        settings = replace(settings, kinematics=tuple(k.strip() for k in args.kinematics.split(",")))
    simulator = simulator_from_args(args)
    if simulator is not None:
        settings = replace(settings, simulator=simulator)
    study_dir = args.study_dir or ("filmcal-study" + (f"-{size}" if size else ""))
    from filmcal._progress import Progress

    progress = Progress(args.progress)
    if simulator is not None:
        progress.warnings.append(f"the calibration ran on {simulator.label()}; the wheel-rail curves apply "
                                 "filmcal's own film model at the calibrated modulus (with the transfer term "
                                 "fitted to filmcal's FE): valid where your model and filmcal's agree")
    summary = run_pipeline(study_dir, settings, films, args.seed, args.workers, progress,
                           report=None if args.no_report else _write_report,
                           films_file=args.films_file, dataset=args.data, dask=args.dask,
                           run_store=args.run_store)
    from filmcal.calibration.pipeline import scatter_warning

    for film, s in summary["films"].items():
        scatter = scatter_warning(s["sigma_mm"]["median"], s["n_data"])
        if scatter:
            progress.warnings.append(f"{film}: {scatter}")
        if not s["diagnostics_ok"]:
            why = "; ".join(s.get("diagnostics_messages") or []) or "see the report's diagnostics"
            progress.warnings.append(f"{film} ({s.get('preferred_model', {}).get('model', s['model'])}): the sampler's checks did not all pass ({why}; "
                                     f"R-hat {s['rhat']:.4f}, ESS {s['ess']:.0f}): treat this posterior as "
                                     "provisional" + (", or run without --quick/--smoke"
                                                      if size else ""))
    if args.json:
        print_json(summary)
    else:
        for film, s in summary["films"].items():
            m, ci = s["modulus_mpa"]["median"], s["modulus_mpa"]["ci90"]
            weights = s.get("imprint_weights") or {}
            print(f"{film} ({s['model']}): E = {m:.0f} MPa [{ci[0]:.0f}, {ci[1]:.0f}], R-hat {s['rhat']:.4f} "
                  f"({s.get('preferred_model', {}).get('model', s['model'])}), "
                  f"ESS {s['ess']:.0f}, cases in their 90 % predictive interval {s['predictive_hits']}/{s['n_cases']}"
                  + (", model weights " + ", ".join(f"{k} {v:.2f}" for k, v in weights.items()) if weights else ""))
        if "report" in summary:
            print(f"report: {summary['report']['html']} and {summary['report']['pdf']}")
        print(f"summary: {study_dir}/summary.json ({summary['elapsed_s']:.0f} s)")
    progress.summary()
    return 0
