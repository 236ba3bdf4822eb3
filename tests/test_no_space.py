"""A full disk at any write: one OSError ENOSPC naming the file, the old file kept, no temporary file left.

The disk is filled at the three levels `filmcal._io` itself uses: the
creation of the temporary file (``tempfile.mkstemp``), the writes into it
(the ``open`` of `filmcal._io.atomic_open`, whose file then stores half of
what it is given and fails), and the ``os.fsync`` before the rename. Every
write site of the package goes through one of `atomic_path`, `atomic_open`,
`atomic_savefig` or `atomic_write_*`, so filling the disk there fills it for
each of them.
"""
from __future__ import annotations

import errno
import json
import os
import sys
import tempfile
from types import SimpleNamespace

import numpy as np
import pytest

import filmcal._io

NO_SPACE = "No space left on device"
OLD = b"the file as it was before\n"


def _no_space(*args, **kwargs):
    raise OSError(errno.ENOSPC, NO_SPACE)


class _FillingFile:
    """An open file on a device that fills up: the first write stores half its data, then ENOSPC."""

    def __init__(self, fh):
        self._fh = fh

    def write(self, data):
        self._fh.write(data[: len(data) // 2])
        self._fh.flush()  # the half really reaches the temporary file
        raise OSError(errno.ENOSPC, NO_SPACE)

    def __getattr__(self, name):
        return getattr(self._fh, name)

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self._fh.close()


def _inject(monkeypatch, level: str) -> None:
    """Fill the disk at `level` of `filmcal._io`."""
    if level == "fsync":
        monkeypatch.setattr(filmcal._io.os, "fsync", _no_space)
    elif level == "write":
        real_open = open

        def filling_open(file, mode="r", *args, **kwargs):
            fh = real_open(file, mode, *args, **kwargs)
            return _FillingFile(fh) if "w" in mode else fh

        monkeypatch.setattr(filmcal._io, "open", filling_open, raising=False)
    elif level == "create":
        def mkstemp(suffix=None, prefix=None, dir=None, text=False):
            raise OSError(errno.ENOSPC, NO_SPACE, os.path.join(str(dir), f"{prefix}abcdefgh{suffix}"))

        monkeypatch.setattr(filmcal._io.tempfile, "mkstemp", mkstemp)
    else:
        raise ValueError(level)


# --- the write sites: each writes its file(s) under `folder` and returns the target paths ---------------

def _design(folder):
    from filmcal.doe import write_design_csv

    write_design_csv(folder / "design.csv", ("a", "b"), np.array([[0.1, 2.0], [0.7, 3.5]]))
    return [folder / "design.csv"]


def _outline(folder):
    from filmcal.correction.outline import CorrectedOutline

    square = [np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])]
    CorrectedOutline(measured_mm=square, mean_mm=square, lo_mm=square, hi_mm=square,
                     area_mm2=np.array([1.0, 0.9, 1.1]), shift_scale=np.zeros(3),
                     rule="uniform offset").write_csv(folder / "outline.csv")
    return [folder / "outline.csv"]


@pytest.fixture(scope="module")
def tiny_surrogate():
    from filmcal.surrogate import GPSurrogate

    X = np.linspace(0.0, 1.0, 6)[:, None]
    return GPSurrogate(("x",), "y", n_restarts=0, random_state=0).fit(X, 1.0 + X[:, 0] ** 2)


def _surrogate(folder, surrogate):
    from filmcal.surrogate import save_surrogate

    save_surrogate(surrogate, folder / "gp")
    return [folder / "gp.npz", folder / "gp.json"]


def _curves(folder):
    from filmcal.correction.curves import CURVE_COLUMNS, write_curves_csv

    write_curves_csv(folder / "curves.csv", [[0] * len(CURVE_COLUMNS)])
    return [folder / "curves.csv"]


def _pressure_profile_png(folder):
    """`filmcal fem --plot` (report.figures.plot_pressure_profile) with a made-up result."""
    from filmcal.report.figures import plot_pressure_profile

    r = np.linspace(0.0, 2.0, 9)
    result = SimpleNamespace(r_mm=r, pressure_profile_mpa=np.maximum(1.0 - r**2, 0.0), sphere_radius_mm=50.0,
                             force_n=1e3, film_modulus_mpa=None, film_poisson=0.3, contact_radius_mm=1.0,
                             hertz_radius_mm=1.1)
    plot_pressure_profile(result, str(folder / "pressure.png"))
    return [folder / "pressure.png"]


def _rail_profile_png(folder):
    """`filmcal profile --plot` (commands.profile.plot_profile)."""
    from filmcal.commands.profile import plot_profile
    from filmcal.wheelrail.profiles import get_profile

    profile = get_profile("60E1")
    y, z = profile.points(2.0)
    plot_profile(profile, y, z, folder / "rail.png")
    return [folder / "rail.png"]


