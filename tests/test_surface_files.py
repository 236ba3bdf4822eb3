"""Measured surfaces as instruments write them: x3p maps and profiles, stylus line profiles; their checks."""
from __future__ import annotations

import json
import math
import subprocess
import sys
import zipfile

import numpy as np
import pytest

from filmcal.contact.roughness import RoughSurface
from filmcal.contact.surface_files import read_line_profile, read_surface_file, read_x3p


def write_x3p(path, heights_um: np.ndarray, pixel_um: float, dtype: str = "D", feature: str = "SUR",
              z_increment: float = 1.0) -> None:
    """An ISO 5436-2 x3p archive as the standard lays it out: metres, x fastest, little-endian."""
    nx, ny = heights_um.shape
    z = heights_um.T.ravel() * 1e-6
    if dtype in ("I", "L"):
        data = np.round(z / z_increment).astype("<i2" if dtype == "I" else "<i4")
        cz = f"<AxisType>A</AxisType><DataType>{dtype}</DataType><Increment>{z_increment!r}</Increment><Offset>0</Offset>"
    else:
        data = z.astype("<f8" if dtype == "D" else "<f4")
        cz = f"<AxisType>A</AxisType><DataType>{dtype}</DataType>"
    inc = pixel_um * 1e-6
    xml = f"""<?xml version="1.0" encoding="UTF-8"?>
<p:ISO5436_2 xmlns:p="http://www.opengps.eu/2008/ISO5436_2">
 <Record1><Revision>ISO5436 - 2000</Revision><FeatureType>{feature}</FeatureType>
  <Axes>
   <CX><AxisType>I</AxisType><DataType>D</DataType><Increment>{inc!r}</Increment><Offset>0</Offset></CX>
   <CY><AxisType>I</AxisType><DataType>D</DataType><Increment>{inc!r}</Increment><Offset>0</Offset></CY>
   <CZ>{cz}</CZ>
  </Axes></Record1>
 <Record3><MatrixDimension><SizeX>{nx}</SizeX><SizeY>{ny}</SizeY><SizeZ>1</SizeZ></MatrixDimension>
  <DataLink><PointDataLink>bindata/data.bin</PointDataLink></DataLink></Record3>
</p:ISO5436_2>"""
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("main.xml", xml)
        zf.writestr("bindata/data.bin", data.tobytes())


@pytest.fixture(scope="module")
def surface():
    # a map ten roll-off wavelengths wide, as an instrument's field of view is: levelling removes no roughness
    return RoughSurface.synthetic(ra_um=1.5, n=256, size_um=200.0, rolloff_wavelength_um=20.0, seed=4)


@pytest.mark.parametrize("dtype", ["D", "F", "I"])
def test_an_x3p_map_reads_back_its_heights_and_ra(tmp_path, surface, dtype):
    path = tmp_path / "wheel.x3p"
    write_x3p(path, surface.heights_um, surface.pixel_um, dtype, z_increment=1e-9)
    read = read_x3p(path)
    assert read.pixel_um == pytest.approx(surface.pixel_um)
    assert read.heights_um.shape == surface.heights_um.shape
    assert read.ra_um == pytest.approx(surface.ra_um, rel=0.02 if dtype == "I" else 0.005)
    assert "plane removed" in read.description


def test_a_tilted_map_is_levelled_and_a_curved_one_refused(tmp_path, surface):
    n = surface.heights_um.shape[0]
    x = np.arange(n) * surface.pixel_um
    tilted = surface.heights_um + 0.05 * x[:, None] + 0.02 * x[None, :]
    write_x3p(tmp_path / "tilt.x3p", tilted, surface.pixel_um)
    assert read_x3p(tmp_path / "tilt.x3p").ra_um == pytest.approx(surface.ra_um, rel=0.02)
    # a wheel of radius 460 mm measured with its form: sagitta over 100 um is 0.0027 um, over 10 mm 27 um
    wide = RoughSurface.synthetic(ra_um=0.5, n=128, size_um=500.0, rolloff_wavelength_um=50.0, seed=1)
    xw = (np.arange(128) - 64) * wide.pixel_um
    curved = wide.heights_um + (xw[:, None] ** 2) / (2 * 0.46e3)  # radius 0.46 mm: a strong form
    write_x3p(tmp_path / "curved.x3p", curved, wide.pixel_um)
    with pytest.raises(ValueError, match="not levelled"):
        read_x3p(tmp_path / "curved.x3p")


