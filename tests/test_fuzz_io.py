"""The shared file helpers (filmcal._io) and the error taxonomy (filmcal._errors)."""
from __future__ import annotations

import hashlib
import json
import os

import numpy as np
import pytest

from filmcal._errors import DamagedFileError, InputError
from filmcal._io import (atomic_path, atomic_write_bytes, atomic_write_json, atomic_write_text,
                         check_input_file, check_output_dir, check_output_file, read_json,
                         sha256_file)


def test_errors_are_value_errors():
    assert issubclass(InputError, ValueError)
    assert issubclass(DamagedFileError, ValueError)
    err = DamagedFileError("/x/posterior.json", "truncated\nsecond line", recomputable=True)
    assert "/x/posterior.json" in str(err) and "delete it" in str(err) and "\n" not in str(err)


def test_atomic_writes_roundtrip_and_leave_no_temporary(tmp_path):
    atomic_write_text(tmp_path / "a.txt", "héllo\n")
    atomic_write_bytes(tmp_path / "b.bin", b"\x00\x01")
    atomic_write_json(tmp_path / "c.json", {"x": np.float64(2.5), "y": float("inf"), "z": np.arange(2)})
    assert (tmp_path / "a.txt").read_text(encoding="utf-8") == "héllo\n"
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"
    # strict JSON: the standard library parses it with non-finite constants refused
    data = json.loads((tmp_path / "c.json").read_text(), parse_constant=lambda c: pytest.fail(c))
    assert data == {"x": 2.5, "y": None, "z": [0, 1]}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt", "b.bin", "c.json"]


def test_atomic_path_keeps_old_file_on_failure(tmp_path):
    target = tmp_path / "s.npz"
    with atomic_path(target) as tmp:
        np.savez(tmp, a=np.arange(3))
    assert np.load(target)["a"].tolist() == [0, 1, 2]
    before = target.read_bytes()
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_bytes(b"partial")
            raise RuntimeError("killed")
    assert target.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["s.npz"]


def test_read_json_names_damaged_file(tmp_path):
    good = tmp_path / "good.json"
    good.write_text('{"a": [1, 2]}')
    assert read_json(good) == {"a": [1, 2]}
    bad = tmp_path / "posterior.json"
    bad.write_text('{"a": [1, 2')
    with pytest.raises(DamagedFileError) as info:
        read_json(bad)
    assert str(bad) in str(info.value) and "recompute" in str(info.value)
    binary = tmp_path / "bin.json"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(DamagedFileError, match="bin.json"):
        read_json(binary, recomputable=False)
    with pytest.raises(FileNotFoundError):
        read_json(tmp_path / "missing.json")


def test_sha256_file_matches_hashlib(tmp_path):
    data = os.urandom(3 * 1024 + 7)
    path = tmp_path / "d.bin"
    path.write_bytes(data)
    assert sha256_file(path, block_bytes=1000) == hashlib.sha256(data).hexdigest()


def test_path_checks(tmp_path):
    (tmp_path / "f.txt").write_text("x")
    assert check_output_file(tmp_path / "new.csv") == tmp_path / "new.csv"
    with pytest.raises(InputError, match="--out .* is a folder"):
        check_output_file(tmp_path)
    with pytest.raises(InputError, match="--csv .*does not exist"):
        check_output_file(tmp_path / "no" / "x.csv", option="--csv")
    with pytest.raises(InputError, match="--out .*is not a folder"):
        check_output_file(tmp_path / "f.txt" / "x.csv")
    with pytest.raises(InputError, match="--study-dir .* is a file"):
        check_output_dir(tmp_path / "f.txt")
    assert check_output_dir(tmp_path / "newdir") == tmp_path / "newdir"
    assert not (tmp_path / "newdir").exists()
    with pytest.raises(InputError, match="does not exist"):
        check_output_dir(tmp_path / "newdir", must_exist=True)
    with pytest.raises(InputError, match="--design .* is a folder"):
        check_input_file(tmp_path, "--design")
    with pytest.raises(InputError, match="--design .* does not exist"):
        check_input_file(tmp_path / "nope.csv", "--design")
    # the probe leaves nothing behind
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.txt"]


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs /proc")
def test_unwritable_system_folder_refused():
    with pytest.raises(InputError, match="not writable"):
        check_output_file("/proc/x.sqlite", option="--store")
    with pytest.raises(InputError, match="not writable"):
        check_output_dir("/proc", option="--out-dir")
    assert str(check_output_dir("/proc", option="--study-dir", writable=False)) == "/proc"


def test_atomic_write_gives_ordinary_permissions(tmp_path):
    mask = os.umask(0o022)
    os.umask(mask)
    new = atomic_write_text(tmp_path / "new.txt", "x")
    assert new.stat().st_mode & 0o777 == 0o666 & ~mask
    old = tmp_path / "old.txt"
    old.write_text("y")
    old.chmod(0o640)
    atomic_write_text(old, "z")
    assert old.stat().st_mode & 0o777 == 0o640 and old.read_text() == "z"


def test_json_safe_paths_and_numpy(tmp_path):
    import math

    from filmcal._json import json_safe

    value = json_safe({"p": tmp_path / "x.csv", "a": np.array([1.5, np.nan]), "i": np.int64(3),
                       "t": (np.float32(0.5), math.inf)})
    assert value == {"p": str(tmp_path / "x.csv"), "a": [1.5, None], "i": 3, "t": [0.5, None]}
    json.dumps(value, allow_nan=False)


def test_read_only_folder(tmp_path, monkeypatch):
    """A folder the process may not write (permissions as os.access reports them, so that the check holds
    for root too, who may write anywhere)."""
    import filmcal._io as io_module

    folder = tmp_path / "ro"
    folder.mkdir()
    real_access = os.access

    def access(path, mode, *args, **kwargs):
        if os.path.realpath(path) == os.path.realpath(folder) and mode & os.W_OK:
            return False
        return real_access(path, mode, *args, **kwargs)

    monkeypatch.setattr(io_module.os, "access", access)
    with pytest.raises(InputError, match="not writable"):
        check_output_file(folder / "x.csv")
    with pytest.raises(InputError, match="not writable"):
        check_output_dir(folder)
    assert check_output_dir(folder, writable=False) == folder
