"""Tests of the simulation campaign: executors, store, resume, failures, CLI.

The models here are toys defined in this module (worker processes import it
by name): a Hertz contact radius, optionally logging every call to a file so
that tests can count how often each point was evaluated.
"""
from __future__ import annotations

import csv
import json
import math
import os
import signal
import sqlite3
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from filmcal.campaign import (
    Campaign,
    DaskExecutor,
    LocalPoolExecutor,
    RunStore,
    SerialExecutor,
    TaskTimeoutError,
    as_design_points,
    outcome_from_outputs,
    point_id,
    read_design_csv,
    settings_hash,
)

TESTS_DIR = Path(__file__).resolve().parent
CALL_LOG_ENV = "FILMCAL_TEST_CALL_LOG"
SLEEP_ENV = "FILMCAL_TEST_SLEEP_S"


def point_key(params: dict) -> str:
    """A readable key of a toy design point."""
    return f"R{params['sphere_radius_mm']:g}/F{params['force_kn']:g}/E{params['modulus_mpa']:g}"


def hertz_radius_mm(params: dict) -> float:
    """Hertz contact radius of two equal elastic bodies, a = (3FR / (4E*))^(1/3), E* = E / (2(1 - nu^2))."""
    e_star = params["modulus_mpa"] / (2.0 * (1.0 - params["poisson"] ** 2))
    return (3.0 * params["force_kn"] * 1e3 * params["sphere_radius_mm"] / (4.0 * e_star)) ** (1.0 / 3.0)


def _log_call(params: dict) -> None:
    log = params.get("call_log") or os.environ.get(CALL_LOG_ENV)
    if log:
        with open(log, "a") as stream:
            stream.write(point_key(params) + "\n")


def counting_model(params: dict) -> dict:
    """Hertz radius; logs the call; sleeps FILMCAL_TEST_SLEEP_S seconds if set."""
    _log_call(params)
    time.sleep(float(os.environ.get(SLEEP_ENV, "0")))
    radius = hertz_radius_mm(params)
    return {"contact_radius_mm": radius, "contact_area_mm2": math.pi * radius**2, "converged": True}


def troublesome_model(params: dict) -> dict:
    """Like `counting_model`, but while the file `fail_marker` exists some forces misbehave."""
    _log_call(params)
    if Path(params["fail_marker"]).exists():
        force = params["force_kn"]
        if force == 13:
            raise ValueError("film collapsed")
        if force == 17:
            time.sleep(30)
        if force == 19:
            return {"contact_radius_mm": float("nan"), "converged": True}
        if force == 23:
            return {"contact_radius_mm": 1.0, "converged": False, "reason": "contact did not converge"}
        if force == 29:
            os._exit(3)
    return {"contact_radius_mm": hertz_radius_mm(params), "converged": True}


def worker_info_model(params: dict) -> dict:
    """Process id and BLAS/OpenMP thread counts of the process that runs the call."""
    from threadpoolctl import threadpool_info

    time.sleep(0.05)
    threads = [info["num_threads"] for info in threadpool_info()]
    return {"pid": os.getpid(), "max_native_threads": max(threads, default=1),
            "omp_num_threads": os.environ.get("OMP_NUM_THREADS", "")}


def toy_design(forces, sphere_radius_mm=450.0, **extra) -> list[dict]:
    return [{"modulus_mpa": 2800.0 + 10.0 * i, "poisson": 0.33, "sphere_radius_mm": sphere_radius_mm,
             "force_kn": float(force), **extra} for i, force in enumerate(forces)]


def write_design_csv(path: Path, points: list[dict]) -> Path:
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(points[0]))
        writer.writeheader()
        writer.writerows(points)
    return path


def logged_calls(path: Path) -> Counter:
    return Counter(path.read_text().split()) if path.exists() else Counter()


