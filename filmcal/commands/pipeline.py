"""`filmcal pipeline`: the whole job on the embedded default, resumable."""
from __future__ import annotations

import argparse
import sys

from filmcal.commands._common import print_json


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
                    "run resumes where it stopped, and a second run only reads (under a minute). A folder keeps "
                    "the settings it was made with; other settings need another folder.")
    p.add_argument("--study-dir", default=None,
                   help="study folder (default ./filmcal-study, or ./filmcal-study-quick with --quick)")
    p.add_argument("--quick", action="store_true",
                   help="a small version for checks (40+12 FE runs, short chains, 3 offsets at 50 kN): 1-3 min")
    p.add_argument("--films", default="MS,HS,HHS", help="film types, comma-separated (default MS,HS,HHS)")
    p.add_argument("--workers", type=int, default=None, help="FE worker processes (default: all cores)")
    p.add_argument("--seed", type=int, default=0, help="seed of designs, surrogate and chains (default 0)")
    p.add_argument("--no-report", action="store_true", help="skip the HTML/PDF report")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object (progress on stderr)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.films import FILM_TYPES
    from filmcal.pipeline import PipelineSettings, run_pipeline

    films = [f.strip().upper() for f in args.films.split(",") if f.strip()]
    unknown = [f for f in films if f not in FILM_TYPES]
    if not films or unknown or len(set(films)) != len(films):
        raise ValueError(f"films must be distinct among {', '.join(FILM_TYPES)}, got {args.films!r}")
    if args.workers is not None and args.workers < 1:
        raise ValueError(f"workers must be >= 1, got {args.workers}")
    settings = PipelineSettings.quick() if args.quick else PipelineSettings()
    study_dir = args.study_dir or ("filmcal-study-quick" if args.quick else "filmcal-study")
    log = (lambda msg: (sys.stderr.write(msg + "\n"), sys.stderr.flush())) if args.json else (
        lambda msg: print(msg, flush=True))
    summary = run_pipeline(study_dir, settings, films, args.seed, args.workers, log, report=not args.no_report)
    if args.json:
        print_json(summary)
    else:
        for film, s in summary["films"].items():
            m, ci = s["modulus_mpa"]["median"], s["modulus_mpa"]["ci90"]
            print(f"{film}: E = {m:.0f} MPa [{ci[0]:.0f}, {ci[1]:.0f}], R-hat {s['rhat']:.4f}, ESS {s['ess']:.0f}, "
                  f"Table 1 cases in 90 % PPI {s['predictive_hits']}/{s['n_cases']}"
                  + (f", leave-one-case-out {s['crossval_hits']}/{s['n_cases']}" if "crossval_hits" in s else "")
                  + f", curves {s['curves_file']}")
        if "report" in summary:
            print(f"report: {summary['report']['html']} and {summary['report']['pdf']}")
        print(f"summary: {study_dir}/summary.json ({summary['elapsed_s']:.0f} s)")
    return 0
