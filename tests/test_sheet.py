"""Scanned sheets: a real page of six imprints with tape, labels and halos, and synthetic pages of known cores."""
from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from filmcal.correction.imprint import (
    DYE_OPTICAL_DENSITY,
    NEUTRAL_OPTICAL_DENSITY,
    YELLOW_OPTICAL_DENSITY,
)
from filmcal.correction.sheet import _stored_box, read_sheet

SHEET = Path(__file__).parent / "data" / "scans" / "lw-sheet-200dpi.jpg"
# The imprints' centres (column, row) in the stored image, read by eye from the page at a quarter of its size
# (tests/data/scans/README.md): the top row is labelled 008, 006, 005 and the bottom row 020, 011, 009 as stored.
CENTRES_PX = [(1755, 413), (2312, 400), (2925, 405), (1755, 1104), (2383, 1099), (2955, 1081)]


def _inside(box, point) -> bool:
    r0, r1, c0, c1 = box
    return c0 <= point[0] < c1 and r0 <= point[1] < r1


@pytest.fixture(scope="module")
def real_sheet():
    return read_sheet(SHEET)


def test_a_real_sheet_yields_its_six_imprints_in_reading_order_and_nothing_else(real_sheet):
    """Tape, handwriting, the scanner's lid and dust give nothing; the six imprints come row by row."""
    boxes = [imp.region_px for imp in real_sheet.imprints]
    assert len(boxes) == 6
    assert all(_inside(box, centre) for box, centre in zip(boxes, CENTRES_PX))
    assert all(imp.status == "ok" for imp in real_sheet.imprints)
    assert real_sheet.pixel_size_mm == pytest.approx(25.4 / 200) and real_sheet.pixel_size_source == "file metadata"
    # the halo (isolated dots about 25 mm across) is reported and not counted: the core is about 9 mm across
    for imp in real_sheet.imprints:
        assert 7.0 < 2 * imp.core.equivalent_radius_mm < 11.0
        assert 15.0 < 2 * math.sqrt(imp.halo_area_mm2 / math.pi) < 35.0
        assert 0.05 < imp.halo_coverage < 0.6


def test_the_replicates_of_a_real_sheet_agree_within_their_stated_uncertainty(real_sheet):
    """Six imprints of one test condition: each lies within two of its standard uncertainties of their mean."""
    areas = np.array([imp.area_mm2 for imp in real_sheet.imprints])
    stds = np.array([imp.area_std_mm2 for imp in real_sheet.imprints])
    assert np.all(np.abs(areas - areas.mean()) < 2 * stds)
    assert np.all(stds < 0.15 * areas)  # and the uncertainty is not inflated to get there


def test_turning_the_page_reverses_the_reading_order_and_keeps_the_areas(real_sheet):
    turned = read_sheet(SHEET, rotate_deg=180)
    assert [imp.region_px for imp in turned.imprints] == [imp.region_px for imp in real_sheet.imprints][::-1]
    assert [imp.area_mm2 for imp in turned.imprints] == pytest.approx(
        [imp.area_mm2 for imp in real_sheet.imprints][::-1], rel=0.01)


@pytest.mark.parametrize("turns", [0, 1, 2, 3])
def test_a_box_of_the_turned_page_maps_to_the_same_pixels_of_the_stored_one(turns):
    stored = np.arange(7 * 11).reshape(7, 11)
    turned = np.rot90(stored, turns)
    r0, r1, c0, c1 = _stored_box((1, 4, 2, 6), turns, stored.shape)
    assert sorted(turned[1:4, 2:6].ravel()) == sorted(stored[r0:r1, c0:c1].ravel())


def _layer(rgb: np.ndarray, mask: np.ndarray, optical_density) -> None:
    """Lay a colour of the given optical densities over the masked pixels (Beer-Lambert: densities add)."""
    rgb[mask] *= 10 ** -np.asarray(optical_density, dtype=float)


