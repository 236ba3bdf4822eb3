"""Scanned imprints: synthetic scans of shapes with analytic areas, written and read back with Pillow."""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from filmcal._errors import DamagedFileError
from filmcal.correction import measure_imprint, otsu_threshold, read_imprint, stain_intensity
from filmcal.correction.imprint import DYE_OPTICAL_DENSITY, NEUTRAL_OPTICAL_DENSITY, YELLOW_OPTICAL_DENSITY

REPO = Path(__file__).resolve().parents[1]
PAPER_RGB = np.array([245.0, 243.0, 240.0])
STAIN_RGB = np.array([215.0, 60.0, 120.0])  # red-magenta Prescale colour


def coverage(shape, inside, supersample=4) -> np.ndarray:
    """Fraction of each pixel covered by a shape (pixel centres at integer + 0.5, row 0 at the top).

    ``inside(x, y)`` takes image coordinates in pixels with x to the right and y up from the lower-left
    corner, so that the analytic areas and centroids are in the frame `measure_imprint` reports.
    """
    rows, cols = shape
    sub = (np.arange(supersample) + 0.5) / supersample
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    cover = np.zeros(shape)
    for dy in sub:
        for dx in sub:
            cover += inside(c + dx, rows - (r + dy))
    return cover / supersample**2


def ellipse(cx, cy, ax, ay):
    return lambda x, y: ((x - cx) / ax) ** 2 + ((y - cy) / ay) ** 2 <= 1.0