def test_a_line_profile_across_the_lay_reads_its_ra(tmp_path):
    """A sine of amplitude A has Ra = 2 A / pi exactly; a tilt is removed with the mean line."""
    spacing_mm, amp = 0.0005, 3.0
    x = np.arange(0.0, 2.0, spacing_mm)
    z = amp * np.sin(2 * np.pi * x / 0.1) + 4.0 * x  # turning marks 0.1 mm apart, a tilt of 4 um/mm
    path = tmp_path / "profile.csv"
    path.write_text("x_mm,z_um\n" + "\n".join(f"{a:.6f},{b:.6f}" for a, b in zip(x, z)))
    surface = read_line_profile(path)
    assert surface.ra_um == pytest.approx(2 * amp / math.pi, rel=0.02)
    assert surface.heights_um.shape[1] == 8 and np.all(surface.heights_um == surface.heights_um[:, :1])
    assert read_surface_file(path).ra_um == pytest.approx(surface.ra_um)  # found by its header


@pytest.mark.parametrize("case, match", [
    ("coarse", "too coarse"), ("small", "too small"), ("nan", "invalid"), ("cloud", "point clouds"),
    ("zip", "not an x3p archive"), ("truncated", "expected")])
def test_bad_surfaces_get_one_clear_line(tmp_path, surface, case, match):
    path = tmp_path / f"{case}.x3p"
    h = surface.heights_um
    if case == "coarse":
        write_x3p(path, h, 20.0)
    elif case == "small":
        write_x3p(path, h[:32, :32], surface.pixel_um)
    elif case == "nan":
        bad = h.copy()
        bad[3, 4] = np.nan
        write_x3p(path, bad, surface.pixel_um)
    elif case == "cloud":
        write_x3p(path, h, surface.pixel_um, feature="PCL")
    elif case == "zip":
        path.write_text("not a zip")
    else:
        write_x3p(path, h, surface.pixel_um)
        with zipfile.ZipFile(path) as zf:
            xml = zf.read("main.xml")
        with zipfile.ZipFile(path, "w") as zf:
            zf.writestr("main.xml", xml)
            zf.writestr("bindata/data.bin", b"\0" * 100)
    with pytest.raises(ValueError, match=match):
        read_x3p(path)