def _dotted_cores(rgb: np.ndarray, x: np.ndarray, y: np.ndarray, cores, rng) -> None:
    """Stain `rgb` with imprints: a core of radius rc dotted at 70 %, a halo thinning from 8 % to none at 2.8 rc."""
    rows, cols = rgb.shape[:2]
    for cx, cy, rc in cores:
        r = np.hypot(x - cx, y - cy)
        cells = rng.random((rows, cols))
        stained = np.where(r <= rc, cells < 0.7, np.where(r <= 2.8 * rc, cells < 0.08 * (1 - (r - rc) / (1.8 * rc)),
                                                           False))
        depth = rng.uniform(0.15, 0.45, size=(rows, cols))
        rgb[stained] *= 10 ** -(depth[stained, None] * np.array(DYE_OPTICAL_DENSITY))


def synthetic_sheet(path: Path, dpi: float = 300.0, seed: int = 0, noise: float = 1.5) -> list[tuple[float, float, float]]:
    """A page of three imprints (dotted core of known radius in a halo of sparse dots) among tape, ink and text.

    Returns the cores' (x_mm, y_mm, radius_mm) in the page frame (x right, y up), in reading order.
    """
    rng = np.random.default_rng(seed)
    h = 25.4 / dpi
    rows, cols = int(120 / h), int(200 / h)
    y, x = (rows - 0.5 - np.arange(rows))[:, None] * h, (np.arange(cols) + 0.5)[None, :] * h
    rgb = np.full((rows, cols, 3), 1.0)
    _layer(rgb, (x > 170) | (y > 110), 0.05 * np.array(NEUTRAL_OPTICAL_DENSITY) + [0.02, 0.0, 0.0])  # grey-blue lid
    cores = [(40.0, 80.0, 4.0), (110.0, 82.0, 5.0), (60.0, 30.0, 3.5)]
    dot = 0.12  # mm: a developed capsule's dot
    _dotted_cores(rgb, x, y, cores, rng)
    assert h < dot * 1.5
    _layer(rgb, (np.abs(x - 75) < 6) & (y > 60) & (y < 100), 0.25 * np.array(YELLOW_OPTICAL_DENSITY))  # tape
    _layer(rgb, (np.abs(x - 150) < 7) & (y > 15) & (y < 100), 0.3 * np.array(YELLOW_OPTICAL_DENSITY))
    strokes = (np.abs(y - 50 - 3 * np.sin(x / 2)) < 0.25) & (x > 100) & (x < 140)  # blue handwriting
    _layer(rgb, strokes, [0.5, 0.25, 0.05])
    digits = ((np.abs(x - 20) < 0.3) | (np.abs(x - 24) < 0.3)) & (np.abs(y - 100) < 4)  # black pen
    _layer(rgb, digits, 0.8 * np.array(NEUTRAL_OPTICAL_DENSITY))
    noisy = np.clip(255 * rgb + rng.normal(0, noise, rgb.shape), 0, 255).astype(np.uint8)
    Image.fromarray(noisy).save(path, quality=90, dpi=(dpi, dpi))
    return cores


def test_synthetic_cores_are_read_within_their_uncertainty_among_tape_ink_and_text(tmp_path):
    """Known core radii: each area within its stated uncertainty (and 4 %), none of the decoys read."""
    path = tmp_path / "sheet.jpg"
    cores = synthetic_sheet(path)
    sheet = read_sheet(path)
    assert len(sheet.imprints) == len(cores)
    for imp, (cx, cy, rc) in zip(sheet.imprints, cores):
        true = math.pi * rc**2
        assert abs(imp.area_mm2 - true) <= imp.area_std_mm2
        assert abs(imp.area_mm2 / true - 1) < 0.04
        assert imp.core.centroid_mm == pytest.approx([cx, cy], abs=0.15)
        # the halo reaches to about 2.8 core radii, thinning out: its outline lies well beyond the core
        assert 2.0 * rc < math.sqrt(imp.halo_area_mm2 / math.pi) < 3.2 * rc