def red_on_white(cover, noise=4.0, seed=0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rgb = PAPER_RGB * (1 - cover[..., None]) + STAIN_RGB * cover[..., None]
    return np.clip(np.rint(rgb + noise * rng.standard_normal(rgb.shape)), 0, 255).astype(np.uint8)


def test_otsu_splits_two_equal_modes_midway():
    """Two equally weighted normal modes of equal spread: by symmetry the best cut is their midpoint."""
    rng = np.random.default_rng(1)
    values = np.clip(np.concatenate([rng.normal(0.2, 0.1, 50000), rng.normal(0.7, 0.1, 50000)]), 0, 1)
    assert otsu_threshold(values) == pytest.approx(0.45, abs=0.01)
    two_levels = np.r_[np.full(900, 0.1), np.full(100, 0.8)]  # an empty gap: the middle of the gap
    assert otsu_threshold(two_levels) == pytest.approx(0.45, abs=0.01)
    with pytest.raises(ValueError, match="no contrast"):
        otsu_threshold(np.full(100, 0.3))


def _pixel(optical_density) -> np.ndarray:
    """The 8-bit colour of a layer of given (R, G, B) optical densities on white paper (Beer-Lambert)."""
    return np.rint(255 * 10 ** -np.asarray(optical_density, dtype=float))


def test_stain_intensity_follows_the_dye_and_ignores_tape_ink_and_grey():
    """By Beer-Lambert a layer's densities add: dye of green density k under any grey or yellow reads 1 - 10^-k."""
    dye, grey, yellow = (np.array(c) for c in (DYE_OPTICAL_DENSITY, NEUTRAL_OPTICAL_DENSITY, YELLOW_OPTICAL_DENSITY))
    blue_ink = np.array([0.30, 0.12, 0.02])  # absorbs red and some green, passes blue
    layers = [0.5 * dye, 0.5 * dye + 0.2 * grey, 0.5 * dye + 0.15 * yellow, 0.8 * grey, 0.3 * yellow, blue_ink,
              blue_ink + 0.3 * grey, np.zeros(3)]
    rgb = np.zeros((3, 3, 3), dtype=np.uint8)
    rgb.reshape(-1, 3)[: len(layers)] = [_pixel(od) for od in layers]
    rgb.reshape(-1, 3)[len(layers):] = 255
    got = stain_intensity(rgb).ravel()[: len(layers)]
    assert got[:3] == pytest.approx(1 - 10**-0.5, abs=0.01)  # the dye, alone, under grey, under tape
    assert np.all(got[3:] < 0.005)  # grey, tape, blue ink, ink on grey, paper (to the 8-bit rounding)
    rgba = np.zeros((3, 3, 4), dtype=np.uint8)  # black but fully transparent
    assert np.all(stain_intensity(rgba) == 0.0)
    grey16 = np.full((3, 3), 65535 // 4, dtype=np.uint16)
    assert stain_intensity(grey16)[0, 0] == pytest.approx(0.75, abs=1e-4)



@pytest.mark.parametrize("layer, sigma", [("dye", 4.0), ("dye on tape", 6.0), ("dye", 0.0)])
def test_intensity_noise_is_the_scatter_of_the_stain_intensity_of_a_uniform_page(layer, sigma):
    """A uniform lightly stained page (no clipping at paper) with Gaussian noise of `sigma` grey levels in each
    channel: `intensity_noise`, carried through the unmixing to first order, is the standard deviation of the
    page's `stain_intensity` measured over its pixels (a second way, by sampling), within 5 %; a noiseless page
    reads 0."""
    from filmcal.correction.imprint import intensity_noise

    dye, yellow = np.array(DYE_OPTICAL_DENSITY), np.array(YELLOW_OPTICAL_DENSITY)
    density = 0.3 * dye + (0.3 * yellow if layer == "dye on tape" else 0.0)
    rng = np.random.default_rng(5)
    rgb = 255 * 10 ** -density + rng.normal(0.0, sigma, (400, 600, 3))
    page = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    measured = float(np.std(stain_intensity(page)))
    if sigma == 0.0:
        assert intensity_noise(page) == 0.0
    else:
        assert intensity_noise(page) == pytest.approx(measured, rel=0.05)

@pytest.mark.parametrize("antialiased", [True, False])
def test_disc_area_centroid_and_outline(antialiased):
    h = 0.05
    cx, cy, radius = 161.3, 139.6, 90.2  # pixels
    cover = coverage((300, 320), ellipse(cx, cy, radius, radius))
    image = 0.6 * (cover if antialiased else (cover >= 0.5))
    imp = measure_imprint(image, h)
    true_area = math.pi * (radius * h) ** 2
    assert abs(imp.area_mm2 - true_area) <= imp.area_std_mm2
    assert abs(imp.area_mm2 / true_area - 1) < (1e-3 if antialiased else 2e-3)
    assert imp.area_std_mm2 / true_area < 0.01
    assert imp.centroid_mm == pytest.approx([cx * h, cy * h], abs=0.05 * h)
    assert imp.n_regions == 1 and np.array_equal(imp.outlines_mm[0][0], imp.outlines_mm[0][-1])
    r = np.hypot(imp.outlines_mm[0][:, 0] - cx * h, imp.outlines_mm[0][:, 1] - cy * h)
    # sub-pixel where the edge is blurred (a box-filtered edge interpolated linearly is off by up to about a
    # quarter pixel at 45 degrees); a hard edge is located to within the pixel
    max_px, rms_px = (0.3, 0.1) if antialiased else (0.75, 0.35)
    assert np.max(np.abs(r - radius * h)) < max_px * h
    assert np.sqrt(np.mean((r - radius * h) ** 2)) < rms_px * h
    assert imp.equivalent_radius_mm == pytest.approx(radius * h, rel=1e-3)


def test_two_patches_holes_and_specks():
    h = 0.04
    shape = (260, 400)
    two = coverage(shape, lambda x, y: ellipse(110, 130, 60, 80)(x, y) | ellipse(290, 120, 45, 45)(x, y))
    hole = coverage(shape, ellipse(110, 130, 6, 6))  # an unstained spot inside the first patch
    specks = np.zeros(shape)
    specks[20:23, 20:23] = specks[240:242, 370:372] = 1.0  # dust, far below 1 mm2
    imp = measure_imprint(0.7 * np.clip(two - hole + specks, 0, 1), h)
    true_area = math.pi * (60 * 80 + 45 * 45) * h**2
    assert imp.n_regions == 2
    assert abs(imp.area_mm2 - true_area) <= imp.area_std_mm2
    assert abs(imp.area_mm2 / true_area - 1) < 2e-3
    small = measure_imprint(0.7 * two, h, min_region_mm2=15.0)  # patches of 24.1 and 10.2 mm2
    assert small.n_regions == 1  # the smaller patch dropped when below min_region_mm2
    assert small.area_mm2 == pytest.approx(math.pi * 60 * 80 * h**2, rel=2e-3)


def test_red_on_white_png_with_noise_and_dpi_metadata(tmp_path):
    cover = coverage((500, 520), ellipse(262.0, 248.5, 177.2, 153.4))
    path = tmp_path / "imprint.png"
    Image.fromarray(red_on_white(cover)).save(path, dpi=(600, 600))
    imp = read_imprint(path)
    h = 25.4 / 600
    assert imp.pixel_size_source == "file metadata"
    assert imp.pixel_size_mm == pytest.approx(h, rel=1e-4)  # PNG stores pixels per metre
    true_area = math.pi * 177.2 * 153.4 * h**2
    assert abs(imp.area_mm2 - true_area) <= imp.area_std_mm2
    assert abs(imp.area_mm2 / true_area - 1) < 1e-3
    from filmcal.correction.imprint import ScanResolutionWarning

    with pytest.warns(ScanResolutionWarning, match="x4"):  # an explicit resolution overrides the metadata, said
        doubled = read_imprint(path, dpi=300)
    assert doubled.pixel_size_source == "dpi"
    assert doubled.area_mm2 == pytest.approx(4 * imp.area_mm2, rel=1e-3)
    with pytest.warns(ScanResolutionWarning, match="records 599.999 dpi"):
        given = read_imprint(path, mm_per_pixel=0.1)
    assert given.area_mm2 == pytest.approx(imp.area_mm2 * (0.1 / imp.pixel_size_mm) ** 2, rel=1e-6)


@pytest.mark.parametrize("bits", [8, 16])
def test_greyscale_tiff(tmp_path, bits):
    cover = coverage((300, 300), ellipse(150.0, 151.0, 110.0, 80.0))
    white = 255 if bits == 8 else 65535
    grey = np.rint(white * (0.95 - 0.55 * cover)).astype(np.uint8 if bits == 8 else np.uint16)
    path = tmp_path / f"imprint{bits}.tif"
    Image.fromarray(grey).save(path, dpi=(400, 400))
    imp = read_imprint(path)
    h = 25.4 / 400
    assert imp.pixel_size_mm == pytest.approx(h, rel=1e-9)
    assert imp.contrast == pytest.approx(0.55, abs=0.05)
    true_area = math.pi * 110 * 80 * h**2
    assert abs(imp.area_mm2 - true_area) <= imp.area_std_mm2
    assert abs(imp.area_mm2 / true_area - 1) < 1e-3


def test_gradual_edge_has_a_larger_threshold_uncertainty():
    """A stain fading over many pixels leaves where it ends uncertain: the threshold part grows."""
    rows = cols = 200
    r, c = np.mgrid[0:rows, 0:cols]
    dist = np.hypot(c + 0.5 - 100, rows - (r + 0.5) - 100)
    sharp = measure_imprint(0.6 * np.clip(60.5 - dist, 0, 1), 0.05)
    soft = measure_imprint(0.6 * np.clip((70 - dist) / 20, 0, 1), 0.05)
    assert soft.area_std_threshold_mm2 > 5 * sharp.area_std_threshold_mm2
    # the fade is linear, so the contour at the Otsu level lies where the intensity equals it
    expected_radius = (70 - 20 * soft.threshold / 0.6) * 0.05
    assert soft.equivalent_radius_mm == pytest.approx(expected_radius, abs=0.05 * 0.05)


def test_bad_input(tmp_path):
    with pytest.raises(FileNotFoundError):
        read_imprint(tmp_path / "missing.png", dpi=600)
    not_image = tmp_path / "notes.png"
    not_image.write_text("not an image")
    with pytest.raises(ValueError, match="not an image"):
        read_imprint(not_image, dpi=600)
    stained = red_on_white(coverage((120, 120), ellipse(60, 60, 30, 30)), noise=0)
    bare = tmp_path / "bare.png"
    Image.fromarray(stained).save(bare)  # no resolution metadata
    with pytest.raises(ValueError, match="dpi or mm_per_pixel"):
        read_imprint(bare)
    placeholder = tmp_path / "bare.tif"
    Image.fromarray(stained).save(placeholder)  # Pillow writes a placeholder of 1 dpi
    with pytest.raises(ValueError, match="dpi or mm_per_pixel"):
        read_imprint(placeholder)
    with pytest.raises(ValueError, match="not both"):
        read_imprint(bare, dpi=600, mm_per_pixel=0.04)
    for bad in (-600, 0, float("nan")):
        with pytest.raises(ValueError, match="dpi"):
            read_imprint(bare, dpi=bad)
    with pytest.raises(ValueError, match="mm_per_pixel"):
        read_imprint(bare, mm_per_pixel=-0.1)
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((100, 100, 3), 250, dtype=np.uint8)).save(blank, dpi=(600, 600))
    with pytest.raises(ValueError, match="no contrast|no stain"):
        read_imprint(blank)
    noisy_blank = np.clip(240 + 3 * np.random.default_rng(0).standard_normal((100, 100, 3)), 0, 255)
    with pytest.raises(ValueError, match="no stain"):
        measure_imprint(stain_intensity(noisy_blank.astype(np.uint8)), 0.05)
    cut = 0.6 * coverage((100, 100), ellipse(10, 50, 30, 30))  # runs off the left edge
    with pytest.raises(ValueError, match="border"):
        measure_imprint(cut, 0.05)
    disc = 0.6 * coverage((100, 100), ellipse(50, 50, 20, 20))
    with pytest.raises(ValueError, match="threshold"):
        measure_imprint(disc, 0.05, threshold=1.5)
    with pytest.raises(ValueError, match="min_region_mm2"):
        measure_imprint(disc, 0.05, min_region_mm2=100.0)  # the disc is 3.1 mm2
    with pytest.raises(ValueError, match="pixel_size_mm"):
        measure_imprint(disc, -0.05)


def run_cli(*args):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", *args],
                          capture_output=True, text=True, env=env, timeout=120)


