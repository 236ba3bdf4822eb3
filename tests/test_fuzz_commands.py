"""Fuzzing the commands with values that parse but are wrong, and with damaged input files.

Each case runs the real command in-process (`filmcal.cli.main`) in a working
folder holding a few prepared files and studies, and asserts the error
contract: exit status 2, exactly one line on stderr that names the option or
the file, no traceback, nothing on stdout, and no file created, changed or
removed anywhere in the folder (a snapshot of every file's size, modification
time and SHA-256). Every case must be refused before any heavy work: a guard
interrupts a case that runs longer than `CASE_LIMIT_S`. The slow tier runs
cases of every command again as a user does, ``python -m filmcal.cli`` in a
process of its own (`test_every_command_as_a_process`): the same contract,
from outside.
"""
from __future__ import annotations

import hashlib
import os
import signal
import sqlite3
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from filmcal import cli

CASE_LIMIT_S = 20


class CaseTooLong(BaseException):
    """Raised by the guard: the command started work instead of refusing its input."""


@pytest.fixture
def guard():
    def alarm(signum, frame):
        raise CaseTooLong(f"the command ran past {CASE_LIMIT_S} s instead of refusing its input")
    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(CASE_LIMIT_S)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


def write_png(path: Path, truncate: bool = False) -> None:
    import numpy as np
    from PIL import Image

    img = np.full((80, 80, 3), 245, dtype=np.uint8)
    img[20:60, 20:60] = (215, 60, 120)
    Image.fromarray(img).save(path, dpi=(600, 600))
    if truncate:
        data = path.read_bytes()
        path.write_bytes(data[: len(data) // 2])


@pytest.fixture(scope="module")
def bomb_png(tmp_path_factory) -> bytes:
    """A PNG of 90 million pixels in 11 kB (above Pillow's decompression-bomb limit)."""
    from PIL import Image

    path = tmp_path_factory.mktemp("bomb") / "bomb.png"
    Image.new("1", (9500, 9500)).save(path)
    return path.read_bytes()


@pytest.fixture
def folder(tmp_path, monkeypatch, bomb_png):
    """A working folder with good and bad inputs of every kind."""
    monkeypatch.chdir(tmp_path)
    return make_folder(tmp_path, bomb_png)


def make_folder(tmp_path: Path, bomb_png: bytes) -> Path:
    """Fill `tmp_path` with the good and bad inputs of every kind."""
    (tmp_path / "design.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,75\n")
    (tmp_path / "binary.csv").write_bytes(b"\x00\x01\xffgarbage\xfe")
    (tmp_path / "empty.csv").write_bytes(b"")
    (tmp_path / "wrongcols.csv").write_text("a,b\n1,2\n")
    (tmp_path / "nan.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\nnan,0.33,450,75\n")
    (tmp_path / "negative.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,-450,75\n")
    (tmp_path / "ragged.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33\n")
    (tmp_path / "badprofile.csv").write_text("y_mm,z_mm\n0,nan\n1,2\n")
    (tmp_path / "hugeprofile.csv").write_text("y_mm,z_mm\n" + "".join(f"{y},{1e300 if abs(y) > 20 else -0.01 * y * y}\n"
                                                                     for y in range(-30, 31, 2)))
    # a flat "rail" 400 mm wide: wider than any wheel profile
    (tmp_path / "widerail.csv").write_text("y_mm,z_mm\n" + "".join(f"{y},{-1e-4 * y * y}\n" for y in range(-200, 201, 5)))
    (tmp_path / "law.csv").write_text("closure_um,pressure_mpa\n1,abc\n")
    (tmp_path / "decreasing.csv").write_text("closure_um,pressure_mpa\n0,0\n2,10\n1,20\n")
    (tmp_path / "nanprofile.csv").write_text("x_um,z_um\n" + "".join(f"{2 * i},{'nan' if i == 2 else i % 3}\n"
                                                                    for i in range(40)))
    (tmp_path / "hugelaw.csv").write_text("closure_um,pressure_mpa\n0,0\n1,10\n1e300,1e300\n")
    (tmp_path / "aug5.csv").write_text("a\n5\n0.5\n")
    (tmp_path / "films.toml").write_text('[LOT7]\nthickness_mm = "thick"\n')
    (tmp_path / "notoml.toml").write_bytes(b"[[[\x00")
    (tmp_path / "nested.toml").write_text("[films.XX]\nrange_mpa = [50, 130]\n")
    (tmp_path / "badact.toml").write_text("[XX]\nactivation_pressure_mpa = -5\n")
    (tmp_path / "garbled.sqlite").write_bytes(os.urandom(4096))
    (tmp_path / "empty.sqlite").write_bytes(b"")
    with sqlite3.connect(tmp_path / "other.sqlite") as conn:  # a database, not a campaign store
        conn.execute("create table t (x)")
    conn.close()
    good = (tmp_path / "design.csv").read_bytes()
    (tmp_path / "truncated.sqlite").write_bytes(b"SQLite format 3\x00" + good[:40])
    write_png(tmp_path / "cut.png", truncate=True)
    (tmp_path / "bomb.png").write_bytes(bomb_png)
    (tmp_path / "notimage.png").write_text("not an image")
    (tmp_path / "emptystudy").mkdir()
    (tmp_path / "badstudy").mkdir()
    (tmp_path / "badstudy" / "study.json").write_text('{"format": "filmcal-study", "films": {')
    (tmp_path / "binstudy").mkdir()
    (tmp_path / "binstudy" / "study.json").write_bytes(b"\xff\xfe\x00\x00")
    (tmp_path / "adir").mkdir()
    (tmp_path / "headeronly.csv").write_text("a\n")  # was 'sample needs at least 1 points, got 0'
    (tmp_path / "uncalibrated").mkdir()  # a study whose manifest records nothing: was reported with 0 figures
    from filmcal.study.manifest import Manifest

    Manifest.new(tmp_path / "uncalibrated" / "study.json").write()
    return tmp_path


def snapshot(folder: Path) -> dict[str, tuple]:
    """Every file's size, modification time and SHA-256 (folders and special files by their kind); lock files
    beside a store or study are not output."""
    out = {}
    for p in folder.rglob("*"):
        if p.name.endswith(".lock"):
            continue
        info = p.lstat()
        if stat.S_ISREG(info.st_mode):  # (a sparse file at an option's size cap: its size and time)
            digest = hashlib.sha256(p.read_bytes()).hexdigest() if info.st_size <= 2**24 else ""
            out[str(p.relative_to(folder))] = (info.st_size, info.st_mtime_ns, digest)
        else:
            out[str(p.relative_to(folder))] = ("dir" if stat.S_ISDIR(info.st_mode) else "special",)
    return out


def run(capsys, argv):
    try:
        code = cli.main(argv)
    except SystemExit as exc:
        code = exc.code
    out, err = capsys.readouterr()
    return code, out, err


def run_process(argv, cwd: Path):
    """The command as a user runs it: its own process in the working folder; (exit status, stdout, stderr)."""
    try:
        p = subprocess.run([sys.executable, "-m", "filmcal.cli", *argv], capture_output=True, text=True,
                           stdin=subprocess.DEVNULL, timeout=CASE_LIMIT_S, cwd=cwd)
    except subprocess.TimeoutExpired:
        return None, "", f"the command ran past {CASE_LIMIT_S} s instead of refusing its input"
    return p.returncode, p.stdout, p.stderr


def xfail(*values, reason):
    return pytest.param(*values, marks=pytest.mark.xfail(reason=reason, strict=False))


WHEEL = ["--force-kn", "100", "--measured-area-mm2", "150", "--offset-mm=-3"]
SPHERE = ["--force-kn", "75", "--sphere-radius-mm", "450", "--measured-radius-mm", "7.1"]
WR = ["--offset-mm=-3", "--force-kn", "100"]
FEM = ["--sphere-radius-mm", "450", "--force-kn", "75"]
DOE = ["--samples", "5", "--param", "a=0:1", "--out", "d.csv"]

# (argv, words of which the stderr line must contain one)
CASES = [
    # fem
    (["fem", "--sphere-radius-mm", "-1", "--force-kn", "75", "--no-film"], ["--sphere-radius-mm"]),
    (["fem", "--sphere-radius-mm", "0", "--force-kn", "75", "--no-film"], ["--sphere-radius-mm"]),
    (["fem", "--sphere-radius-mm", "450", "--force-kn", "0", "--no-film"], ["--force-kn", "force"]),
    (["fem", *FEM, "--film-modulus-mpa", "-5"], ["--film-modulus-mpa"]),
    (["fem", *FEM, "--film-modulus-mpa", "0"], ["--film-modulus-mpa"]),
    (["fem", *FEM, "--film-modulus-mpa", "2800", "--film-poisson", "0.5"], ["--film-poisson"]),
    (["fem", *FEM, "--film-modulus-mpa", "2800", "--film-poisson", "-1"], ["--film-poisson"]),
    (["fem", *FEM, "--film-modulus-mpa", "2800", "--film-thickness-mm", "0"], ["--film-thickness-mm"]),
    (["fem", *FEM, "--no-film", "--friction-coefficient", "-0.1"], ["--friction-coefficient"]),
    (["fem", *FEM, "--no-film", "--film-modulus-mpa", "2800"], ["--film-modulus-mpa", "--no-film"]),
    (["fem", *FEM], ["--film-modulus-mpa", "--no-film"]),
    (["fem", "--sphere-radius-mm", "1e300", "--force-kn", "75", "--no-film"], ["--sphere-radius-mm"]),
    (["fem", "--sphere-radius-mm", "450", "--force-kn", "1e9", "--film-modulus-mpa", "2800"], ["--force-kn"]),
    # doe
    (["doe", "--samples", "1", "--param", "a=0:1", "--out", "d.csv"], ["--samples"]),
    (["doe", "--samples", "5", "--param", "a=1:0", "--out", "d.csv"], ["a:", "low"]),
    (["doe", "--samples", "5", "--param", "a", "--out", "d.csv"], ["name=low:high"]),
    (["doe", "--samples", "5", "--param", "a=0:1:cubic", "--out", "d.csv"], ["a:"]),
    (["doe", "--samples", "5", "--param", "a=-1:1:log", "--out", "d.csv"], ["a:"]),
    (["doe", "--samples", "5", "--param", "a=0:1", "--param", "a=0:2", "--out", "d.csv"], ["a"]),
    (["doe", "--samples", "5", "--param", "a=nan:1", "--out", "d.csv"], ["a"]),
    (["doe", "--samples", "5", *[f"--param=p{i}=0:1" for i in range(21)], "--out", "d.csv"], ["--param"]),
    (["doe", *DOE, "--augment", "binary.csv"], ["--augment", "binary.csv"]),
    (["doe", *DOE, "--augment", "empty.csv"], ["empty.csv"]),
    (["doe", *DOE, "--augment", "headeronly.csv"], ["headeronly.csv has a header and no points"]),
    (["doe", *DOE, "--augment", "wrongcols.csv"], ["--augment", "wrongcols.csv"]),
    (["doe", *DOE, "--augment", "ragged.csv"], ["ragged.csv", "--augment"]),
    # campaign
    (["campaign", "run", "--design", "binary.csv", "--store", "r.sqlite"], ["--design", "binary.csv"]),
    (["campaign", "run", "--design", "empty.csv", "--store", "r.sqlite"], ["empty.csv"]),
    (["campaign", "run", "--design", "wrongcols.csv", "--store", "r.sqlite"], ["column"]),
    (["campaign", "run", "--design", "nan.csv", "--store", "r.sqlite"], ["modulus_mpa"]),
    (["campaign", "run", "--design", "negative.csv", "--store", "r.sqlite"], ["sphere_radius_mm"]),
    (["campaign", "run", "--design", "ragged.csv", "--store", "r.sqlite"], ["ragged.csv", "row", "--design"]),
    (["campaign", "run", "--design", "design.csv", "--store", "r.sqlite", "--simulator-python", "garbage"], ["--simulator-python"]),
    (["campaign", "run", "--design", "design.csv", "--store", "r.sqlite", "--simulator-python", "nosuchmodule:f"],
     ["--simulator-python", "nosuchmodule"]),
    (["campaign", "run", "--design", "design.csv", "--store", "r.sqlite", "--dask", "garbage"], ["--dask"]),
    (["campaign", "run", "--design", "design.csv", "--store", "garbled.sqlite"], ["garbled.sqlite"]),
    (["campaign", "status", "--store", "garbled.sqlite"], ["garbled.sqlite"]),
    (["campaign", "status", "--store", "truncated.sqlite"], ["truncated.sqlite"]),
    (["campaign", "status", "--store", "empty.sqlite"], ["empty.sqlite"]),
    (["campaign", "status", "--store", "design.csv"], ["design.csv"]),
    (["campaign", "status", "--store", "other.sqlite"], ["other.sqlite"]),
    (["campaign", "export", "--store", "garbled.sqlite", "--out", "e.csv"], ["garbled.sqlite"]),
    (["campaign", "export", "--store", "empty.sqlite", "--out", "e.csv"], ["empty.sqlite"]),
    # calibrate
    (["calibrate", "--film", "XX", "--study-dir", "emptystudy"], ["XX", "--film"]),
    (["calibrate", "--film", " HS", "--study-dir", "emptystudy"], ["HS", "--film"]),
    (["calibrate", "--film", "", "--study-dir", "emptystudy"], ["film"]),
    (["calibrate", "--film", "HS", "--forces-kn", "abc", "--study-dir", "emptystudy"], ["--forces-kn"]),
    (["calibrate", "--film", "HS", "--forces-kn", "100-50", "--study-dir", "emptystudy"], ["--forces-kn"]),
    # no data left in the range: refused before the FE work (was a traceback and exit 70 after it)
    (["calibrate", "--film", "HS", "--forces-kn", "1000-2000", "--study-dir", "emptystudy"],
     ["--forces-kn", "at least 2"]),
    (["calibrate", "--film", "LOT7", "--films-file", "films.toml", "--study-dir", "emptystudy"], ["films.toml"]),
    (["calibrate", "--film", "LOT7", "--films-file", "notoml.toml", "--study-dir", "emptystudy"], ["notoml.toml"]),
    # a film one table too deep was 'film films: unknown key(s) XX'
    (["calibrate", "--film", "XX", "--films-file", "nested.toml", "--study-dir", "emptystudy"], ["not [films.XX]"]),
    # a bad value in the file was told as if of --activation-pressure-mpa, an option not given: it is the file's
    (["fem", "--sphere-radius-mm", "300", "--force-kn", "60", "--film-modulus-mpa", "2800", "--film", "XX",
      "--films-file", "badact.toml"], ["error: --films-file: films file"]),
    (["calibrate", "--film", "HS", "--data", "binary.csv", "--study-dir", "emptystudy"], ["binary.csv"]),
    (["calibrate", "--film", "HS", "--data", "wrongcols.csv", "--study-dir", "emptystudy"], ["wrongcols.csv"]),
    (["calibrate", "--film", "HS", "--study-dir", "badstudy"], ["badstudy/study.json"]),
    (["calibrate", "--film", "HS", "--study-dir", "binstudy"], ["binstudy/study.json"]),
    # profile
    (["profile", "UIC60"], ["UIC60"]),
    (["profile", "badprofile.csv"], ["badprofile.csv"]),
    (["profile", "missing.csv"], ["missing.csv"]),
    (["profile", "binary.csv"], ["binary.csv"]),
    (["profile", "empty.csv"], ["empty.csv"]),
    (["profile", "S1002", "--step-mm", "0"], ["--step-mm"]),
    (["profile", "S1002", "--step-mm", "100"], ["--step-mm"]),
    # wheelrail
    (["wheelrail", "--offset-mm", "100", "--force-kn", "100", "--no-film"], ["--offset-mm"]),
    (["wheelrail", "--offset-mm", "0", "--force-kn", "-1", "--no-film"], ["--force-kn"]),
    (["wheelrail", *WR, "--no-film", "--rail-inclination", "1/0"], ["--rail-inclination"]),
    (["wheelrail", *WR, "--no-film", "--rail-inclination", "abc"], ["--rail-inclination"]),
    (["wheelrail", *WR, "--no-film", "--rail-inclination", "1"], ["--rail-inclination"]),
    # a soft large-strain film ended in an IndexError; a tiny modulus blamed --offset-mm
    (["wheelrail", *WR, "--film-modulus-mpa", "0.1", "--kinematics", "large"], ["--film-modulus-mpa"]),
    (["wheelrail", *WR, "--film-modulus-mpa", "1e-3"], ["--film-modulus-mpa"]),
    (["wheelrail", *WR, "--no-film", "--rail", "missing.csv"], ["missing.csv"]),
    (["wheelrail", *WR, "--no-film", "--rail", "badprofile.csv"], ["badprofile.csv"]),
    (["wheelrail", *WR, "--no-film", "--rail", "binary.csv"], ["binary.csv"]),
    (["wheelrail", *WR, "--no-film", "--wheel", "UIC60"], ["UIC60"]),
    (["wheelrail", *WR, "--film-modulus-mpa", "2800", "--film-poisson", "0.7"], ["--film-poisson", "poisson"]),
    (["wheelrail", *WR, "--film-modulus-mpa", "-1"], ["--film-modulus-mpa"]),
    (["wheelrail", *WR, "--no-film", "--rail", "widerail.csv"], ["widerail", "cannot cover"]),
    (["wheelrail", *WR, "--no-film", "--rail-roughness-ra-um", "31"], ["--rail-roughness-ra-um"]),
    (["wheelrail", *WR, "--no-film", "--rail-roughness-ra-um", "1", "--roughness-law", "law.csv"],
     ["--rail-roughness-ra-um", "--roughness-law"]),
    (["wheelrail", *WR, "--no-film", "--rail", "hugeprofile.csv"], ["hugeprofile.csv"]),
    (["profile", "hugeprofile.csv", "--kind", "rail"], ["hugeprofile.csv"]),
    (["wheelrail", *WR, "--no-film", "--nominal-radius-mm", "0"], ["--nominal-radius-mm", "radius"]),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-ra-um", "-1"], ["--wheel-roughness-ra-um"]),
    # an Ra of a few atoms made no surface to solve (ZeroDivisionError, exit 70)
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-ra-um=1e-308"], ["--wheel-roughness-ra-um"]),
    (["wheelrail", *WR, "--no-film", "--nominal-radius-mm", "1e308"], ["--nominal-radius-mm"]),
    (["curves", "--film", "HS", "--roughness-law", "decreasing.csv", "--study-dir", "emptystudy"],
     ["decreasing.csv", "--study-dir"]),
    # a law to 1e300 was solved with (a unit error); a design range wider than a float said numpy's warnings
    (["wheelrail", *WR, "--film-modulus-mpa", "2800", "--roughness-law", "hugelaw.csv"],
     ["--roughness-law", "hugelaw.csv", "check the units"]),
    (["doe", "--samples", "3", "--param", "a=-1.7e308:1.7e308", "--out", "o.csv"], ["--param", "wider than a float"]),
    # a line profile with one bad row among many said 'needs finite numbers in at least two rows'
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "nanprofile.csv"], ["line 4 is not finite"]),
    # an empty number was answered in Python's words ("could not convert string to float: ''")
    (["serve", "--study-dir", "emptystudy", "--port="], ["--port: must be an integer, got ''"]),
    (["scan", "cut.png", "--out", "s.csv", "--min-imprint-mm2="], ["--min-imprint-mm2: must be a number, got ''"]),
    # a films file that is not TOML was blamed on --films
    (["pipeline", "--films-file", "binary.csv", "--study-dir", "new"], ["--films-file: films file"]),
    (["doe", "--samples", "3", "--param", "a=0:1", "--augment", "aug5.csv", "--out", "o.csv"],
     ["--augment", "aug5.csv", "must lie in [0, 1]"]),
    # fem: a sphere as small as the FE body collapsed its rim elements (exit 70); a contact beyond the body
    (["fem", "--sphere-radius-mm", "50", "--force-kn", "10", "--no-film"], ["--sphere-radius-mm"]),
    (["fem", "--sphere-radius-mm", "5000", "--force-kn", "2000", "--no-film"], ["--force-kn"]),
    (["fem", "--sphere-radius-mm", "450", "--force-kn", "50", "--no-film", "--element-size-mm", "2"],
     ["--element-size-mm"]),
    (["scan", "films.toml", "--out", "s.csv", "--dpi", "1e300"], ["--dpi"]),
    (["scan", "films.toml", "--out", "s.csv", "--mm-per-pixel", "1e-300"], ["--mm-per-pixel"]),
    (["calibrate", "--film", "HS", "--max-steps", "1", "--study-dir", "emptystudy"], ["--max-steps"]),
    # a batch written over itself lost the measurements
    (["correct", "--batch", "design.csv", "--out", "design.csv", "--study-dir", "emptystudy"], ["--out"]),
    (["correct", "--batch", "empty.csv", "--out", "o.csv", "--study-dir", "emptystudy"], ["--batch", "empty.csv"]),
    # an output written over an input lost it (a store overwritten by its CSV, a scan by its table or overview)
    (["campaign", "export", "--store", "garbled.sqlite", "--out", "garbled.sqlite"], ["--out"]),
    (["scan", "cut.png", "--out", "cut.png"], ["--out"]),
    (["scan", "cut.png", "--out", "s.csv", "--overview", "cut.png"], ["--overview"]),
    (["scan", "cut.png", "--out", "s.png"], ["--out"]),
    (["doe", "--samples", "2", "--param", "modulus_mpa=100:1000", "--augment", "design.csv", "--out", "design.csv"],
     ["--out"]),
    # a map-reading option that the given map does not read was ignored
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "cut.png", "--roughness-pixel-um", "1",
      "--roughness-height-range-um", "5", "--roughness-height-scale", "2"], ["--roughness-height-scale", "image"]),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "design.csv", "--roughness-pixel-um", "1",
      "--roughness-height-range-um", "5"], ["--roughness-height-range-um", "csv map"]),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "bomb.png", "--roughness-pixel-um", "1",
      "--roughness-height-range-um", "5"], ["bomb.png"]),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "cut.png", "--roughness-pixel-um", "1",
      "--roughness-height-range-um", "5"], ["cut.png"]),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "notimage.png", "--roughness-pixel-um", "1",
      "--roughness-height-range-um", "5"], ["notimage.png"]),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "binary.csv", "--roughness-pixel-um", "1"],
     ["binary.csv"]),
    # correct
    (["correct", "--film", "XX", *WHEEL, "--study-dir", "emptystudy"], ["XX", "--film", "--study-dir"]),
    (["correct", "--film", " HS", *WHEEL, "--study-dir", "emptystudy"], ["HS", "--film", "--study-dir"]),
    (["correct", "--film", "HS", *WHEEL, "--study-dir", "missing"], ["--study-dir"]),
    (["correct", "--film", "HS", *WHEEL, "--study-dir", "emptystudy"], ["--study-dir"]),
    (["correct", "--film", "HS", *WHEEL, "--study-dir", "badstudy"], ["badstudy/study.json"]),
    (["correct", "--film", "HS", *SPHERE, "--study-dir", "binstudy"], ["binstudy/study.json"]),
    (["correct", "--film", "HS", "--force-kn", "100", "--offset-mm=-3", "--study-dir", "badstudy"],
     ["--measured-area-mm2", "--scan"]),
    (["correct", "--film", "HS", *WHEEL, "--measured-radius-mm", "7", "--study-dir", "badstudy"],
     ["--measured", "either"]),
    (["correct", "--film", "HS", "--force-kn", "100", "--measured-area-mm2", "-5", "--offset-mm=-3",
      "--study-dir", "badstudy"], ["--measured-area-mm2"]),
    (["correct", "--film", "HS", *WHEEL, "--dpi", "600", "--study-dir", "badstudy"], ["--dpi"]),
    (["correct", "--film", "HS", *WHEEL, "--scan", "cut.png", "--study-dir", "badstudy"], ["--scan"]),
    (["correct", "--film", "HS", *WHEEL, "--measured-area-std-mm2", "-1", "--study-dir", "badstudy"],
     ["--measured-area-std-mm2"]),
    (["correct", "--film", "HS", "--force-kn", "100000", "--measured-area-mm2", "150", "--offset-mm=-3",
      "--study-dir", "badstudy"], ["--force-kn"]),
    # how a map is read, without a map: was ignored
    (["correct", "--film", "HS", *WHEEL, "--roughness-pixel-um", "1", "--study-dir", "badstudy"],
     ["--roughness-pixel-um"]),
    (["wheelrail", *WR, "--no-film", "--roughness-height-scale", "2"], ["--roughness-height-scale"]),
    (["curves", "--film", "HS", "--roughness-height-range-um", "5", "--study-dir", "emptystudy"],
     ["--roughness-height-range-um"]),
    # a repeated imprint model started the whole pipeline with it twice
    (["pipeline", "--study-dir", "emptystudy", "--imprint-models", "edge,edge"], ["edge is given more than once"]),
    # a simulator told none of a run's inputs ran the design first, then failed on its output
    (["pipeline", "--study-dir", "emptystudy", "--simulator-command", "echo hi"], ["every run would be the same"]),
    # curves
    (["curves", "--film", "HS", "--offsets-mm=0,0", "--study-dir", "emptystudy"], ["0 more than once"]),
    # draws of the roughness inputs for smooth bodies were ignored
    (["curves", "--film", "HS", "--roughness-draws", "4", "--study-dir", "emptystudy"], ["--roughness-draws"]),
    (["correct", "--film", "HS", *WHEEL, "--roughness-draws", "2", "--study-dir", "badstudy"], ["--roughness-draws"]),
    (["curves", "--film", "HS", "--csv", "same.png", "--plot", "same.png", "--study-dir", "emptystudy"],
     ["is the file of --csv"]),
    # an option the command ignored: a standard profile's kind
    (["profile", "60E1", "--kind", "wheel"], ["rail profile"]),
    # every command's output options, not only those that checked them: the CSV was written over by the plot
    (["fem", "--sphere-radius-mm", "300", "--force-kn", "60", "--no-film", "--plot", "same.png", "--pressure-csv",
      "same.png"], ["is the file of --plot"]),
    (["curves", "--film", "HS", "--csv", "emptystudy/curves.csv", "--study-dir", "emptystudy"],
     ["inside the study folder"]),
    (["correct", "--batch", "design.csv", "--out", "emptystudy/out.csv", "--study-dir", "emptystudy"],
     ["inside the study folder"]),
    (["curves", "--film", "HS", "--offsets-mm=-7:2:1e-7", "--study-dir", "emptystudy"], ["--offsets-mm"]),
    (["curves", "--film", "HS", "--offsets-mm=abc", "--study-dir", "emptystudy"], ["--offsets-mm"]),
    (["curves", "--film", "HS", "--forces-kn=1:1e9:1", "--study-dir", "emptystudy"], ["--forces-kn"]),
    (["curves", "--film", "HS", "--forces-kn=50,nan", "--study-dir", "emptystudy"], ["--forces-kn"]),
    (["curves", "--film", "HS", "--forces-kn=0", "--study-dir", "emptystudy"], ["--forces-kn", "--study-dir"]),
    (["curves", "--film", "HS", "--forces-kn=1e9", "--study-dir", "emptystudy"], ["--forces-kn"]),
    (["curves", "--film", "HS", "--roughness-law", "law.csv", "--study-dir", "emptystudy"],
     ["law.csv", "--roughness-law", "--study-dir"]),
    (["curves", "--film", "XX", "--study-dir", "emptystudy"], ["XX", "--film", "--study-dir"]),
    (["curves", "--film", "HS", "--study-dir", "badstudy"], ["badstudy/study.json"]),
    (["curves", "--film", "HS", "--study-dir", "missing"], ["--study-dir"]),
    # pipeline
    (["pipeline", "--films", "XX", "--study-dir", "emptystudy"], ["XX", "--films"]),
    (["pipeline", "--films", "HS,HS", "--study-dir", "emptystudy"], ["--films"]),
    (["pipeline", "--films", ",", "--study-dir", "emptystudy"], ["--films"]),
    (["pipeline", "--films-file", "films.toml", "--study-dir", "emptystudy"], ["films.toml"]),
    (["pipeline", "--study-dir", "badstudy"], ["badstudy/study.json"]),
    # scan
    (["scan", "missing.jpg", "--out", "s.csv"], ["missing.jpg"]),
    # the film column was filled with any name, refused only when the batch was corrected
    (["scan", "cut.png", "--out", "s.csv", "--film", "XYZ"], ["'XYZ'", "--films-file"]),
    (["scan", "films.toml", "--out", "s.csv"], ["films.toml"]),
    (["scan", "films.toml", "--out", "s.csv", "--min-imprint-mm2", "-1"], ["--min-imprint-mm2", "min_imprint_mm2"]),
    (["scan", "films.toml", "--out", "s.csv", "--overview", "s.txt"], ["--overview"]),
    # serve
    (["serve", "--study-dir", "missing"], ["--study-dir"]),
    (["serve", "--study-dir", "badstudy"], ["badstudy/study.json"]),
    (["serve", "--study-dir", "emptystudy", "--port", "70000"], ["--port"]),
    (["serve", "--study-dir", "emptystudy", "--request-timeout-s", "0"], ["--request-timeout-s"]),
    # report
    (["report", "--study-dir", "missing"], ["--study-dir", "study_dir"]),
    (["report", "--study-dir", "emptystudy"], ["--study-dir", "study_dir", "emptystudy"]),
    (["report", "--study-dir", "badstudy"], ["badstudy/study.json"]),
    (["report", "--study-dir", "binstudy"], ["binstudy/study.json"]),
    (["report", "--study-dir", "uncalibrated", "--out-dir", "adir"], ["holds no results yet"]),
]


