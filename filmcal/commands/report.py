"""`filmcal report`: the calibration report of a study folder as HTML and PDF."""
from __future__ import annotations

import argparse

from filmcal.commands._common import print_json
from filmcal.commands._options import add, local


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "report", help="write the calibration report of a study folder (self-contained HTML and PDF)",
        description="Write the report of a study folder made by `filmcal pipeline`: FE verification against "
                    "Hertz, the analogues of the paper's Figs. 2, 3, 6 and 7, design quality, surrogate "
                    "validation, posteriors with diagnostics per film type, posterior predictive checks against "
                    "Table 1, wheel-rail correction curves with 90 %% bands, and provenance (versions, seeds, "
                    "settings hash, file checksums), and a glossary. The HTML embeds its figures (one file to "
                    "share); the PDF is the same report typeset on A4 by Typst (a title page with the answer per "
                    "film, contents with page numbers, tables as text, each figure with its caption; no browser "
                    "needed). Reads the study's files only; the figures are drawn on every core "
                    "(docs/pipeline.md gives measured times).")
    add(p, "study_dir", default="filmcal-study", help="study folder (default ./filmcal-study)")
    local(p, "--out-dir", default=None,
          help="output folder (default STUDY_DIR/report; any other folder must lie outside the study: a read-only "
               "study's report goes elsewhere)")
    add(p, "json", action="store_true", help="print the written paths as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.study import Study

    study = Study(args.study_dir)  # a folder that is not a study is refused before the report's imports
    if not study.manifest.data["artefacts"]:  # a report of what a study holds; this one holds nothing yet
        raise ValueError(f"--study-dir {args.study_dir!r} holds no results yet (no calibration, no curves): run "
                         "`filmcal pipeline` or `filmcal calibrate --study-dir ...` first")
    from pathlib import Path

    from filmcal._io import check_output_dir

    if args.out_dir is not None:
        check_output_dir(args.out_dir, "--out-dir")
        if Path(args.out_dir).resolve() != (Path(args.study_dir) / "report").resolve():
            from filmcal.study.layout import check_outside_study

            check_outside_study(args.out_dir, "--out-dir", args.study_dir)  # STUDY_DIR/report, or elsewhere
    else:  # STUDY_DIR/report: a read-only study (an archive, a colleague's) needs --out-dir elsewhere
        try:
            check_output_dir(Path(args.study_dir) / "report", "--study-dir")
        except ValueError as exc:
            raise type(exc)(f"{exc}: the report goes to STUDY_DIR/report; give --out-dir elsewhere") from None
    from filmcal.report import write_report

    paths = write_report(args.study_dir, args.out_dir)
    out = {"html": str(paths["html"]), "pdf": str(paths["pdf"]), "figures": paths["figures"],
           "pdf_engine": paths["pdf_engine"]}
    if args.json:
        print_json(out)
    else:
        print(f"report: {out['html']} and {out['pdf']} ({out['figures']} figures)")
    return 0
