"""`filmcal scan`: every imprint on a scanned sheet, numbered, read with its uncertainty, as a batch table."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from filmcal.commands._common import print_json
from filmcal.commands._options import add, add_scan_resolution, local


def add_parser(subparsers) -> None:
    """Register the `scan` subcommand."""
    p = subparsers.add_parser(
        "scan",
        help="find, number and read every imprint on a scanned sheet",
        description="Find every imprint on a scanned page (a colour scan: PNG, TIFF or JPEG in RGB; several imprints taped on one "
                    "sheet, with labels, tape and dust), number them in reading order (rows from the top, left to "
                    "right, after --rotate-deg) and read each one's area with its uncertainty. The stain is "
                    "unmixed by the dye's colour, so tape, pencil, black pen and blue ink are not read as stain. "
                    "An imprint is a dense core inside a halo of isolated dots: the area is the core's (where the "
                    "averaged stain falls from the core's level to the halo's, by Otsu's threshold), the halo is "
                    "reported beside it (halo_area_mm2, halo_coverage) and not counted; the uncertainty adds "
                    "the pixel size, the threshold and the averaging scale. Writes a table that "
                    "`filmcal correct --batch` takes (fill in film, force_kn and offset_mm, or give them here for "
                    "a sheet of one test series) and an overview image with every outline and number: look at "
                    "it before correcting. Prints one line per imprint (or --json).")
    p.add_argument("sheet", metavar="SHEET", help="the scanned page")
    local(p, "--out", metavar="FILE.csv", required=True,
          help="the imprints' table (columns imprint, scan, region_px, x_mm, y_mm, film, force_kn, offset_mm, "
               "measured_area_mm2, measured_area_std_mm2, equivalent_radius_mm, halo_area_mm2, halo_coverage, "
               "scan_status)")
    local(p, "--overview", metavar="FILE.png",
          help="the overview image (default: --out with .png in place of .csv)")
    add_scan_resolution(p)
    local(p, "--rotate-deg", choices=("0", "90", "180", "270"), default="0",
          help="turn the page counter-clockwise before numbering: 180 for a sheet scanned upside down "
               "(default 0)")
    local(p, "--min-imprint-mm2", type=float, default=5.0,
          help="least stained area of an imprint in mm2; smaller groups of dots are dust (default 5)")
    add(p, "film", extra="(fills the film column; checked against the built-in films and --films-file)")
    add(p, "films_file", extra="(where --film's own film is defined)")
    add(p, "force_kn", extra="(fills the force_kn column)")
    add(p, "offset_mm", extra="(fills the offset_mm column)")
    add(p, "json", action="store_true", help="print the imprints as one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from filmcal.correction.sheet import DOT_INTENSITY, DOT_NOISE_SIGMAS, scan_sheet

    from filmcal._io import check_distinct_files

    if args.film:
        from filmcal.films import get_film

        get_film(args.film, args.films_file)  # an unknown name is refused before the image is read
    out = Path(args.out)
    overview = Path(args.overview) if args.overview else out.with_suffix(".png")
    check_distinct_files((args.sheet, "the scanned sheet"), (out, "--out"),
                         (overview, "--overview" if args.overview else "--out's overview (its name with .png)"))
    sheet = scan_sheet(args.sheet, out, overview, dpi=args.dpi, mm_per_pixel=args.mm_per_pixel,
                       rotate_deg=int(args.rotate_deg), min_imprint_mm2=args.min_imprint_mm2, film=args.film or "",
                       force_kn=args.force_kn, offset_mm=args.offset_mm)
    if args.json:
        print_json({"sheet": str(args.sheet), "table": str(out), "overview": str(overview),
                    "pixel_size_mm": sheet.pixel_size_mm, "pixel_size_source": sheet.pixel_size_source,
                    "rotate_deg": sheet.rotate_deg, "dot_intensity": sheet.dot_intensity,
                    "imprints": [{**imp.core.to_dict(), "number": imp.number, "region_px": list(imp.region_px),
                                  "area_std_scale_mm2": imp.area_std_scale_mm2, "halo_area_mm2": imp.halo_area_mm2,
                                  "halo_coverage": imp.halo_coverage, "status": imp.status}
                                 for imp in sheet.imprints]})
        return 0
    print(f"{len(sheet.imprints)} imprints on {Path(args.sheet).name} ({sheet.pixel_size_mm:.4g} mm per pixel, "
          f"{sheet.pixel_size_source}); areas are the dense cores', halos beside them")
    if sheet.dot_intensity > DOT_INTENSITY:
        print(f"a noisy scan: a dot is read above {sheet.dot_intensity:.3f} of stain ({DOT_NOISE_SIGMAS:g} times "
              f"the scan's noise, instead of {DOT_INTENSITY:g}), so the halos' faintest dots are not counted")
    for imp in sheet.imprints:
        x, y = imp.core.centroid_mm
        print(f"  {imp.number:2d}  at ({x:6.1f}, {y:6.1f}) mm   area {imp.area_mm2:8.2f} +/- {imp.area_std_mm2:.2f} mm2"
              f"   halo {imp.halo_area_mm2:7.1f} mm2 ({100 * imp.halo_coverage:.0f} % dotted)"
              + ("" if imp.status == "ok" else f"   {imp.status}"))
    print(f"table: {out}\noverview: {overview}", file=sys.stderr)
    return 0