def _case_id(case) -> str:
    values = case.values if hasattr(case, "values") else case
    argv = values[0]
    return " ".join(argv)[:90]


@pytest.mark.parametrize("argv,names", CASES, ids=[_case_id(c) for c in CASES])
def test_command_refuses_bad_input_cleanly(capsys, folder, guard, argv, names):
    before = snapshot(folder)
    code, out, err = run(capsys, argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2, (code, err)
    assert len(lines) == 1, err
    assert "Traceback" not in err and out == ""
    assert any(n in lines[0] for n in names), (names, lines[0])
    assert snapshot(folder) == before, "a refused command created, changed or removed a file"


def test_every_command_as_a_process(tmp_path, bomb_png):
    """The first two cases of every command again as a user runs them (``python -m filmcal.cli``, a process and
    working folder of their own, four at a time): exit 2, one stderr line naming the option or file, nothing on
    stdout, every file's SHA-256 unchanged (the in-process cases check the rest alike)."""
    from concurrent.futures import ThreadPoolExecutor

    seen: dict = {}
    cases = []
    for case in CASES:
        if getattr(case, "marks", None):
            continue
        argv = case[0]
        key = " ".join(argv[:2]) if argv[0] == "campaign" else argv[0]
        if seen.setdefault(key, 0) < 2:
            seen[key] += 1
            cases.append(case)

    def one(k: int, argv: list, names: list) -> str | None:
        where = tmp_path / f"case{k}"
        where.mkdir()
        make_folder(where, bomb_png)
        before = snapshot(where)
        code, out, err = run_process(argv, where)
        lines = [line for line in err.splitlines() if line.strip()]
        if code != 2 or len(lines) != 1 or out or "Traceback" in err or not any(n in lines[0] for n in names):
            return f"{' '.join(argv)}: exit {code}, stderr {err.strip()[-300:]!r}, stdout {out[:100]!r}"
        if snapshot(where) != before:
            return f"{' '.join(argv)}: a file was created, changed or removed"
        return None

    with ThreadPoolExecutor(4) as pool:
        failures = [f for f in pool.map(lambda kc: one(kc[0], *kc[1]), enumerate(cases)) if f]
    assert len(seen) >= 12 and not failures, "\n".join(failures[:20])


MANIFEST_READERS = [["calibrate", "--film", "HS"], ["correct", "--film", "HS", *WHEEL], ["curves", "--film", "HS"],
                    ["pipeline"], ["report"], ["serve"]]


@pytest.mark.parametrize("study", ["badstudy", "binstudy"])
@pytest.mark.parametrize("command", MANIFEST_READERS, ids=lambda c: c[0])
def test_a_damaged_manifest_is_not_answered_with_delete(capsys, folder, guard, command, study):
    """A truncated or garbled study.json was answered "delete it and rerun", which loses the study (and the
    rerun then refuses the folder): the line names the manifest and says to restore it or use a new folder."""
    before = snapshot(folder)
    code, out, err = run(capsys, [*command, "--study-dir", study])
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and out == "", err
    assert f"{study}/study.json" in lines[0] and "manifest" in lines[0], lines[0]
    assert "delete" not in lines[0].lower() and "backup" in lines[0] and "--study-dir" in lines[0], lines[0]
    assert snapshot(folder) == before


# (argv, the option that names the file): a device, a named pipe or a folder is refused before any work (/dev/zero
# as --data, --films-file or --roughness-law grew to several GB before a refusal)
SPECIAL_FILE_CASES = [
    (["calibrate", "--film", "HS", "--data", "/dev/zero", "--study-dir", "emptystudy"], "--data"),
    (["pipeline", "--films-file", "/dev/zero", "--study-dir", "emptystudy"], "--films-file"),
    (["calibrate", "--film", "HS", "--films-file", "/dev/zero", "--study-dir", "emptystudy"], "--films-file"),
    (["wheelrail", *WR, "--no-film", "--wheel-roughness-map", "/dev/zero"], "--wheel-roughness-map"),
    (["curves", "--film", "HS", "--rail-roughness-map", "/dev/zero", "--study-dir", "emptystudy"],
     "--rail-roughness-map"),
    (["curves", "--film", "HS", "--roughness-law", "/dev/zero", "--study-dir", "emptystudy"], "--roughness-law"),
    (["wheelrail", *WR, "--no-film", "--wheel", "/dev/zero"], "--wheel"),
    (["profile", "/dev/zero"], "name"),
    (["scan", "/dev/zero", "--out", "s.csv"], "SHEET"),
    (["campaign", "run", "--design", "design.csv", "--store", "r.sqlite", "--simulator-command", "true",
      "--template-file", "/dev/zero"], "--template-file"),
    (["campaign", "run", "--design", "pipe.csv", "--store", "r.sqlite"], "--design"),
    (["correct", "--film", "HS", *WHEEL, "--batch", "adir", "--study-dir", "emptystudy"], "--batch"),
]


@pytest.mark.parametrize("argv,option", SPECIAL_FILE_CASES, ids=[_case_id(c) for c in SPECIAL_FILE_CASES])
def test_an_input_that_is_not_a_regular_file_is_refused_before_work(capsys, folder, guard, argv, option):
    os.mkfifo(folder / "pipe.csv")
    path = argv[argv.index(option) + 1] if option.startswith("--") else argv[1]
    before = snapshot(folder)
    code, out, err = run(capsys, argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and out == "", err
    assert f"{option} {path!r}" in lines[0], lines[0]
    assert "not a regular file" in lines[0] or "folder" in lines[0], lines[0]
    assert snapshot(folder) == before


@pytest.mark.parametrize("argv,option", [
    (["calibrate", "--film", "HS", "--data", "big.csv", "--study-dir", "emptystudy"], "--data"),
    (["wheelrail", *WR, "--no-film", "--rail-roughness-map", "big.csv"], "--rail-roughness-map"),
], ids=lambda v: v if isinstance(v, str) else None)
def test_an_input_file_above_its_size_cap_is_refused_before_work(capsys, folder, guard, argv, option):
    """A file one byte above its option's cap (a sparse file: no disk used) is refused naming the cap."""
    from filmcal._io import INPUT_FILE_MAX_MIB, check_input_file

    dest = option.lstrip("-").replace("-", "_")
    cap_mib = cli.INPUT_FILE_CAPS_MIB.get(dest, INPUT_FILE_MAX_MIB)
    with open(folder / "big.csv", "wb") as stream:
        stream.truncate(int(cap_mib * 2**20) + 1)
    before = snapshot(folder)
    code, out, err = run(capsys, argv)
    lines = [line for line in err.splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and out == "", err
    assert f"{option} 'big.csv' is larger than {cap_mib:g} MiB" in lines[0], lines[0]
    assert snapshot(folder) == before
    with open(folder / "big.csv", "r+b") as stream:  # at the cap: accepted
        stream.truncate(int(cap_mib * 2**20))
    assert check_input_file(folder / "big.csv", option, cap_mib) == folder / "big.csv"


def test_campaign_status_leaves_an_empty_file_alone(capsys, folder):
    """A zero-byte file is not turned into a store by reading it."""
    code, _, err = run(capsys, ["campaign", "status", "--store", "empty.sqlite", "--json"])
    assert code == 2 and (folder / "empty.sqlite").stat().st_size == 0, err


def cases_per_command() -> dict[str, int]:
    counts: dict[str, int] = {}
    for case in CASES:
        argv = (case.values if hasattr(case, "values") else case)[0]
        key = " ".join(argv[:2]) if argv[0] == "campaign" else argv[0]
        counts[key] = counts.get(key, 0) + 1
    return counts


def test_every_command_has_cases():
    counts = cases_per_command()
    for name in cli.command_modules():
        assert any(k.split()[0] == name for k in counts), name
