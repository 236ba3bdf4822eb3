"""The pipeline on a Dask cluster: every stage's parallel work there, the same posterior as local workers."""
from __future__ import annotations

import json
import subprocess
import sys


def _pipeline(study, *where: str, size: str = "--smoke") -> dict:
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", size, "--films", "HS", "--study-dir",
                        str(study), "--no-report", "--json", "--progress", "quiet", *where],
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    return json.loads(p.stdout)


def test_the_pipeline_on_a_local_dask_cluster_gives_the_posterior_of_local_workers(tmp_path):
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        on_cluster = _pipeline(tmp_path / "dask", "--dask", cluster.scheduler_address, size="--quick")
    local = _pipeline(tmp_path / "local", "--workers", "2", size="--quick")
    assert on_cluster["films"]["HS"]["modulus_mpa"] == local["films"]["HS"]["modulus_mpa"]
    assert on_cluster["films"]["HS"]["imprint_weights"] == local["films"]["HS"]["imprint_weights"]


def test_an_unreachable_scheduler_is_refused_before_anything_is_written(tmp_path):
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--smoke", "--study-dir", str(tmp_path / "st"),
                        "--dask", "tcp://127.0.0.1:1"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "Dask scheduler" in p.stderr
    assert not (tmp_path / "st").exists()


def test_a_pipeline_killed_on_a_dask_cluster_resumes_without_running_finished_work_again(tmp_path):
    """SIGKILL of the command while its FE runs go on the cluster: the rerun keeps every finished run (none is
    run twice) and ends with the posterior an uninterrupted local run gives."""
    import signal
    import sqlite3
    import time

    from distributed import LocalCluster

    study = tmp_path / "dask"

    def finished() -> list:
        stores = list((study / "runs").glob("runs-*.sqlite")) if (study / "runs").exists() else []
        rows = []
        for store in stores:
            try:
                with sqlite3.connect(store, timeout=1) as db:
                    rows += db.execute("select point_id, attempts, finished_at from runs where status = 'ok'"
                                       ).fetchall()
            except sqlite3.OperationalError:  # not created yet
                pass
        return sorted(rows)

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--smoke", "--films", "HS", "--study-dir", str(study),
               "--no-report", "--json", "--progress", "quiet", "--dask", cluster.scheduler_address]
        first = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 300
        while len(finished()) < 10 and time.monotonic() < deadline and first.poll() is None:
            time.sleep(0.2)
        first.send_signal(signal.SIGKILL)
        first.wait()
        kept = finished()
        assert kept, "the run was killed before any FE run finished"
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
        assert p.returncode == 0, p.stderr[-2000:]
    after = {point: (attempts, when) for point, attempts, when in finished()}
    assert all(after[point] == (attempts, when) for point, attempts, when in kept)  # none run again
    local = _pipeline(tmp_path / "local", "--workers", "2")
    assert json.loads(p.stdout)["films"]["HS"]["modulus_mpa"] == local["films"]["HS"]["modulus_mpa"]