def test_command_rejects_bad_imprint_input(tmp_path):
    blank = tmp_path / "blank.png"
    Image.fromarray(np.full((60, 60, 3), 250, dtype=np.uint8)).save(blank)
    wheel = ["--offset-mm=-3", "--force-kn", "100", "--study-dir", str(tmp_path), "--json"]
    cases = [
        ["--scan", str(tmp_path / "missing.png"), "--dpi", "600", *wheel],
        ["--scan", str(blank), *wheel],  # no pixel size
        ["--scan", str(blank), "--dpi", "600", *wheel],  # no stain
        ["--scan", str(blank), "--dpi", "600", "--mm-per-pixel", "0.04", *wheel],
        ["--scan", str(blank), "--dpi=-600", *wheel],
        ["--scan", str(blank), "--dpi", "600", "--measured-area-mm2", "150", *wheel],
        ["--dpi", "600", "--measured-area-mm2", "150", *wheel],  # --dpi without --scan
    ]
    for args in cases:
        p = run_cli(*args)
        assert p.returncode == 2, (args, p.stderr)
        assert len(p.stderr.strip().splitlines()) == 1, (args, p.stderr)
        assert not p.stdout


def _scan_png(path: Path) -> bytes:
    stained = red_on_white(coverage((120, 120), ellipse(60, 60, 30, 30)), noise=0)
    Image.fromarray(stained).save(path, dpi=(600, 600))
    return path.read_bytes()