def _figure_without_suffix(folder):
    """`atomic_savefig` to a name without a suffix (format: matplotlib's default, PNG)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1))
    fig.add_subplot().plot([0, 1], [0, 1])
    filmcal._io.atomic_savefig(fig, folder / "figure", dpi=30)
    return [folder / "figure"]


def _json(folder):
    filmcal._io.atomic_write_json(folder / "data.json", {"a": np.float64(1.5), "b": [1, 2, 3]})
    return [folder / "data.json"]


SITES = {"design_csv": _design, "outline_csv": _outline, "surrogate_npz_json": _surrogate, "curves_csv": _curves,
         "pressure_profile_png": _pressure_profile_png, "rail_profile_png": _rail_profile_png,
         "figure_without_suffix": _figure_without_suffix, "json": _json}


def _write(site, folder, request):
    writer = SITES[site]
    if site == "surrogate_npz_json":
        return writer(folder, request.getfixturevalue("tiny_surrogate"))
    return writer(folder)


def _temporaries(folder) -> list[str]:
    return sorted(name for name in os.listdir(folder) if ".tmp" in name)


@pytest.mark.parametrize("existing", [False, True], ids=["new", "replacing"])
@pytest.mark.parametrize("level", ["fsync", "write", "create"])
@pytest.mark.parametrize("site", sorted(SITES))
def test_a_full_disk_fails_the_write_whole_and_leaves_nothing(site, level, existing, tmp_path, monkeypatch,
                                                              request):
    clean = tmp_path / "clean"
    clean.mkdir()
    targets = [t.name for t in _write(site, clean, request)]
    assert all((clean / name).stat().st_size > 0 for name in targets)
    folder = tmp_path / "full"
    folder.mkdir()
    if existing:
        for name in targets:
            (folder / name).write_bytes(OLD)
    before = sorted(os.listdir(folder))

    _inject(monkeypatch, level)
    with pytest.raises(OSError) as info:
        _write(site, folder, request)
    monkeypatch.undo()

    assert info.value.errno == errno.ENOSPC
    assert info.value.filename == str(folder / targets[0])  # the file being written, not its temporary file
    assert _temporaries(folder) == []
    assert sorted(os.listdir(folder)) == before  # nothing new, nothing removed
    for name in targets:
        assert (folder / name).read_bytes() == OLD if existing else not (folder / name).exists()


@pytest.mark.parametrize("site", sorted(SITES))
def test_ctrl_c_in_the_middle_of_a_write_leaves_the_old_file_and_no_temporary(site, tmp_path, monkeypatch, request):
    targets = [t.name for t in _write(site, tmp_path, request)]
    written = {name: (tmp_path / name).read_bytes() for name in targets}
    real_open = open

    class Interrupted(_FillingFile):
        def write(self, data):
            self._fh.write(data[: len(data) // 2])
            raise KeyboardInterrupt

    def interrupted_open(file, mode="r", *args, **kwargs):
        fh = real_open(file, mode, *args, **kwargs)
        return Interrupted(fh) if "w" in mode else fh

    monkeypatch.setattr(filmcal._io, "open", interrupted_open, raising=False)
    with pytest.raises(KeyboardInterrupt):
        _write(site, tmp_path, request)
    monkeypatch.undo()
    assert sorted(os.listdir(tmp_path)) == sorted(targets)
    assert {name: (tmp_path / name).read_bytes() for name in targets} == written


def test_after_the_disk_has_room_again_the_same_write_gives_the_same_bytes(tmp_path, monkeypatch):
    clean, folder = tmp_path / "clean", tmp_path / "full"
    clean.mkdir()
    folder.mkdir()
    _design(clean)
    _inject(monkeypatch, "write")
    with pytest.raises(OSError):
        _design(folder)
    monkeypatch.undo()
    _design(folder)
    assert (folder / "design.csv").read_bytes() == (clean / "design.csv").read_bytes()
    assert os.listdir(folder) == ["design.csv"]


def test_a_refused_temporary_file_names_the_destination(tmp_path, monkeypatch):
    """Permission denied while creating the temporary file: the error names the file asked for."""
    def mkstemp(suffix=None, prefix=None, dir=None, text=False):
        raise PermissionError(errno.EACCES, "Permission denied", os.path.join(str(dir), f"{prefix}x{suffix}"))

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    with pytest.raises(PermissionError) as info:
        filmcal._io.atomic_write_text(tmp_path / "a.txt", "x")
    assert info.value.filename == str(tmp_path / "a.txt")


DOE = ["doe", "--samples", "5", "--param", "a=0:1", "--param", "b=1:10:log", "--iterations", "2", "--seed", "3"]


@pytest.mark.parametrize("level", ["fsync", "write"])
def test_the_command_line_says_no_space_in_one_line_and_exits_2(level, tmp_path, monkeypatch, capsys):
    from filmcal import cli

    clean, out = tmp_path / "clean.csv", tmp_path / "design.csv"
    assert cli.main([*DOE, "--out", str(clean)]) == 0
    capsys.readouterr()

    _inject(monkeypatch, level)
    assert cli.main([*DOE, "--out", str(out)]) == 2
    monkeypatch.undo()
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    message = lines[0].lower()
    assert "no space" in message and f"--out {str(out)!r}" in lines[0]
    assert "delete" not in message and "remove" not in message and "damaged (" not in message
    assert "traceback" not in captured.err.lower()
    assert not out.exists() and _temporaries(tmp_path) == []

    assert cli.main([*DOE, "--out", str(out)]) == 0  # room again: the same design, byte for byte
    assert out.read_bytes() == clean.read_bytes()
    assert _temporaries(tmp_path) == []


@pytest.mark.parametrize(("name", "magic"), [("figure", b"\x89PNG"), ("figure.png", b"\x89PNG"),
                                             ("figure.PDF", b"%PDF"), ("figure.svg", b"<?xml")])
def test_a_figure_is_written_in_the_format_of_its_name_under_exactly_that_name(name, magic, tmp_path):
    """The temporary file's name ends in .tmp: the format comes from the name asked for."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1, 1))
    fig.add_subplot().plot([0, 1], [0, 1])
    filmcal._io.atomic_savefig(fig, tmp_path / name, dpi=30)
    assert os.listdir(tmp_path) == [name]
    assert (tmp_path / name).read_bytes().startswith(magic)