def test_wheelrail_and_correct_report_the_measured_ra_of_an_x3p_and_a_profile(tmp_path, surface, quick_study):
    """The x3p map of a synthetic surface and the stylus profile of a sine (Ra = 2 A / pi) through `filmcal
    wheelrail` and `filmcal correct` (on a study): each command reports the Ra it read within 2 %."""
    path = tmp_path / "wheel.x3p"
    write_x3p(path, surface.heights_um, surface.pixel_um)
    x = np.arange(0.0, 1.0, 0.0005)
    profile = tmp_path / "rail.csv"
    profile.write_text("x_mm,z_um\n" + "\n".join(f"{a:.6f},{1.2 * np.sin(2 * np.pi * a / 0.05):.6f}" for a in x))
    base = [sys.executable, "-m", "filmcal.cli", "wheelrail", "--offset-mm=0", "--force-kn", "50", "--film", "HS",
            "--film-modulus-mpa", "2500", "--grid-mm", "0.2", "--json"]
    p = subprocess.run(base + ["--wheel-roughness-map", str(path), "--rail-roughness-map", str(profile)],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert out["roughness"]["wheel_ra_um"] == pytest.approx(surface.ra_um, rel=0.02)
    assert out["roughness"]["rail_ra_um"] == pytest.approx(2 * 1.2 / math.pi, rel=0.02)
    assert out["imprint_area_mm2"] > 0
    bad = subprocess.run(base + ["--wheel-roughness-map", str(tmp_path / "none.x3p")], capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    import shutil

    study = tmp_path / "study"  # a copy: the rough solves kept by this answer stay out of the shared study
    shutil.copytree(quick_study[0], study)
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--measured-area-mm2", "150",
                        "--offset-mm=-3", "--force-kn", "100", "--study-dir", str(study), "--json", "--progress",
                        "quiet", "--roughness-draws", "2", "--wheel-roughness-map", str(path),
                        "--rail-roughness-map", str(profile)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    read = json.loads(p.stdout)["provenance"]["roughness"]
    assert read["wheel_ra_um"] == pytest.approx(surface.ra_um, rel=0.02)
    assert read["rail_ra_um"] == pytest.approx(2 * 1.2 / math.pi, rel=0.02)
    assert read["wheel_map"]["file"] == str(path) and read["rail_map"]["file"] == str(profile)


@pytest.mark.parametrize("amplitude_um, match", [(1e300, "heights reach 1e\\+300 um"), (1e8, "heights reach 1e\\+08 um"),
                                                 (60.0, "Ra 38\\.[12] um once levelled"),
                                                 (0.005, "Ra 0.00318 um once levelled")])
def test_a_profile_with_implausible_heights_is_refused_in_one_line_naming_it(tmp_path, amplitude_um, match):
    """+-1e300 um ended in a ZeroDivisionError traceback (exit 70), +-1e8 um in 'the contact reaches the end of
    the profile'. Ra = 2 A / pi of a sine says which amplitudes lie outside 0.01-30 um."""
    x = np.arange(0.0, 1.0, 0.0005)
    path = tmp_path / "odd.csv"
    path.write_text("x_mm,z_um\n" + "\n".join(f"{a:.6f},{amplitude_um * math.sin(2 * math.pi * a / 0.05):.6g}"
                                               for a in x))
    with pytest.raises(ValueError, match=match):
        read_surface_file(path)
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "wheelrail", "--offset-mm=-3", "--force-kn", "100",
                        "--no-film", "--wheel-roughness-map", str(path)], capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "odd.csv" in p.stderr, p.stderr


def test_a_jpeg_or_other_binary_map_is_refused_saying_what_is_read(tmp_path):
    """A JPEG height map read as a CSV said 'not a text file of heights ('utf-8' codec can't decode byte 0xff ...)'.
    JPEG's lossy compression alters heights, so it is refused by name; other binary files say which formats are
    read."""
    from PIL import Image

    grey = Image.fromarray((np.random.default_rng(0).random((64, 64)) * 255).astype(np.uint8))
    grey.save(tmp_path / "map.jpg")
    grey.save(tmp_path / "map.bmp")
    with pytest.raises(ValueError, match="JPEG's lossy compression alters the heights; save the map as a 16-bit PNG"):
        read_surface_file(tmp_path / "map.jpg", pixel_um=2.0)
    with pytest.raises(ValueError, match="a binary file, not a text file of heights .*PNG or TIFF.*x3p"):
        read_surface_file(tmp_path / "map.bmp", pixel_um=2.0)
    for reading in (["--roughness-pixel-um", "2"], ["--roughness-pixel-um", "2", "--roughness-height-range-um", "10"]):
        p = subprocess.run([sys.executable, "-m", "filmcal.cli", "wheelrail", "--offset-mm=-3", "--force-kn", "100",
                            "--no-film", "--wheel-roughness-map", str(tmp_path / "map.jpg"), *reading],
                           capture_output=True, text=True)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr
        assert "map.jpg: a JPEG's lossy compression" in p.stderr, p.stderr
