"""`filmcal pipeline`: the whole job on the embedded default, resumable."""
from __future__ import annotations

import argparse
import sys

from filmcal.commands._common import print_json


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "pipeline", help="run the whole job: FE campaign, surrogate, calibration of MS/HS/HHS, correction curves",
        description="Run (or resume) the whole job in one study folder: an optimal Latin hypercube of FE runs of "
                    "the Hertzian film experiments (local processes, SQLite store), a validated Gaussian-process "
                    "surrogate, the Bayesian calibration of MS, HS and HHS against Table 1, and wheel-rail "
                    "correction curves (S1002/60E2, 50 and 100 kN, eta -7..2 mm) with 90 %% credible bands. "
                    "Finished work is kept and reused: a second run only reads.")
    p.add_argument("--study-dir", default="filmcal-study", help="study folder (default ./filmcal-study)")
    p.add_argument("--quick", action="store_true", help="a small version (few FE runs, 3 offsets, 50 kN)")
    p.add_argument("--films", default="MS,HS,HHS", help="film types, comma-separated (default MS,HS,HHS)")
    p.add_argument("--workers", type=int, default=None, help="FE worker processes (default: all cores)")
    p.add_argument("--seed", type=int, default=0, help="seed of designs, surrogate and chains")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.films import FILM_TYPES
    from filmcal.pipeline import PipelineSettings, run_pipeline

    films = [f.strip().upper() for f in args.films.split(",") if f.strip()]
    unknown = [f for f in films if f not in FILM_TYPES]
    if not films or unknown:
        raise ValueError(f"films must be among {', '.join(FILM_TYPES)}, got {args.films!r}")
    settings = PipelineSettings.quick() if args.quick else PipelineSettings()
    log = (lambda msg: sys.stderr.write(msg + "\n")) if args.json else print
    summary = run_pipeline(args.study_dir, settings, films, args.seed, args.workers, log)
    if args.json:
        print_json(summary)
    else:
        for film, s in summary["films"].items():
            m, ci = s["modulus_mpa"]["median"], s["modulus_mpa"]["ci90"]
            print(f"{film}: E = {m:.0f} MPa [{ci[0]:.0f}, {ci[1]:.0f}], R-hat {s['rhat']:.4f}, ESS {s['ess']:.0f}, "
                  f"curves {s['curves_file']}")
        print(f"summary: {args.study_dir}/summary.json ({summary['elapsed_s']:.0f} s)")
    return 0