def test_filmcal_scan_writes_a_table_correct_batch_reads_and_an_overview(tmp_path):
    path = tmp_path / "sheet.jpg"
    cores = synthetic_sheet(path, dpi=200, seed=3)
    out = tmp_path / "imprints.csv"
    cli = [sys.executable, "-m", "filmcal.cli", "scan", str(path), "--out", str(out), "--film", "HS",
           "--force-kn", "100", "--offset-mm=-3"]
    p = subprocess.run(cli, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert p.stdout.startswith(f"{len(cores)} imprints on sheet.jpg")
    assert (tmp_path / "imprints.png").stat().st_size > 10_000
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(line for line in fh if not line.startswith("#")))
    assert [r["imprint"] for r in rows] == ["1", "2", "3"]
    assert all(r["film"] == "HS" and r["force_kn"] == "100" and r["offset_mm"] == "-3" for r in rows)
    for row, (_, _, rc) in zip(rows, cores):
        assert float(row["measured_area_mm2"]) == pytest.approx(math.pi * rc**2, rel=0.05)
    from filmcal.study.batch import read_batch

    header, batch_rows = read_batch(out)  # the table is a batch as it stands
    assert len(batch_rows) == 3 and "measured_area_std_mm2" in header
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((300, 400, 3), 240, dtype=np.uint8)).save(blank, dpi=(200, 200))
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "scan", str(blank), "--out", str(out)],
                       capture_output=True, text=True)
    assert p.returncode == 2 and "no imprint found" in p.stderr


@pytest.mark.parametrize("mode, problem", [("L", "greyscale"), ("I;16", "greyscale"), ("P", "palette")])
def test_a_grey_or_palette_sheet_is_refused_for_its_colours_not_for_a_cut_imprint(tmp_path, mode, problem):
    """A grey or palette copy of a good sheet was refused as 'the stain touches the image border': grey
    reads every tinted paper pixel as stain, a web palette dithers the paper into dye-coloured dots. Both
    now get one line that names what is wrong with the file, and nothing is written."""
    colour = tmp_path / "sheet.jpg"
    synthetic_sheet(colour, dpi=200, seed=5)
    image = Image.open(colour)
    converted = image.convert("L").convert("I;16") if mode == "I;16" else image.convert(mode)
    path = tmp_path / "sheet.png"
    converted.save(path, dpi=(200, 200))
    out = tmp_path / "imprints.csv"
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "scan", str(path), "--out", str(out)],
                       capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert problem in p.stderr and "sheet.png" in p.stderr
    assert not out.exists() and not (tmp_path / "imprints.png").exists()


def test_a_page_cropped_through_an_imprint_reads_the_others_and_the_batch_refuses_the_cut_one(real_sheet, tmp_path):
    """Cropping the real page through its first column of imprints refused the whole page ('the stain touches
    the image border'). Now the four whole imprints read as on the full page, the two cut ones are marked, and
    `correct --batch` marks their rows failed instead of correcting a part of an imprint as a whole one."""
    image = Image.open(SHEET)
    left = CENTRES_PX[0][0]  # through the middle of imprints 1 and 4
    path = tmp_path / "cropped.png"
    image.crop((left, 0, image.width, image.height)).save(path, dpi=image.info["dpi"])
    sheet = read_sheet(path)
    assert [imp.status for imp in sheet.imprints] == ["touches the page's edge: cut off", "ok", "ok"] * 2
    whole = {i: imp.area_mm2 for i, imp in enumerate(real_sheet.imprints) if i not in (0, 3)}
    for i, area in whole.items():
        assert sheet.imprints[i].area_mm2 == pytest.approx(area, abs=0.05)
    for i in (0, 3):
        assert 0.1 * real_sheet.imprints[i].area_mm2 < sheet.imprints[i].area_mm2 < 0.6 * real_sheet.imprints[i].area_mm2
    from filmcal.study.batch import _measurement

    with pytest.raises(ValueError, match="cut off; its area is not the whole imprint's"):
        _measurement({"film": "HS", "force_kn": "100", "measured_area_mm2": "8.3", "offset_mm": "-3",
                      "scan_status": sheet.imprints[0].status})


def test_a_resolution_given_against_the_files_own_is_said(tmp_path):
    """`--dpi 100` on the real page, which records 200 dpi, read every area 4 times larger (and two specks of
    dust as imprints) without a word; now it is said, with the factor. Agreeing with the file, or overriding a
    software default of 72 or 96 dpi, says nothing."""
    def scan(path, *extra):
        return subprocess.run([sys.executable, "-m", "filmcal.cli", "scan", str(path), "--out",
                               str(tmp_path / "t.csv"), *extra], capture_output=True, text=True)

    p = scan(SHEET, "--dpi", "100")
    warned = [line for line in p.stderr.splitlines() if "warning" in line]
    assert p.returncode == 0 and len(warned) == 1
    assert "records 200 dpi; read at the 100 dpi given instead" in warned[0] and "x4)" in warned[0]
    assert not [line for line in scan(SHEET, "--dpi", "200").stderr.splitlines() if "warning" in line]
    default = tmp_path / "sheet96.jpg"
    Image.open(SHEET).save(default, dpi=(96, 96), quality=95)
    assert not [line for line in scan(default, "--dpi", "200").stderr.splitlines() if "warning" in line]