def stored_rows(store: Path, status: str | None = None) -> list[tuple[dict, str]]:
    """(inputs, status) of the rows of a store, read with plain sqlite3."""
    conn = sqlite3.connect(f"file:{store}?mode=ro", uri=True)
    try:
        rows = conn.execute("SELECT inputs_json, status FROM runs").fetchall()
    finally:
        conn.close()
    return [(json.loads(inputs), s) for inputs, s in rows if status is None or s == status]


@pytest.fixture(scope="module")
def pool():
    with LocalPoolExecutor(2) as executor:
        yield executor


def run_cli(argv: list[str]) -> int:
    """Exit status of `filmcal` with these arguments (argparse errors included)."""
    from filmcal.cli import main as cli_main

    try:
        return cli_main(argv)
    except SystemExit as exc:
        return exc.code


# -- resume after a kill --------------------------------------------------------------


def _wait_for_ok_rows(store: Path, at_least: int, process: subprocess.Popen, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert process.poll() is None, "the campaign ended before it could be killed"
        try:
            if len(stored_rows(store, "ok")) >= at_least:
                return
        except sqlite3.Error:
            pass  # store or table not created yet
        time.sleep(0.02)
    raise AssertionError(f"fewer than {at_least} ok rows after {timeout_s} s")


def test_killed_campaign_resumes_without_recomputing_finished_points(tmp_path):
    points = toy_design(range(20, 40))
    design = write_design_csv(tmp_path / "design.csv", points)
    store, log = tmp_path / "runs.sqlite", tmp_path / "calls.log"
    env = {**os.environ, CALL_LOG_ENV: str(log), SLEEP_ENV: "0.1",
           "PYTHONPATH": os.pathsep.join(filter(None, [str(TESTS_DIR), os.environ.get("PYTHONPATH")]))}
    command = [sys.executable, "-m", "filmcal.cli", "campaign", "run", "--design", str(design),
               "--store", str(store), "--workers", "2", "--simulator-python", "test_campaign:counting_model", "--json"]

    from test_campaign_parallel import alive, descendants

    with (tmp_path / "first.err").open("w") as stderr:
        first = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=stderr)
        try:
            _wait_for_ok_rows(store, 4, first)
            workers = descendants(first.pid)  # the workers and the resource tracker
        finally:
            first.send_signal(signal.SIGKILL)
            first.wait(timeout=30)
    assert first.returncode == -signal.SIGKILL, (tmp_path / "first.err").read_text()
    killed_at = time.monotonic()
    assert len(workers) >= 2
    while any(alive(pid) for pid in workers) and time.monotonic() - killed_at < 5.0:
        time.sleep(0.05)
    assert not [pid for pid in workers if alive(pid)], "worker processes outlived the killed campaign by 5 s"
    ok_before = {point_key(inputs) for inputs, _ in stored_rows(store, "ok")}
    assert 4 <= len(ok_before) < len(points)  # killed midway

    second = subprocess.run(command, env=env, capture_output=True, text=True, timeout=120)
    assert second.returncode == 0, second.stderr
    summary = json.loads(second.stdout)
    assert summary["n_run"] == len(points) - len(ok_before)
    assert (summary["ok"], summary["failed"], summary["pending"]) == (len(points), 0, 0)

    rows = stored_rows(store)
    keys = [point_key(inputs) for inputs, _ in rows]
    assert sorted(keys) == sorted(point_key(p) for p in points)  # exactly one row per point
    assert all(status == "ok" for _, status in rows)
    calls = logged_calls(log)
    assert all(calls[key] == 1 for key in ok_before)  # finished points were not recomputed
    assert set(calls) == set(keys)


# -- failures ---------------------------------------------------------------------------


