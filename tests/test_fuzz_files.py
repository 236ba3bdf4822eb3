"""Damaged artefacts of every kind and the command line's error boundary.

Every kind of file the package reads (JSON results and manifests, CSV designs,
npz surrogates, SQLite stores, HDF5 chains, NetCDF posteriors, PNG scans) is
damaged in several ways (truncated, garbled, emptied, replaced by another
kind) and read by the package's own loader; the boundary of `filmcal.cli`
must turn each failure into one line that names the file (exit status 2),
never into an internal error. Then the boundary itself: internal errors keep
their traceback with status 70, Ctrl-C gives one line and 130, quotes in
messages survive, and a few cases run as real processes.
"""
from __future__ import annotations

import argparse
import importlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from filmcal import cli


def boundary_line(exc: BaseException, args: argparse.Namespace | None = None) -> str | None:
    return cli.user_error_message(exc, args or argparse.Namespace(), {})


def load_error(load, path):
    with pytest.raises(BaseException) as info:
        load(path)
    return info.value


def damage(path: Path, how: str) -> None:
    data = path.read_bytes()
    if how == "truncated":
        path.write_bytes(data[: max(1, len(data) // 2)])
    elif how == "head":
        path.write_bytes(data[:16])
    elif how == "garbled":
        rng = np.random.default_rng(7)
        buf = bytearray(data)
        start = min(64, len(buf) // 4)
        for i in rng.integers(start, len(buf), size=max(8, len(buf) // 50)):
            buf[i] ^= 0x5A
        path.write_bytes(bytes(buf))
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "text":
        path.write_text("this is not the file you are looking for\n")
    elif how == "zeros":
        path.write_bytes(bytes(len(data)))
    else:
        raise AssertionError(how)


HOWS = ["truncated", "head", "garbled", "empty", "text", "zeros"]


def assert_names_file(exc: BaseException, path: Path) -> None:
    line = boundary_line(exc)
    assert line is not None, f"classified as an internal error: {type(exc).__name__}: {exc}"
    assert "\n" not in line
    assert path.name in line, line


# --- artefacts ------------------------------------------------------------------------

@pytest.fixture(scope="module")
def surrogate_files(tmp_path_factory):
    from filmcal.surrogate import GPSurrogate, save_surrogate

    folder = tmp_path_factory.mktemp("surrogate")
    rng = np.random.default_rng(0)
    X = rng.uniform(0, 1, size=(12, 2))
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a tiny fit: convergence is beside the point
        gp = GPSurrogate(n_restarts=0, random_state=0).fit(X, np.sin(3 * X[:, 0]) + X[:, 1])
    json_path, npz_path = save_surrogate(gp, folder / "gp")
    return json_path.read_bytes(), npz_path.read_bytes()


@pytest.mark.parametrize("part", ["npz", "json"])
@pytest.mark.parametrize("how", HOWS)
def test_damaged_surrogate(tmp_path, surrogate_files, part, how):
    from filmcal.surrogate import load_surrogate

    (tmp_path / "gp.json").write_bytes(surrogate_files[0])
    (tmp_path / "gp.npz").write_bytes(surrogate_files[1])
    target = tmp_path / f"gp.{part}"
    damage(target, how)
    exc = load_error(load_surrogate, tmp_path / "gp")
    assert_names_file(exc, target)


def test_surrogate_npz_with_pickled_objects_is_refused(tmp_path, surrogate_files):
    from filmcal.surrogate import load_surrogate

    (tmp_path / "gp.json").write_bytes(surrogate_files[0])
    np.savez(tmp_path / "gp.npz", X_train=np.array([object()], dtype=object), y_train=np.zeros(1))
    exc = load_error(load_surrogate, tmp_path / "gp")
    assert_names_file(exc, tmp_path / "gp.npz")


@pytest.fixture(scope="module")
def chain_bytes(tmp_path_factory):
    import h5py

    path = tmp_path_factory.mktemp("chain") / "chain.h5"
    with h5py.File(path, "w") as f:
        f.attrs["filmcal_metadata"] = '{"format": "x"}'
        f.create_dataset("chain", data=np.random.default_rng(0).standard_normal((200, 8, 3)))
    return path.read_bytes()


@pytest.mark.parametrize("how", HOWS)
def test_damaged_chain_file(tmp_path, chain_bytes, how):
    from filmcal.calibration.sampling import read_chain

    path = tmp_path / "HS.h5"
    path.write_bytes(chain_bytes)
    damage(path, how)
    exc = load_error(read_chain, path)
    assert_names_file(exc, path)


@pytest.mark.parametrize("how", HOWS)
def test_damaged_netcdf_posterior(tmp_path, chain_bytes, how):
    from filmcal.calibration.posterior import load_posterior_netcdf

    path = tmp_path / "posterior.nc"
    path.write_bytes(chain_bytes)
    damage(path, how)
    exc = load_error(load_posterior_netcdf, path)
    assert_names_file(exc, path)


@pytest.mark.parametrize("how", HOWS)
def test_damaged_json_artefacts(tmp_path, how):
    from filmcal._io import read_json
    from filmcal.calibration.posterior import load_result

    path = tmp_path / "posterior-HS.json"
    path.write_text('{"format": "filmcal-calibration", "version": 1, "samples": {"modulus_mpa": [1, 2, 3]}}')
    damage(path, how)
    for load in (read_json, load_result):
        exc = load_error(load, path)
        assert_names_file(exc, path)


def test_json_read_without_the_helper_still_names_the_file(tmp_path):
    """Code that decodes a file itself is covered too: the boundary finds the file it read."""
    import json

    path = tmp_path / "summary.json"
    path.write_text('{"films": [1, 2')

    def legacy_reader(path: Path):
        return json.loads(path.read_text())

    exc = load_error(legacy_reader, path)
    line = boundary_line(exc)
    assert line is not None and "summary.json" in line and "delete it" in line


@pytest.mark.parametrize("how", HOWS)
def test_damaged_sqlite_store(tmp_path, how):
    from filmcal.campaign import RunStore

    path = tmp_path / "runs.sqlite"
    with RunStore(path) as store:
        store.counts()
    # grow the file past one page so that damage reaches the schema
    damage(path, how)

    def open_and_count(p):
        with RunStore(p, create=False) as store:
            return store.counts()

    try:
        counts = open_and_count(path)
    except BaseException as exc:  # noqa: BLE001 - whatever it is, the boundary must name the file
        assert_names_file(exc, path)
    else:  # zeros past the header can still read as an empty store; it must then say so
        assert counts.total == 0


@pytest.mark.parametrize("how", HOWS)
def test_damaged_design_csv(tmp_path, how):
    from filmcal.campaign import read_design_csv

    path = tmp_path / "design.csv"
    path.write_text("modulus_mpa,poisson,radius_mm,force_kn\n" + "2800,0.33,450,75\n" * 40)
    damage(path, how)
    try:
        points = read_design_csv(path)
    except BaseException as exc:  # noqa: BLE001
        assert_names_file(exc, path)
    else:  # a truncated CSV is still a CSV: fewer rows, possibly a short last row that the checks refuse
        assert isinstance(points, list)


@pytest.mark.parametrize("how", HOWS)
def test_damaged_png_scan(tmp_path, how):
    from PIL import Image

    from filmcal.correction import read_imprint

    img = np.full((120, 120, 3), 245, dtype=np.uint8)
    img[30:90, 30:90] = (215, 60, 120)
    path = tmp_path / "scan.png"
    Image.fromarray(img).save(path, dpi=(600, 600))
    damage(path, how)
    exc = load_error(read_imprint, path)
    assert_names_file(exc, path)


# --- the boundary -------------------------------------------------------------------------

def run_with(monkeypatch, capsys, exc: BaseException):
    module = importlib.import_module("filmcal.commands.profile")

    def explode(args):
        raise exc
    monkeypatch.setattr(module, "run", explode)
    code = cli.main(["profile", "S1002"])
    out, err = capsys.readouterr()
    return code, out, err


def test_internal_error_keeps_its_traceback_and_exits_70(monkeypatch, capsys):
    code, out, err = run_with(monkeypatch, capsys, ZeroDivisionError("division by zero"))
    assert code == cli.EXIT_INTERNAL == 70
    assert "Traceback" in err and "ZeroDivisionError" in err and "bug" in err.splitlines()[-1]
    code, _, err = run_with(monkeypatch, capsys, KeyError("modulus_mpa"))
    assert code == 70 and "Traceback" in err


def test_ctrl_c_is_one_line_and_130(monkeypatch, capsys):
    code, out, err = run_with(monkeypatch, capsys, KeyboardInterrupt())
    assert code == 130 and out == "" and err.strip() == "filmcal profile: interrupted"


@pytest.mark.parametrize("exc,expected", [
    (ValueError("unknown film 'XX'"), "unknown film 'XX'"),
    (ValueError("got \"quoted\""), "got \"quoted\""),
    (ValueError("first line\nsecond line"), "first line; second line"),
    (MemoryError(), "not enough memory"),
    (PermissionError(13, "Permission denied", "/root/x.csv"), "'/root/x.csv': Permission denied"),
    (IsADirectoryError(21, "Is a directory", "/tmp"), "'/tmp': Is a directory"),
    (NotADirectoryError(20, "Not a directory", "/etc/passwd/x"), "Not a directory"),
    (FileNotFoundError(2, "No such file or directory", "gone.csv"), "'gone.csv'"),
])
def test_user_errors_are_one_line_with_their_quotes(monkeypatch, capsys, exc, expected):
    code, out, err = run_with(monkeypatch, capsys, exc)
    lines = err.strip().splitlines()
    assert code == 2 and out == "" and len(lines) == 1, err
    assert lines[0].startswith("filmcal profile: error: ") and expected in lines[0], lines[0]
    assert lines[0].count("'") % 2 == 0 and lines[0].count('"') % 2 == 0


def test_broken_pipe_is_quiet(monkeypatch, capsys):
    code, out, err = run_with(monkeypatch, capsys, BrokenPipeError(32, "Broken pipe"))
    assert code == 0 and err == ""


def _process(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "filmcal.cli", *args], capture_output=True, text=True,
                          timeout=120, **kw)


def test_as_processes(tmp_path):
    p = _process()
    assert p.returncode == 2 and p.stdout == "" and len(p.stderr.splitlines()) == 1
    assert p.stderr.startswith("filmcal: error: a command is required")
    p = _process("doe", "--samples", "100000", "--param", "a=0:1", "--out", str(tmp_path / "d.csv"))
    assert p.returncode == 2 and len(p.stderr.splitlines()) == 1 and "--samples" in p.stderr
    p = _process("campaign", "status", "--store", str(tmp_path))
    assert p.returncode == 2 and len(p.stderr.splitlines()) == 1 and "--store" in p.stderr
    assert sorted(os.listdir(tmp_path)) == []


def _interrupt_a_running_doe(out: Path, **popen) -> tuple[subprocess.Popen, str, str, float]:
    """Start a long `doe`, send SIGINT once it works; return the process, its stdout, stderr and the wait."""
    proc = subprocess.Popen([sys.executable, "-m", "filmcal.cli", "doe", "--samples", "2000", "--iterations",
                             "1000", "--param", "a=0:1", "--param", "b=0:1", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **popen)
    # wait until the optimiser's libraries are loaded (the command is working), not a fixed time
    maps = Path(f"/proc/{proc.pid}/maps")
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if maps.exists() and "scipy/spatial" in maps.read_text(errors="replace"):
            break
        time.sleep(0.1)
    time.sleep(1.0)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    try:
        stdout, stderr = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        stdout, stderr = proc.communicate()
    return proc, stdout, stderr, time.monotonic() - sent


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="watches the process through /proc")
def test_ctrl_c_of_a_running_command_exits_130_with_one_line(tmp_path):
    proc, stdout, stderr, waited = _interrupt_a_running_doe(tmp_path / "d.csv")
    assert proc.returncode == 130, stderr
    assert stderr.strip() == "filmcal doe: interrupted" and stdout == ""
    assert waited < 2.0, waited
    assert sorted(os.listdir(tmp_path)) == []  # no partial design, no temporary file


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="watches the process through /proc")
def test_ctrl_c_stops_a_command_started_with_sigint_ignored(tmp_path):
    """Started with SIGINT ignored (a shell's background job, `nohup ... &`), Ctrl-C still ends it: 130, one line."""
    proc, stdout, stderr, waited = _interrupt_a_running_doe(
        tmp_path / "d.csv", preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    assert proc.returncode == 130, (proc.returncode, stderr)
    assert stderr.strip() == "filmcal doe: interrupted" and stdout == ""
    assert waited < 2.0, waited
    assert sorted(os.listdir(tmp_path)) == []


def test_a_ctrl_c_that_python_swallows_is_delivered_again():
    """A KeyboardInterrupt raised in a ``__del__`` (or an import lock's weakref callback) is only
    printed by Python; inside the command's boundary it reaches the main thread again."""

    class Finaliser:
        def __del__(self):
            raise KeyboardInterrupt

    reached = []
    with pytest.raises(KeyboardInterrupt):
        with cli._swallowed_ctrl_c_redelivered():
            Finaliser()  # its __del__ runs at once and raises where Python cannot propagate it
            for _ in range(10_000_000):
                reached.append(1)
                time.sleep(0.001)
    assert len(reached) < 100  # the interrupt came at once, not at the loop's end


def test_a_command_that_cannot_register_is_an_internal_error(monkeypatch, capsys):
    module = importlib.import_module("filmcal.commands.profile")

    def broken(subparsers):
        raise AttributeError("typo in a parser")
    monkeypatch.setattr(module, "add_parser", broken)
    assert cli.main(["fem", "--help"]) == 70
    err = capsys.readouterr().err
    assert "Traceback" in err and "AttributeError" in err


def test_a_library_warning_is_one_line(monkeypatch, capsys):
    """A warning that reaches the command line (a GP fit that did not converge) is one line naming its kind,
    without the file, line number and source line of Python's default display."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning

    module = importlib.import_module("filmcal.commands.profile")

    def warn(args):
        warnings.warn("GP hyperparameter optimisation: lbfgs failed to converge\nIncrease the number of iterations",
                      ConvergenceWarning, stacklevel=1)
        return 0
    monkeypatch.setattr(module, "run", warn)
    with warnings.catch_warnings():
        code = cli.main(["profile", "S1002"])
    out, err = capsys.readouterr()
    assert code == 0 and err.splitlines() == [
        "filmcal profile: warning: ConvergenceWarning: GP hyperparameter optimisation: lbfgs failed to converge"]