@pytest.mark.parametrize("noise", [0.0, 2.5])
def test_a_noisy_lossless_scan_reads_each_imprint_apart(tmp_path, noise):
    """Grey levels scattered by 2-3 of 255 (a flatbed's noise, kept by PNG where JPEG smooths it) dot about 6 %
    of white paper above `DOT_INTENSITY`: every imprint of the page was found as one, its halo the whole page,
    cut off by its edges. The paper's own dot fraction is now the level's floor: the three cores are read apart,
    each within its stated uncertainty of its known area, none touching the page's edge."""
    rng = np.random.default_rng(11)
    dpi = 300.0
    h = 25.4 / dpi
    rows, cols = int(90 / h), int(160 / h)
    y, x = (rows - 0.5 - np.arange(rows))[:, None] * h, (np.arange(cols) + 0.5)[None, :] * h
    rgb = np.full((rows, cols, 3), 1.0)
    cores = [(30.0, 60.0, 4.0), (90.0, 60.0, 5.0), (60.0, 25.0, 3.5)]
    _dotted_cores(rgb, x, y, cores, rng)
    path = tmp_path / "noisy.png"
    Image.fromarray(np.clip(255 * rgb + rng.normal(0, noise, rgb.shape), 0, 255).astype(np.uint8)).save(
        path, dpi=(dpi, dpi))
    sheet = read_sheet(path)
    assert len(sheet.imprints) == len(cores)
    for imp, (cx, cy, rc) in zip(sheet.imprints, cores):
        assert abs(imp.area_mm2 - math.pi * rc**2) <= imp.area_std_mm2
        assert imp.core.centroid_mm == pytest.approx([cx, cy], abs=0.15)
        assert math.sqrt(imp.halo_area_mm2 / math.pi) < 3.2 * rc and imp.status == "ok"


def test_the_real_sheet_scanned_with_a_noisy_sensor_reads_its_six_imprints(real_sheet, tmp_path):
    """The real page with its grey levels scattered by 5 of 255 (a camera or a fast scanner; saved lossless)
    read 46 imprints: the noise dotted a third of the paper and the tape. A dot now stands `DOT_NOISE_SIGMAS`
    times the scan's own noise above the paper: the six imprints are read where they lie, each core within its
    stated uncertainty of the clean scan's, and the clean scan keeps `DOT_INTENSITY`."""
    from filmcal.correction.sheet import DOT_INTENSITY

    pixels = np.asarray(Image.open(SHEET).convert("RGB"), dtype=float)
    noisy = tmp_path / "noisy.png"
    Image.fromarray(np.clip(pixels + np.random.default_rng(3).normal(0.0, 5.0, pixels.shape), 0, 255)
                    .astype(np.uint8)).save(noisy, dpi=(200, 200))
    sheet = read_sheet(noisy)
    assert real_sheet.dot_intensity == DOT_INTENSITY and sheet.dot_intensity > 2 * DOT_INTENSITY
    assert len(sheet.imprints) == 6
    assert all(_inside(imp.region_px, centre) for imp, centre in zip(sheet.imprints, CENTRES_PX))
    for imp, clean in zip(sheet.imprints, real_sheet.imprints):
        assert abs(imp.area_mm2 - clean.area_mm2) <= math.hypot(imp.area_std_mm2, clean.area_std_mm2)
        assert imp.status == "ok"


def test_a_file_without_resolution_read_at_a_given_dpi_is_read(tmp_path):
    """A PNG without resolution metadata, read with --dpi, ended in 'cannot convert float NaN to integer' (the
    check of the file's own resolution against the given one rounded a missing one): a blank page now says that
    it holds no imprint."""
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((300, 400, 3), 255, dtype=np.uint8)).save(blank)
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "scan", str(blank), "--dpi", "150", "--out",
                        str(tmp_path / "out.csv")], capture_output=True, text=True)
    assert p.returncode == 2 and "no imprint found" in p.stderr, p.stderr
