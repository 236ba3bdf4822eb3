"""`calibrate` and `curves` on a Dask cluster (`--dask ADDRESS`), as `pipeline`: refused with one line before
anything is written when the scheduler cannot be reached, exclusive of --workers, the same posterior."""
from __future__ import annotations

import hashlib
import json
import subprocess
import sys

import pytest

from filmcal.cli import main

UNREACHABLE = "tcp://127.0.0.1:1"
#: The smallest calibration (the smoke pipeline's sizes, one imprint model).
SMOKE_CALIBRATION = ("calibrate", "--film", "HS", "--imprint-model", "edge", "--kinematics", "small",
                     "--train-runs", "20", "--test-runs", "5", "--max-steps", "400", "--json")


def _files(folder) -> dict:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _h5_numbers(path) -> dict:
    """Every dataset and attribute of an HDF5 file, as SHA-256 of its values' bytes."""
    import h5py
    import numpy as np

    out: dict = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            for key, value in obj.attrs.items():
                out[f"{name}@{key}"] = hashlib.sha256(np.asarray(value).tobytes()).hexdigest()
            if isinstance(obj, h5py.Dataset):
                out[name] = hashlib.sha256(np.ascontiguousarray(obj[()]).tobytes()).hexdigest()
        visit("/", f)
        f.visititems(visit)
    return out


@pytest.mark.slow(reason="9 s: three commands waiting out the scheduler's 5 s connect timeout")
def test_an_unreachable_scheduler_is_refused_before_anything_is_written(tmp_path):
    from filmcal.study import Study

    Study(tmp_path / "study", create=True)
    before = _files(tmp_path / "study")
    commands = {"calibrate new": [*SMOKE_CALIBRATION, "--study-dir", str(tmp_path / "new")],
                "calibrate": [*SMOKE_CALIBRATION, "--study-dir", str(tmp_path / "study")],
                "curves": ["curves", "--film", "HS", "--study-dir", str(tmp_path / "study")]}
    running = {name: subprocess.Popen([sys.executable, "-m", "filmcal.cli", *argv, "--dask", UNREACHABLE],
                                      stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
               for name, argv in commands.items()}
    for name, p in running.items():
        out, err = p.communicate(timeout=120)
        assert p.returncode == 2 and out == "", (name, err)
        assert len(err.strip().splitlines()) == 1 and f"Dask scheduler at {UNREACHABLE}" in err, (name, err)
    assert not (tmp_path / "new").exists()
    assert _files(tmp_path / "study") == before


@pytest.mark.parametrize("command", ["pipeline", "calibrate", "curves"])
def test_dask_and_workers_together_are_refused_as_the_pipeline_refuses_them(command, tmp_path, capsys):
    study = tmp_path / "study"
    argv = [command, "--study-dir", str(study), "--workers", "2", "--dask", UNREACHABLE]
    with pytest.raises(SystemExit) as exit_:
        main(argv + (["--film", "HS"] if command != "pipeline" else []))
    assert exit_.value.code == 2
    err = capsys.readouterr().err
    assert err == f"filmcal {command}: error: argument --dask: not allowed with argument --workers\n"
    assert not study.exists()


def _run(capsys, *argv: str) -> dict:
    assert main(list(argv)) == 0, capsys.readouterr().err[-2000:]
    return json.loads(capsys.readouterr().out)


def test_calibrate_and_curves_on_a_local_dask_cluster_give_the_results_of_a_local_run(tmp_path, capsys):
    from distributed import LocalCluster

    dask, local = str(tmp_path / "dask"), str(tmp_path / "local")
    curves = ("curves", "--film", "HS", "--imprint-model", "edge", "--forces-kn", "50", "--offsets-mm=-3,0", "--json")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        on_cluster = _run(capsys, *SMOKE_CALIBRATION, "--study-dir", dask, "--dask", cluster.scheduler_address)
        curves_on_cluster = _run(capsys, *curves, "--study-dir", dask, "--dask", cluster.scheduler_address)
    # the references in this process (--workers 1): the cheapest
    here = _run(capsys, *SMOKE_CALIBRATION, "--study-dir", local, "--workers", "1")
    for key in ("modulus_mpa", "oedometric_modulus_mpa", "sigma_mm", "surrogate_validation"):
        assert on_cluster[key] == here[key], key
    # the surrogate fitted to the FE runs is the local one byte for byte, and the chain made on the cluster
    # holds the local chain's numbers (an HDF5 file's bytes also carry its layout, which may differ)
    dask_files, local_files = _files(tmp_path / "dask"), _files(tmp_path / "local")
    chains = [n for n in local_files if n.startswith("chains/")]
    assert chains
    for name in [n for n in local_files if n.startswith("surrogates/") and not n.endswith("-validation.json")]:
        assert dask_files.get(name) == local_files[name], name
    for name in chains:
        assert _h5_numbers(tmp_path / "dask" / name) == _h5_numbers(tmp_path / "local" / name), name
    assert curves_on_cluster["rows"] == _run(capsys, *curves, "--study-dir", local, "--workers", "1")["rows"]