@pytest.mark.parametrize("cut", [0.3, 0.6, 0.9])
def test_truncated_scan_names_the_file(tmp_path, cut):
    data = _scan_png(tmp_path / "whole.png")
    truncated = tmp_path / "truncated.png"
    truncated.write_bytes(data[: int(cut * len(data))])
    with pytest.raises(DamagedFileError, match="truncated.png") as info:
        read_imprint(truncated)
    assert "\n" not in str(info.value)


def test_garbled_scan_names_the_file(tmp_path):
    data = bytearray(_scan_png(tmp_path / "whole.png"))
    rng = np.random.default_rng(3)
    for i in rng.integers(60, len(data) - 20, size=40):  # past the header: the pixel data are garbled
        data[i] ^= 0xFF
    garbled = tmp_path / "garbled.png"
    garbled.write_bytes(bytes(data))
    with pytest.raises(DamagedFileError, match="garbled.png"):
        read_imprint(garbled)


def test_decompression_bomb_refused_before_decoding(tmp_path):
    from filmcal.correction.imprint import MAX_IMPRINT_PIXELS

    # a 1-bit image: small on disk, far more pixels than an imprint scan
    side = int(math.isqrt(MAX_IMPRINT_PIXELS)) + 100
    big = tmp_path / "big.png"
    Image.new("1", (side, side)).save(big, dpi=(600, 600))
    assert big.stat().st_size < 2_000_000
    with pytest.raises(ValueError, match="big.png: .* million pixels .*: crop it or scan it at a lower resolution"):
        read_imprint(big)
    # beyond Pillow's own bomb limit: its error is reported with the file's name
    huge = tmp_path / "huge.png"
    side = int(math.isqrt(2 * Image.MAX_IMAGE_PIXELS)) + 100
    Image.new("1", (side, side)).save(huge)
    with pytest.raises(DamagedFileError, match="huge.png"):
        read_imprint(huge)


def test_command_names_damaged_scan(tmp_path):
    data = _scan_png(tmp_path / "whole.png")
    (tmp_path / "cut.png").write_bytes(data[: len(data) // 2])
    p = run_cli("--scan", str(tmp_path / "cut.png"), "--offset-mm=-3", "--force-kn", "100",
                "--study-dir", str(tmp_path), "--json")
    assert p.returncode == 2, p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    assert not p.stdout
