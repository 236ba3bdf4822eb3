"""Scanned sheets: every imprint on a page, found, numbered and read with its uncertainty.

A lab tapes several imprints on one page, labels them by hand and scans the page. `read_sheet` reads it:

1. *Dye.* The stain intensity of every pixel is unmixed by the dye's colour (`stain_intensity`), so the
   yellow tape, the grey scanner lid, pencil, black pen and blue ink read as paper.
2. *Imprints.* A pixel is a stained dot where its intensity exceeds `DOT_INTENSITY`, or `DOT_NOISE_SIGMAS`
   times the scan's own noise where that is higher (`dot_intensity`: a noisy scanner or camera). The dots' local
   fraction, averaged over a Gaussian of `FIND_SCALE_MM`, marks an imprint where it reaches
   `FIND_COVERAGE` above the paper's own (a noisy scan dots the paper too: `find_level`): connected regions
   of at least ``min_imprint_mm2`` are the imprints, smaller ones are dust or stray marks. An imprint is its
   *dense core* inside a *halo* of isolated dots.
3. *Core.* A Prescale imprint is a field of developed microcapsules: the core is densely dotted, the halo
   sparsely, and the paper not at all. Within each imprint the stain intensity averaged over a Gaussian of
   `CORE_SCALE_MM` (several dot spacings, well under the core's radius) falls in two classes, core and
   halo; Otsu's threshold between them is the core's edge, and its outline and area are read sub-pixel as
   in `measure_imprint`. **The outline is the core's: the halo is not part of the area.** Its isolated dots
   record single capsules that broke where the pressure lies below the film's range (the manufacturer's
   minimum pressure is where the colour *begins* to develop densely), so the halo is reported beside the
   area (``halo_area_mm2``: the whole imprint's area at `FIND_COVERAGE`; ``halo_coverage``: the stained
   fraction of the halo ring) and never added to it.
4. *Uncertainty.* Three parts in quadrature: the pixel size and the threshold (10 % of the core-halo
   contrast) as in `measure_imprint`, and the averaging scale (half the difference of the areas read at
   0.7 and 1.4 times `CORE_SCALE_MM`, `SCALE_SPREAD`). The threshold part is a matter of
   definition and common to every imprint read by the same rule: replicates agree better than the stated
   uncertainty says when it dominates (``area_std_threshold_mm2`` is kept apart for that reason).
5. *Order.* Imprints are numbered in reading order: rows from the top of the page (an imprint starts a new
   row when it lies wholly below the current row's imprints), left to right within a row, after the page
   is turned by ``rotate_deg`` (a sheet scanned upside down: 180).

Coordinates are those of `measure_imprint` for the page as turned: x to the right, y up, mm, origin at
the lower-left corner; ``region_px`` is the imprint's box in the stored (unturned) image's pixels.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from filmcal._validation import check_positive
from filmcal.correction.imprint import (
    Imprint,
    _pixel_size,
    intensity_noise,
    load_scan,
    measure_imprint,
    otsu_threshold,
    stain_intensity,
)

__all__ = ["Sheet", "SheetImprint", "read_sheet", "find_imprints", "dot_intensity", "write_sheet_table", "plot_sheet",
           "scan_sheet", "SHEET_COLUMNS"]

#: Stain intensity above which a pixel is a developed dot (the paper's noise on a flatbed scan is ~0.005).
DOT_INTENSITY = 0.02
#: A dot stands this many standard deviations of the scan's noise above blank paper (`dot_intensity`).
DOT_NOISE_SIGMAS = 2.0
#: Scale (Gaussian standard deviation, mm) and dot fraction at which imprints are found on the page.
FIND_SCALE_MM = 2.0
FIND_COVERAGE = 0.05
#: Most of the dot fraction of blank paper taken as the scan's noise (`find_imprints`): a noisy flatbed scan
#: (grey levels scattered by 2-3 of 255) dots 5-10 % of the paper above `DOT_INTENSITY`.
MAX_NOISE_COVERAGE = 0.15
#: Side (mm) of the square over which the paper's own dot fraction is taken (`find_level`): several imprints wide.
BACKGROUND_MM = 40.0
#: Scale (Gaussian standard deviation, mm) over which the stain is averaged to tell the core from the halo.
CORE_SCALE_MM = 0.5
#: The factors applied to `CORE_SCALE_MM` for the averaging scale's part of the uncertainty.
SCALE_SPREAD = (0.7, 1.4)
#: Largest sheet read (pixels): an A3 page at 500 dpi. About 20 bytes a pixel are held while reading.
MAX_SHEET_PIXELS = 60_000_000

#: The columns `Sheet.rows` gives, in order; `filmcal correct --batch` takes the table as it is.
SHEET_COLUMNS = ("imprint", "scan", "region_px", "x_mm", "y_mm", "film", "force_kn", "offset_mm",
                 "measured_area_mm2", "measured_area_std_mm2", "equivalent_radius_mm", "halo_area_mm2",
                 "halo_coverage", "scan_status")


@dataclass
class SheetImprint:
    """One imprint of a sheet.

    Attributes
    ----------
    number : int
        Its place in reading order, from 1.
    core : Imprint
        The dense core's outline, area and uncertainty (``area_std_mm2`` includes the averaging scale's
        part, ``area_std_scale_mm2``), in the turned page's frame.
    area_std_scale_mm2 : float
        Half the difference of the core areas read at the two averaging scales of `SCALE_SPREAD`.
    halo_area_mm2 : float
        Area of the whole imprint, core and halo, where the dots' fraction reaches `FIND_COVERAGE`.
    halo_coverage : float
        Stained fraction of the halo ring (imprint minus core).
    halo_outlines_mm : list of ndarray
        The halo's outer outline.
    region_px : tuple of int
        ``(row0, row1, col0, col1)`` of the imprint's box in the stored image (half-open).
    status : str
        "ok", or why the reading is doubtful ("touches the page's edge: cut off").
    """

    number: int
    core: Imprint
    area_std_scale_mm2: float
    halo_area_mm2: float
    halo_coverage: float
    halo_outlines_mm: list[np.ndarray] = field(repr=False)
    region_px: tuple[int, int, int, int]
    status: str = "ok"

    @property
    def area_mm2(self) -> float:
        return self.core.area_mm2

    @property
    def area_std_mm2(self) -> float:
        return self.core.area_std_mm2


@dataclass
class Sheet:
    """Every imprint found on a scanned page, in reading order.

    Attributes
    ----------
    path : Path
    imprints : list of SheetImprint
    pixel_size_mm : float
    pixel_size_source : str
    rotate_deg : int
        How the page was turned before reading (counter-clockwise).
    intensity : ndarray
        The turned page's stain intensity (for the overview).
    dot_intensity : float
        The stain intensity above which a pixel was read as a dot (`dot_intensity`).
    """

    path: Path
    imprints: list[SheetImprint]
    pixel_size_mm: float
    pixel_size_source: str
    rotate_deg: int
    intensity: np.ndarray = field(repr=False)
    dot_intensity: float = DOT_INTENSITY

    def rows(self, *, film: str = "", force_kn: float | None = None, offset_mm: float | None = None) -> list[dict]:
        """One row per imprint in `SHEET_COLUMNS`, as `filmcal correct --batch` reads them.

        ``film``, ``force_kn`` and ``offset_mm`` fill those columns when given (a sheet of one test
        series); left empty, a lab fills them in before the batch.
        """
        def fmt(value, digits=6):
            return "" if value is None else f"{value:.{digits}g}"

        return [{"imprint": str(imp.number), "scan": f"{self.path.name}[{imp.region_px[0]}:{imp.region_px[1]},"
                                                     f"{imp.region_px[2]}:{imp.region_px[3]}]",
                 "region_px": " ".join(str(v) for v in imp.region_px),
                 "x_mm": fmt(imp.core.centroid_mm[0], 5), "y_mm": fmt(imp.core.centroid_mm[1], 5),
                 "film": film, "force_kn": fmt(force_kn), "offset_mm": fmt(offset_mm),
                 "measured_area_mm2": fmt(imp.area_mm2), "measured_area_std_mm2": fmt(imp.area_std_mm2, 4),
                 "equivalent_radius_mm": fmt(imp.core.equivalent_radius_mm, 5),
                 "halo_area_mm2": fmt(imp.halo_area_mm2, 5), "halo_coverage": fmt(imp.halo_coverage, 3),
                 "scan_status": imp.status}
                for imp in self.imprints]


def _gaussian(image: np.ndarray, sigma_px: float) -> np.ndarray:
    from scipy import ndimage

    return ndimage.gaussian_filter(image, sigma_px, mode="nearest", truncate=3.0)


def dot_intensity(noise: float) -> float:
    """The stain intensity above which a pixel is a dot on a scan whose blank paper scatters by ``noise``
    (`filmcal.correction.imprint.intensity_noise`): `DOT_INTENSITY`, or `DOT_NOISE_SIGMAS` times the noise
    where that is higher. Without it, a scan whose grey levels scatter by 5 of 255 dotted a third of its paper
    and read 46 imprints on a page of 6."""
    return max(DOT_INTENSITY, DOT_NOISE_SIGMAS * float(noise))


def find_level(coverage: np.ndarray, pixel_size_mm: float) -> np.ndarray | float:
    """The dot fraction at which an imprint begins, pixel by pixel: `FIND_COVERAGE` above the paper's own.

    A scanner's noise dots paper more where it is tinted (tape, the lid's shadow) than where it is white; most of
    any `BACKGROUND_MM` square of a page is paper, so the median dot fraction over it is the paper's there (0 on a
    clean scan, which leaves `FIND_COVERAGE`), taken up to `MAX_NOISE_COVERAGE`. Without it, noise that dots 6 % of
    the paper joined every imprint of a page into one, cut off by its edges.
    """
    from scipy import ndimage

    if not np.any(coverage >= FIND_COVERAGE * 0.5):
        return FIND_COVERAGE
    step = max(1, int(round(1.0 / pixel_size_mm)))  # about 1 mm cells: the coverage is smooth over FIND_SCALE_MM
    coarse = coverage[::step, ::step]
    size = max(3, int(round(BACKGROUND_MM / (step * pixel_size_mm))) | 1)
    background = ndimage.median_filter(coarse, size=size, mode="nearest")
    full = np.repeat(np.repeat(background, step, axis=0), step, axis=1)[:coverage.shape[0], :coverage.shape[1]]
    return FIND_COVERAGE + np.minimum(full, MAX_NOISE_COVERAGE)


def find_imprints(intensity: np.ndarray, pixel_size_mm: float, *, min_imprint_mm2: float = 5.0,
                  dot_intensity: float = DOT_INTENSITY) -> tuple[np.ndarray, list[tuple[slice, slice]]]:
    """Label the imprints of a page's stain intensity (module notes, step 2); a dot is a pixel above
    ``dot_intensity`` (the function `dot_intensity` gives it for a scan's noise).

    Returns
    -------
    labels : ndarray of int
        0 outside imprints, k inside the k-th kept imprint (unordered).
    boxes : list of (slice, slice)
        Each kept imprint's box.
    """
    from scipy import ndimage

    h = check_positive("pixel_size_mm", pixel_size_mm)
    dots = (np.asarray(intensity) > dot_intensity).astype(np.float32)
    coverage = _gaussian(dots, FIND_SCALE_MM / h)
    labels, n = ndimage.label(coverage >= find_level(coverage, h), structure=np.ones((3, 3), dtype=int))
    if n == 0:
        return labels, []
    # an imprint must hold a core: stain at least min_imprint_mm2 of dots, not only a smear of dust
    dot_area = ndimage.sum(dots, labels, index=np.arange(1, n + 1)) * h * h
    keep = np.flatnonzero(dot_area >= min_imprint_mm2) + 1
    relabel = np.zeros(n + 1, dtype=np.int32)
    relabel[keep] = np.arange(1, keep.size + 1)
    labels = relabel[labels]
    return labels, [box for box in ndimage.find_objects(labels) if box is not None]


def _reading_order(boxes: list[tuple[slice, slice]]) -> list[int]:
    """Indices of the boxes in reading order (rows from the top, left to right)."""
    order = sorted(range(len(boxes)), key=lambda i: (boxes[i][0].start, boxes[i][1].start))
    rows: list[list[int]] = []
    row_bottom = -1
    for i in order:
        if not rows or boxes[i][0].start >= row_bottom:
            rows.append([i])
            row_bottom = boxes[i][0].stop
        else:
            rows[-1].append(i)
            row_bottom = max(row_bottom, boxes[i][0].stop)
    return [i for row in rows for i in sorted(row, key=lambda j: boxes[j][1].start)]


def _read_one(intensity: np.ndarray, region: np.ndarray, h: float, dot_level: float
              ) -> tuple[Imprint, float, float, float, list[np.ndarray]]:
    """The core (with the scale's uncertainty), the halo's area, coverage and outline of one imprint.

    The window is read with one pixel of blank paper around it, so that an imprint cut by the page's edge is
    read as far as it goes (the sheet marks it cut off) instead of refused as a single scan would be.
    """
    intensity, region = np.pad(intensity, 1), np.pad(region, 1)
    inside = np.where(region, intensity, 0.0)
    areas = []
    core = None
    for factor in (1.0, *SCALE_SPREAD):
        smooth = np.clip(_gaussian(inside, factor * CORE_SCALE_MM / h), 0.0, 1.0)
        smooth[~region] = 0.0
        threshold = otsu_threshold(smooth[region])
        imp = measure_imprint(smooth, h, threshold=threshold, min_region_mm2=0.5, min_contrast=0.0)
        if core is None:
            core = imp
        areas.append(imp.area_mm2)
    std_scale = 0.5 * abs(areas[2] - areas[1])
    core.area_std_mm2 = float(math.hypot(core.area_std_mm2, std_scale))
    halo = measure_imprint(region.astype(float), h, threshold=0.5, min_region_mm2=0.5, min_contrast=0.0)
    ring = region & ~core.mask
    coverage = float(np.mean(intensity[ring] > dot_level)) if ring.any() else 0.0
    # back to the window's frame: the pad's column on the left and row at the bottom (y up) move x and y by h
    core.mask = core.mask[1:-1, 1:-1]
    core.outlines_mm = [ring_mm - h for ring_mm in core.outlines_mm]
    core.centroid_mm = core.centroid_mm - h
    return core, std_scale, halo.area_mm2, coverage, [ring_mm - h for ring_mm in halo.outlines_mm]


def read_sheet(path, *, dpi: float | None = None, mm_per_pixel: float | None = None, rotate_deg: int = 0,
               min_imprint_mm2: float = 5.0, progress=None) -> Sheet:
    """Find, number and read every imprint on a scanned page (module notes).

    Parameters
    ----------
    path : str or Path
        The scan (PNG, TIFF or JPEG; colour for the dye's unmixing).
    dpi, mm_per_pixel : float, optional
        The resolution; the file's own by default (see `read_imprint`).
    rotate_deg : {0, 90, 180, 270}
        Turn the page counter-clockwise before numbering (180 for a sheet scanned upside down).
    min_imprint_mm2 : float
        Least stained area (mm^2) of an imprint: smaller groups of dots are dust or stray marks.
    progress : callable, optional
        Called as ``progress(done, total)`` after each imprint.

    Returns
    -------
    Sheet

    Raises
    ------
    ValueError
        For a bad parameter, a damaged or oversized file (`filmcal._errors.DamagedFileError`) or a page
        without imprints.
    """
    path = Path(path)
    if rotate_deg not in (0, 90, 180, 270):
        raise ValueError(f"rotate_deg must be 0, 90, 180 or 270, got {rotate_deg!r}")
    min_imprint_mm2 = check_positive("min_imprint_mm2", min_imprint_mm2)
    pixels, info = load_scan(path, MAX_SHEET_PIXELS)
    if pixels.ndim == 2 or pixels.shape[2] == 2:  # grey, grey with alpha
        raise ValueError(f"{path.name} is a greyscale image: the film's magenta dye is told from tape, pencil, ink "
                         "and paper by its colour; scan the sheet in colour (RGB)")
    h, source = _pixel_size(dpi, mm_per_pixel, info, path)
    stored = stain_intensity(pixels)
    level = dot_intensity(intensity_noise(pixels))
    del pixels
    turns = rotate_deg // 90
    intensity = np.ascontiguousarray(np.rot90(stored, turns))
    labels, boxes = find_imprints(intensity, h, min_imprint_mm2=min_imprint_mm2, dot_intensity=level)
    if not boxes:
        raise ValueError(f"{path.name}: no imprint found (no group of dye-coloured dots of at least "
                         f"{min_imprint_mm2:g} mm2); is it a colour scan of Prescale film?")
    rows, cols = intensity.shape
    margin = math.ceil(3.0 * 1.4 * CORE_SCALE_MM / h) + 2
    imprints = []
    order = _reading_order(boxes)
    for number, index in enumerate(order, start=1):
        box = boxes[index]
        r0, r1 = max(box[0].start - margin, 0), min(box[0].stop + margin, rows)
        c0, c1 = max(box[1].start - margin, 0), min(box[1].stop + margin, cols)
        region = labels[r0:r1, c0:c1] == index + 1
        core, std_scale, halo_area, coverage, halo_outlines = _read_one(intensity[r0:r1, c0:c1], region, h,
                                                                        level)
        # window coordinates -> page coordinates (x right, y up from the turned page's lower-left corner)
        shift = np.array([c0 * h, (rows - r1) * h])
        core.outlines_mm = [ring + shift for ring in core.outlines_mm]
        core.centroid_mm = core.centroid_mm + shift
        halo_outlines = [ring + shift for ring in halo_outlines]
        cut = box[0].start == 0 or box[1].start == 0 or box[0].stop == rows or box[1].stop == cols
        imprints.append(SheetImprint(
            number=number, core=core, area_std_scale_mm2=std_scale, halo_area_mm2=halo_area,
            halo_coverage=coverage, halo_outlines_mm=halo_outlines,
            region_px=_stored_box((box[0].start, box[0].stop, box[1].start, box[1].stop), turns, stored.shape),
            status="touches the page's edge: cut off" if cut else "ok"))
        if progress is not None:
            progress(number, len(order))
    return Sheet(path=path, imprints=imprints, pixel_size_mm=h, pixel_size_source=source, rotate_deg=rotate_deg,
                 intensity=intensity, dot_intensity=level)


def _stored_box(box: tuple[int, int, int, int], turns: int, stored_shape: tuple[int, int]) -> tuple[int, ...]:
    """A half-open box of the page turned ``turns`` quarter turns counter-clockwise, in the stored image."""
    r0, r1, c0, c1 = box
    corners = [(r0, c0), (r0, c1 - 1), (r1 - 1, c0), (r1 - 1, c1 - 1)]
    for t in range(turns % 4, 0, -1):
        # np.rot90 maps (i, j) of the page turned t - 1 times to (n - 1 - j, i) of the page turned t times,
        # n the columns of the former: undo it
        n = stored_shape[1] if (t - 1) % 2 == 0 else stored_shape[0]
        corners = [(j, n - 1 - i) for i, j in corners]
    rs, cs = [c[0] for c in corners], [c[1] for c in corners]
    return (int(min(rs)), int(max(rs)) + 1, int(min(cs)), int(max(cs)) + 1)


def write_sheet_table(sheet: Sheet, path, *, film: str = "", force_kn: float | None = None,
                      offset_mm: float | None = None) -> None:
    """Write `Sheet.rows` as CSV (atomically), with a ``#`` comment line saying what the numbers are."""
    import csv

    from filmcal._io import atomic_open
    from filmcal._versions import __version__

    with atomic_open(path, "w", newline="") as fh:
        fh.write(f"# filmcal {__version__} scan of {sheet.path.name}: {len(sheet.imprints)} imprints, "
                 f"{sheet.pixel_size_mm:.5g} mm per pixel ({sheet.pixel_size_source}), turned {sheet.rotate_deg} "
                 "deg; measured_area_mm2 is the dense core's, the halo is beside it\n")
        writer = csv.DictWriter(fh, fieldnames=SHEET_COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(sheet.rows(film=film, force_kn=force_kn, offset_mm=offset_mm))


def plot_sheet(sheet: Sheet, path) -> None:
    """Draw the overview: the page with every imprint's core and halo outline and number, and a zoom of each.

    The page is the scan as it is (turned by ``rotate_deg``), so tape, labels and ink can be seen not to
    have been read as imprints.
    """
    from matplotlib.figure import Figure

    from filmcal._io import atomic_savefig

    pixels, _ = load_scan(sheet.path, MAX_SHEET_PIXELS)
    page = np.rot90(pixels, sheet.rotate_deg // 90)
    if page.ndim == 2:
        page = np.repeat(page[:, :, None], 3, axis=2)
    page = page[:, :, :3]
    rows, cols = page.shape[:2]
    h = sheet.pixel_size_mm
    step = max(1, math.ceil(max(rows, cols) / 1600))
    extent = (0.0, cols * h, 0.0, rows * h)
    n = len(sheet.imprints)
    per_row = min(max(n, 1), 6)
    zoom_rows = math.ceil(n / per_row)
    fig = Figure(figsize=(12, 12 * rows / cols * 0.75 + 2.4 * zoom_rows), layout="constrained")
    grid = fig.add_gridspec(1 + zoom_rows, per_row, height_ratios=[12 * rows / cols * 0.75] + [2.4] * zoom_rows)
    ax = fig.add_subplot(grid[0, :])
    ax.imshow(page[::step, ::step], extent=extent, interpolation="antialiased")
    for imp in sheet.imprints:
        for ring in imp.halo_outlines_mm:
            ax.plot(ring[:, 0], ring[:, 1], "--", lw=0.7, color="tab:blue")
        for ring in imp.core.outlines_mm:
            ax.plot(ring[:, 0], ring[:, 1], "-", lw=0.9, color="black")
        top = max(float(r[:, 1].max()) for r in imp.halo_outlines_mm)
        ax.annotate(f"{imp.number}", (imp.core.centroid_mm[0], top), xytext=(0, 4), textcoords="offset points",
                    ha="center", va="bottom", fontsize=11, weight="bold", color="tab:blue")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_title(f"{sheet.path.name}: {n} imprints in reading order (black: dense core, the area read; "
                 f"dashed: halo of isolated dots, not counted)", fontsize=10)
    for k, imp in enumerate(sheet.imprints):
        zx = fig.add_subplot(grid[1 + k // per_row, k % per_row])
        halo = np.vstack(imp.halo_outlines_mm)
        x0, x1 = halo[:, 0].min() - 1, halo[:, 0].max() + 1
        y0, y1 = halo[:, 1].min() - 1, halo[:, 1].max() + 1
        c0, c1 = max(int(x0 / h), 0), min(math.ceil(x1 / h), cols)
        r0, r1 = max(rows - math.ceil(y1 / h), 0), min(rows - int(y0 / h), rows)
        zx.imshow(page[r0:r1, c0:c1], extent=(c0 * h, c1 * h, (rows - r1) * h, (rows - r0) * h),
                  interpolation="nearest")
        for ring in imp.halo_outlines_mm:
            zx.plot(ring[:, 0], ring[:, 1], "--", lw=0.7, color="tab:blue")
        for ring in imp.core.outlines_mm:
            zx.plot(ring[:, 0], ring[:, 1], "-", lw=0.9, color="black")
        zx.set_title(f"{imp.number}: {imp.area_mm2:.1f} ± {imp.area_std_mm2:.1f} mm²"
                     + ("" if imp.status == "ok" else " (cut off)"), fontsize=9)
        zx.set_xticks([])
        zx.set_yticks([])
    atomic_savefig(fig, path, dpi=110)  # the format from path's suffix, not the temporary file's


def scan_sheet(path, out, overview, *, dpi: float | None = None, mm_per_pixel: float | None = None,
               rotate_deg: int = 0, min_imprint_mm2: float = 5.0, film: str = "", force_kn: float | None = None,
               offset_mm: float | None = None) -> Sheet:
    """Read a sheet (`read_sheet`), write its table (`write_sheet_table`) and its overview (`plot_sheet`)."""
    sheet = read_sheet(path, dpi=dpi, mm_per_pixel=mm_per_pixel, rotate_deg=rotate_deg,
                       min_imprint_mm2=min_imprint_mm2)
    write_sheet_table(sheet, out, film=film, force_kn=force_kn, offset_mm=offset_mm)
    plot_sheet(sheet, overview)
    return sheet
