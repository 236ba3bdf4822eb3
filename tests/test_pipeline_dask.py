"""The pipeline on a Dask cluster: every stage's parallel work there, the same posterior as local workers."""
from __future__ import annotations

import json
import subprocess
import sys


def _pipeline(study, *where: str) -> dict:
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--smoke", "--films", "HS", "--study-dir",
                        str(study), "--no-report", "--json", "--progress", "quiet", *where],
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    return json.loads(p.stdout)


def test_the_pipeline_on_a_local_dask_cluster_gives_the_posterior_of_local_workers(tmp_path):
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        on_cluster = _pipeline(tmp_path / "dask", "--dask", cluster.scheduler_address)
    local = _pipeline(tmp_path / "local", "--workers", "2")
    assert on_cluster["films"]["HS"]["modulus_mpa"] == local["films"]["HS"]["modulus_mpa"]
    assert on_cluster["films"]["HS"]["imprint_weights"] == local["films"]["HS"]["imprint_weights"]


def test_an_unreachable_scheduler_is_refused_before_anything_is_written(tmp_path):
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--smoke", "--study-dir", str(tmp_path / "st"),
                        "--dask", "tcp://127.0.0.1:1"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "Dask scheduler" in p.stderr
    assert not (tmp_path / "st").exists()