def test_failures_are_recorded_with_reasons_and_retried_on_request(tmp_path, pool):
    marker, log = tmp_path / "fail-now", tmp_path / "calls.log"
    marker.touch()
    points = toy_design([10, 11, 13, 17, 19, 23, 29, 31, 37, 41], call_log=str(log), fail_marker=str(marker))
    # 5 s: the first call on a replacement worker includes importing this module, which
    # on a loaded machine can take a second or more; the hanging point sleeps 30 s
    campaign = Campaign(troublesome_model, tmp_path / "runs.sqlite", executor=pool)

    summary = campaign.run(points, timeout_s=5.0, progress=False)
    reasons = {r.inputs["force_kn"]: r.reason for r in campaign.records("failed")}
    assert reasons == {
        13.0: "ValueError: film collapsed",
        17.0: "timeout after 5 s",
        19.0: "non-finite output contact_radius_mm=nan",
        23.0: "contact did not converge",
        29.0: "WorkerDiedError: worker process died (exit code 3)",
    }
    assert (summary.n_run_ok, summary.n_run_failed, summary.counts.pending) == (5, 5, 0)
    results = campaign.results()
    for inputs_force, radius in zip(results.inputs["force_kn"], results.outputs["contact_radius_mm"]):
        params = next(p for p in points if p["force_kn"] == inputs_force)
        assert radius == pytest.approx(hertz_radius_mm(params), rel=1e-12)

    assert campaign.run(points, timeout_s=5.0, progress=False).n_run == 0  # failed runs are not retried

    marker.unlink()
    retried = campaign.run(points, retry_failed=True, timeout_s=5.0, progress=False)
    assert (retried.n_run, retried.counts.ok) == (5, len(points))
    calls = logged_calls(log)
    assert {key: n for key, n in calls.items() if n == 2} == {
        point_key(p): 2 for p in points if p["force_kn"] in reasons}
    assert sum(calls.values()) == len(points) + len(reasons)
    attempts = {r.inputs["force_kn"]: r.attempts for r in campaign.records()}
    assert attempts == {p["force_kn"]: 2 if p["force_kn"] in reasons else 1 for p in points}


def test_serial_executor_interrupts_a_hung_model(tmp_path):
    marker = tmp_path / "fail-now"
    marker.touch()
    points = toy_design([10, 13, 17, 19], fail_marker=str(marker))
    campaign = Campaign(troublesome_model, tmp_path / "runs.sqlite", executor=SerialExecutor())
    start = time.perf_counter()
    summary = campaign.run(points, timeout_s=0.3, progress=False)
    assert time.perf_counter() - start < 10.0
    assert (summary.n_run_ok, summary.n_run_failed) == (1, 3)
    assert {r.inputs["force_kn"]: r.reason for r in campaign.records("failed")}[17.0] == "timeout after 0.3 s"


def test_pool_reuses_its_workers_and_pins_native_threads(pool):
    futures = [pool.submit(worker_info_model, {}) for _ in range(8)]
    infos = [future.result(timeout=60) for future in futures]
    assert len({info["pid"] for info in infos}) <= pool.max_workers
    assert all(info["max_native_threads"] == 1 and info["omp_num_threads"] == "1" for info in infos)


def test_pool_timeout_kills_only_the_overdue_call(pool):
    hung = pool.submit(time.sleep, 30, timeout_s=0.5)
    quick = [pool.submit(math.sqrt, float(x), timeout_s=5.0) for x in range(6)]
    assert [f.result(timeout=60) for f in quick] == [math.sqrt(x) for x in range(6)]
    with pytest.raises(TaskTimeoutError, match="timeout after 0.5 s"):
        hung.result(timeout=60)


def test_toy_model_reproduces_the_hertz_reference_case():
    # DESIGN.md: two steel bodies, R450, 75 kN -> a = 6.031 mm
    params = {"modulus_mpa": 210000.0, "poisson": 0.3, "sphere_radius_mm": 450.0, "force_kn": 75.0}
    assert counting_model(params)["contact_radius_mm"] == pytest.approx(6.031, abs=5e-4)