def _small_filesystems() -> bool:
    """True where a private mount namespace can mount a small tmpfs (root with CAP_SYS_ADMIN)."""
    import shutil as _shutil
    import subprocess as _subprocess

    if _shutil.which("unshare") is None:
        return False
    probe = _subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"],
                            capture_output=True)
    return probe.returncode == 0


def test_a_study_on_a_full_small_filesystem_stops_in_one_line_and_resumes_when_there_is_room(tmp_path):
    """A smoke pipeline on a real 600 KiB tmpfs (its chains need more): one line naming 'no space', no
    temporary file left; after the filesystem grows, the rerun completes with the posterior of a clean run.
    HDF5 met the full disk inside its buffers and printed finaliser tracebacks; the chain's writer now refuses
    a write that cannot fit first. Where mounts are not allowed, the same refusal is shown with the free
    space the chain's writer reads made small."""
    import subprocess as _subprocess

    clean = _subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--smoke", "--films", "HS",
                             "--study-dir", str(tmp_path / "clean"), "--no-report", "--json", "--progress", "quiet"],
                            capture_output=True, text=True, timeout=900)
    assert clean.returncode == 0, clean.stderr[-2000:]
    small = tmp_path / "small"
    small.mkdir()
    pipeline = (f"{sys.executable} -m filmcal.cli pipeline --smoke --films HS --study-dir {small}/st --no-report "
                "--json --progress quiet")
    if _small_filesystems():
        script = (f"mount -t tmpfs -o size=600k tmpfs {small} && {{ {pipeline} > {tmp_path}/1.out 2> {tmp_path}/1.err;"
                  f" echo $? > {tmp_path}/1.rc; find {small} -name '*.tmp*' > {tmp_path}/1.tmp; "
                  f"mount -o remount,size=100m {small} && {pipeline} > {tmp_path}/2.out 2> {tmp_path}/2.err; "
                  f"echo $? > {tmp_path}/2.rc; }}")
        _subprocess.run(["unshare", "-m", "sh", "-c", script], check=True, timeout=1800)
        first_rc, first_err = int((tmp_path / "1.rc").read_text()), (tmp_path / "1.err").read_text()
        assert (tmp_path / "1.tmp").read_text() == ""
        second_rc, second_out = int((tmp_path / "2.rc").read_text()), (tmp_path / "2.out").read_text()
    else:
        low = ("import shutil, sys; from filmcal.cli import main; real = shutil.disk_usage; "
               "shutil.disk_usage = lambda p: real(p)._replace(free=1000); sys.exit(main(sys.argv[1:]))")
        args = pipeline.split()[3:] + ["--workers", "1"]  # the chains written in this process, as patched
        first = _subprocess.run([sys.executable, "-c", low, *args], capture_output=True, text=True, timeout=900)
        first_rc, first_err = first.returncode, first.stderr
        assert not list(small.rglob("*.tmp*"))
        second = _subprocess.run(pipeline.split(), capture_output=True, text=True, timeout=900)
        second_rc, second_out = second.returncode, second.stdout
    assert first_rc == 2 and len(first_err.strip().splitlines()) == 1, first_err[-3000:]
    assert "no space left on the device" in first_err and "delete" not in first_err
    assert second_rc == 0
    assert json.loads(second_out)["films"]["HS"]["modulus_mpa"] == json.loads(clean.stdout)["films"]["HS"]["modulus_mpa"]