def test_outputs_are_classified():
    assert outcome_from_outputs({"a": np.float64(1.5), "n": np.int64(3), "ok": np.bool_(True)}, 0.1).outputs == {
        "a": 1.5, "n": 3, "ok": True}
    assert outcome_from_outputs({"converged": False}, 0.1).reason == "model did not converge"
    assert outcome_from_outputs({"a": float("inf")}, 0.1).status == "failed"
    assert outcome_from_outputs({"a": np.ones(3)}, 0.1).reason == "output a: unsupported output type ndarray"
    assert outcome_from_outputs([1.0], 0.1).reason == "model returned list, expected a dict of outputs"


# -- Dask -------------------------------------------------------------------------------


def test_dask_cluster_gives_the_same_results_as_the_local_pool(tmp_path, pool, capsys):
    from dask.distributed import Client, LocalCluster

    points = toy_design([20, 40, 60, 80], sphere_radius_mm=300.0) + toy_design([25, 50, 75], sphere_radius_mm=600.0)
    local = Campaign(counting_model, tmp_path / "local.sqlite", executor=pool)
    local.run(points, progress=False)
    design = write_design_csv(tmp_path / "design.csv", points)
    cluster = LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None)
    try:
        with Client(cluster) as client, DaskExecutor(client) as executor:
            assert executor.max_workers == 2
            remote = Campaign(counting_model, tmp_path / "dask.sqlite", executor=executor)
            summary = remote.run(points, timeout_s=30.0, progress=False)
        assert run_cli(["campaign", "run", "--design", str(design), "--store", str(tmp_path / "cli.sqlite"),
                        "--dask", cluster.scheduler_address, "--simulator-python", "test_campaign:counting_model"]) == 0
    finally:
        cluster.close()
    assert summary.counts.ok == len(points)
    by_id = {r.point_id: r.outputs for r in local.records()}
    assert len(by_id) == len(points)
    assert {r.point_id: r.outputs for r in remote.records()} == by_id
    cli_store = Campaign(counting_model, tmp_path / "cli.sqlite", model_name="test_campaign:counting_model")
    assert sorted(r.outputs["contact_radius_mm"] for r in cli_store.records("ok")) == sorted(
        r["contact_radius_mm"] for r in by_id.values())


# -- store, design, ids -----------------------------------------------------------------


def test_point_id_depends_on_values_and_settings_only():
    h = settings_hash("toy:model", {"mesh": "fine"})
    assert point_id({"sphere_radius_mm": 450, "force_kn": 75.0}, h) == point_id({"force_kn": 75.0, "sphere_radius_mm": 450.0}, h)
    assert point_id({"sphere_radius_mm": 450.0, "force_kn": 75.0}, h) != point_id({"sphere_radius_mm": 450.0, "force_kn": 75.5}, h)
    assert point_id({"sphere_radius_mm": 450.0}, h) != point_id({"sphere_radius_mm": 450.0}, settings_hash("toy:model", {}))
    assert settings_hash("toy:model", {}) != settings_hash("toy:other", {})


def test_points_are_submitted_grouped_by_radius(tmp_path):
    log = tmp_path / "calls.log"
    points = [p for pair in zip(toy_design([20, 30], sphere_radius_mm=600.0, call_log=str(log)),
                                toy_design([40, 50], sphere_radius_mm=300.0, call_log=str(log))) for p in pair]
    Campaign(counting_model, tmp_path / "runs.sqlite", executor=SerialExecutor()).run(points, progress=False)
    radii = [line.split("/")[0] for line in log.read_text().split()]
    assert radii == ["R300", "R300", "R600", "R600"]


def test_export_csv_round_trips_inputs_outputs_and_status(tmp_path):
    marker = tmp_path / "fail-now"
    marker.touch()
    points = toy_design([10, 13, 20], fail_marker=str(marker))
    campaign = Campaign(troublesome_model, tmp_path / "runs.sqlite", executor=SerialExecutor())
    campaign.run(points, progress=False)
    assert campaign.export_csv(tmp_path / "runs.csv") == 3
    with (tmp_path / "runs.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    by_force = {float(row["force_kn"]): row for row in rows}
    assert by_force[13.0]["status"] == "failed" and by_force[13.0]["reason"] == "ValueError: film collapsed"
    assert by_force[13.0]["contact_radius_mm"] == ""
    for force in (10.0, 20.0):
        params = next(p for p in points if p["force_kn"] == force)
        assert by_force[force]["status"] == "ok" and by_force[force]["reason"] == ""
        assert float(by_force[force]["contact_radius_mm"]) == hertz_radius_mm(params)
        assert float(by_force[force]["modulus_mpa"]) == params["modulus_mpa"]
    assert {"point_id", "elapsed_s", "settings_hash", "package_version", "created_at"} <= set(rows[0])


def test_design_inputs_are_validated(tmp_path):
    with pytest.raises(ValueError, match="no points"):
        as_design_points([])
    with pytest.raises(ValueError, match="column force_kn must be a finite number"):
        as_design_points([{"force_kn": float("nan")}])
    with pytest.raises(ValueError, match="must be a number, a boolean or a string"):
        as_design_points([{"force_kn": [1.0]}])
    with pytest.raises(ValueError, match="differ in length"):
        as_design_points({"a": [1.0, 2.0], "b": [1.0]})
    with pytest.raises(FileNotFoundError):
        read_design_csv(tmp_path / "missing.csv")
    (tmp_path / "d.csv").write_text("sphere_radius_mm,no_film,sphere_contact,force_kn\n450,true,tied,\n")
    assert read_design_csv(tmp_path / "d.csv") == [{"sphere_radius_mm": 450.0, "no_film": True, "sphere_contact": "tied"}]
    with pytest.raises(ValueError, match="timeout_s must be > 0"):
        Campaign(counting_model, tmp_path / "s.sqlite", executor=SerialExecutor()).run(toy_design([1]), timeout_s=0)
    with pytest.raises(ValueError, match="model must be callable"):
        Campaign("not a model", tmp_path / "s.sqlite")
    with pytest.raises(ValueError, match="max_workers"):
        LocalPoolExecutor(0)


def test_opening_a_store_checks_what_it_is(tmp_path):
    with pytest.raises(FileNotFoundError):
        RunStore(tmp_path / "missing.sqlite", create=False)
    (tmp_path / "text.sqlite").write_text("not a database")
    with pytest.raises(ValueError, match="not a campaign store"):
        RunStore(tmp_path / "text.sqlite")
    with sqlite3.connect(tmp_path / "other.sqlite") as conn:
        conn.execute("CREATE TABLE runs (x)")
    with pytest.raises(ValueError, match="not a campaign store"):
        RunStore(tmp_path / "other.sqlite")


# -- command line -----------------------------------------------------------------------


def test_cli_run_status_export(tmp_path, capsys):
    design = write_design_csv(tmp_path / "design.csv", toy_design([30, 60, 90]))
    store = tmp_path / "runs.sqlite"
    run = ["campaign", "run", "--design", str(design), "--store", str(store), "--workers", "1",
           "--simulator-python", "test_campaign:counting_model", "--json"]
    assert run_cli(run) == 0
    assert json.loads(capsys.readouterr().out)["n_run"] == 3
    assert run_cli(run) == 0
    assert json.loads(capsys.readouterr().out)["n_run"] == 0
    assert run_cli(["campaign", "status", "--store", str(store), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == {"ok": 3, "failed": 0, "pending": 0, "total": 3, "running": None}
    assert run_cli(["campaign", "export", "--store", str(store), "--out", str(tmp_path / "runs.csv")]) == 0
    with (tmp_path / "runs.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    radii = sorted(float(row["contact_radius_mm"]) for row in rows)
    assert radii == pytest.approx(sorted(hertz_radius_mm(p) for p in toy_design([30, 60, 90])), rel=1e-12)


@pytest.mark.parametrize("design_text, message", [
    (None, "does not exist"),
    ("modulus_mpa,poisson,sphere_radius_mm\n2800,0.33,450\n", "lacks column(s) force_kn"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,lots\n", "force_kn must be a finite number"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.7,450,75\n", "poisson must lie in (-1, 0.5)"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn,mesh\n2800,0.3,450,75,1\n", "unknown design column(s) mesh"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn,sphere_contact\n2800,0.3,450,75,glued\n", "sphere_contact must be"),
    # the bounds `filmcal fem` gives the same quantities
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn\n1e300,0.33,450,75\n", "modulus_mpa must lie in [1, 1e+06]"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,1e300\n", "force_kn must lie in [0.001, 2000]"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,10,75\n", "sphere_radius_mm must be at least 55 mm"),
    ("modulus_mpa,poisson,sphere_radius_mm,force_kn,film_thickness_mm\n2800,0.33,450,75,9\n",
     "film_thickness_mm must lie in [0.001, 5]"),
])
def test_cli_rejects_bad_designs_with_one_line(tmp_path, capsys, design_text, message):
    design = tmp_path / "design.csv"
    if design_text is not None:
        design.write_text(design_text)
    # the FE model's design columns are checked before anything runs or is written
    status = run_cli(["campaign", "run", "--design", str(design), "--store", str(tmp_path / "runs.sqlite")])
    err = capsys.readouterr().err
    assert status == 2
    assert message in err and err.count("\n") == 1
    assert not (tmp_path / "runs.sqlite").exists()


@pytest.mark.parametrize("argv", [
    ["campaign", "run", "--design", "d.csv", "--store", "s.sqlite", "--workers", "0"],
    ["campaign", "run", "--design", "d.csv", "--store", "s.sqlite", "--timeout-s", "-1"],
    ["campaign", "run", "--design", "d.csv", "--store", "s.sqlite", "--workers", "2", "--dask", "tcp://x:1"],
    ["campaign", "status", "--store", "missing.sqlite"],
    ["campaign", "export", "--store", "d.csv", "--out", "out.csv"],
])
def test_cli_rejects_bad_options_with_one_line(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "d.csv").write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,75\n")
    assert run_cli(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error" in err
    assert not (tmp_path / "s.sqlite").exists()


def test_cli_model_option_imports_by_name_only(tmp_path, capsys):
    design = write_design_csv(tmp_path / "design.csv", toy_design([30]))
    for spec, message in [(str(tmp_path / "design.csv"), "MODULE:FUNCTION"), ("os.path:nothing_here", "cannot import")]:
        assert run_cli(["campaign", "run", "--design", str(design), "--store", str(tmp_path / "s.sqlite"),
                        "--simulator-python", spec]) == 2
        assert message in capsys.readouterr().err


def test_a_design_with_a_byte_order_mark_reads_its_first_column(tmp_path):
    """A spreadsheet's UTF-8 BOM made the first column '\\ufeffmodulus_mpa' (misread as unknown)."""
    path = tmp_path / "d.csv"
    path.write_bytes("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,75\n".encode("utf-8-sig"))
    assert read_design_csv(path) == [{"modulus_mpa": 2800.0, "poisson": 0.33, "sphere_radius_mm": 450.0,
                                      "force_kn": 75.0}]


def test_export_escapes_text_a_spreadsheet_would_run(tmp_path):
    """A reason or label starting with '=' or '@' was exported as it was: a formula in a spreadsheet."""
    from filmcal.campaign.store import _cell

    assert _cell("=HYPERLINK(1)") == "'=HYPERLINK(1)" and _cell("@SUM(A1)") == "'@SUM(A1)"
    assert _cell(-3.5) == "-3.5" and _cell(-3) == "-3" and _cell("timeout after 2 s") == "timeout after 2 s"
