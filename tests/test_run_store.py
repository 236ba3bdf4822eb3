"""Runs are shared: a second dataset in another study, given the same --run-store, runs no FE run again;
each study pins the runs it used by their SHA-256 and refuses a store whose runs were changed."""
from __future__ import annotations

import json
import shutil
import sqlite3

import pytest

from filmcal import cli

HEADER = "film,sphere_radius_mm,force_kn,radius_error_mm\n"
#: The design alone (no runs at the data's cases) unless a test says otherwise: the store's mechanics
SMALL = ["--film", "HS", "--imprint-model", "edge", "--train-runs", "24", "--test-runs", "8", "--max-steps", "1500",
         "--workers", "1", "--moduli-per-case", "0"]


def _calibrate(tmp_path, study: str, data: str, capsys, *more: str) -> int:
    status = cli.main(["calibrate", "--data", str(tmp_path / data), "--study-dir", str(tmp_path / study),
                       "--run-store", str(tmp_path / "store"), *SMALL, *more])
    err = capsys.readouterr().err
    assert status == 0, err
    return status


@pytest.fixture
def two_labs(tmp_path):
    (tmp_path / "a.csv").write_text(HEADER + "HS,450,75,1.2\nHS,300,50,1.1\nHS,600,100,1.3\n")
    (tmp_path / "b.csv").write_text(HEADER + "HS,375,75,1.15\nHS,525,50,1.05\nHS,450,100,1.25\n")
    return tmp_path


def _runs(tmp_path) -> list[tuple]:
    (store,) = (tmp_path / "store").glob("runs-*.sqlite")
    with sqlite3.connect(store) as db:
        return db.execute("select point_id, status, attempts, finished_at from runs order by point_id").fetchall()


def test_a_second_dataset_runs_no_fe_run_again(two_labs, capsys):
    assert _calibrate(two_labs, "first", "a.csv", capsys) == 0
    runs = _runs(two_labs)
    assert len(runs) == 32 and {r[1] for r in runs} == {"ok"}  # the design's 24 + 8 runs
    assert _calibrate(two_labs, "second", "b.csv", capsys) == 0
    assert _runs(two_labs) == runs  # not one run again: same runs, attempts and finishing times
    first, second = (json.loads((two_labs / s / "study.json").read_text()) for s in ("first", "second"))
    assert first["run_store"] == second["run_store"] == str((two_labs / "store").resolve())
    assert first["fe_runs"] == second["fe_runs"] and len(first["fe_runs"]) == 1
    # with runs at each dataset's cases (8 moduli at each of its 3), a dataset adds only its own cases' runs
    assert _calibrate(two_labs, "third", "a.csv", capsys, "--moduli-per-case", "8") == 0
    with_cases = _runs(two_labs)
    assert len(with_cases) == 32 + 24 and set(runs) <= set(with_cases)
    assert _calibrate(two_labs, "fourth", "b.csv", capsys, "--moduli-per-case", "8") == 0
    assert len(_runs(two_labs)) == 32 + 24 + 24 and set(with_cases) <= set(_runs(two_labs))
    assert not (two_labs / "first" / "runs").exists()  # the runs live in the shared store only
    assert first["dataset"]["sha256"] != second["dataset"]["sha256"]  # two datasets indeed


def test_new_studies_share_the_users_cache_by_default(two_labs, capsys, monkeypatch):
    """Without --run-store a new study keeps its runs in the user's cache folder, so a second study of
    another dataset runs no FE run again, and one with another FE setting reuses none;
    FILMCAL_RUN_STORE=study keeps them in the study's own folder."""
    from filmcal.study.core import RUN_STORE_VARIABLE

    monkeypatch.delenv(RUN_STORE_VARIABLE)
    monkeypatch.setenv("XDG_CACHE_HOME", str(two_labs / "cache"))
    store = two_labs / "cache" / "filmcal" / "runs"

    def calibrate(study: str, data: str, *more: str) -> dict:
        status = cli.main(["calibrate", "--data", str(two_labs / data), "--study-dir", str(two_labs / study), *SMALL,
                           *more])
        assert status == 0, capsys.readouterr().err
        return json.loads((two_labs / study / "study.json").read_text())

    first = calibrate("first", "a.csv")
    (db_path,) = store.glob("runs-*.sqlite")
    with sqlite3.connect(db_path) as db:
        runs = db.execute("select point_id, attempts, finished_at from runs order by point_id").fetchall()
    assert len(runs) == 32
    second = calibrate("second", "b.csv")
    with sqlite3.connect(db_path) as db:
        assert db.execute("select point_id, attempts, finished_at from runs order by point_id").fetchall() == runs
    assert first["run_store"] == second["run_store"] == str(store.resolve())
    assert not (two_labs / "first" / "runs").exists() and not (two_labs / "second" / "runs").exists()
    calibrate("changed", "a.csv", "--kinematics", "large")  # another FE setting: not one run reused
    (other,) = set(store.glob("runs-*.sqlite")) - {db_path}
    with sqlite3.connect(other) as db:
        assert db.execute("select count(*), sum(attempts) from runs where status = 'ok'").fetchone() == (32, 32)
    monkeypatch.setenv(RUN_STORE_VARIABLE, "study")
    own = calibrate("own", "a.csv")
    assert "run_store" not in own and len(list((two_labs / "own" / "runs").glob("runs-*.sqlite"))) == 1


def test_a_study_whose_store_is_out_of_reach_says_so_and_accepts_its_runs_computed_again(two_labs, capsys,
                                                                                         monkeypatch):
    """A colleague's copy of a study records a store it cannot use: one line says how to give another; there its
    runs are computed again and recognised as the ones the study used (timing aside), so the refit goes on."""
    from filmcal.study.core import RUN_STORE_VARIABLE

    monkeypatch.setenv(RUN_STORE_VARIABLE, str(two_labs / "theirs"))
    base = ["calibrate", "--data", str(two_labs / "a.csv"), "--study-dir", str(two_labs / "copy"), *SMALL]
    assert cli.main(base) == 0, capsys.readouterr().err
    capsys.readouterr()
    shutil.rmtree(two_labs / "theirs")
    (two_labs / "theirs").write_text("not a folder\n")  # out of reach
    shutil.rmtree(two_labs / "copy" / "surrogates")  # the refit reads the runs
    assert cli.main(base) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "run store" in err[0] and "--run-store" in err[0], err
    assert cli.main([*base, "--run-store", str(two_labs / "mine"), "--json"]) == 0, capsys.readouterr().err
    out = json.loads(capsys.readouterr().out)
    (store,) = (two_labs / "mine").glob("runs-*.sqlite")
    with sqlite3.connect(store) as db:
        assert db.execute("select count(*) from runs where status = 'ok'").fetchone() == (32,)
    assert out["modulus_mpa"]["median"] > 0


def test_a_study_refuses_runs_changed_in_the_shared_store(two_labs, capsys):
    assert _calibrate(two_labs, "first", "a.csv", capsys) == 0
    (store,) = (two_labs / "store").glob("runs-*.sqlite")
    with sqlite3.connect(store) as db:  # one run's answer edited after the study used it
        point, outputs = db.execute("select point_id, outputs_json from runs where status = 'ok' limit 1").fetchone()
        changed = {k: (v * 1.01 if isinstance(v, float) else v) for k, v in json.loads(outputs).items()}
        db.execute("update runs set outputs_json = ? where point_id = ?", (json.dumps(changed), point))
    shutil.rmtree(two_labs / "first" / "surrogates")  # the surrogate is refitted, so the runs are read again
    assert cli.main(["calibrate", "--data", str(two_labs / "a.csv"), "--study-dir", str(two_labs / "first"),
                     *SMALL]) == 2  # the recorded store, without --run-store
    err = capsys.readouterr().err
    assert "differ from those this study used" in err and len(err.strip().splitlines()) == 1


def test_two_studies_at_once_on_one_store_compute_each_run_once(two_labs):
    """Two calibrations started together on one shared store: the second waits for the first (saying so) and
    then reuses its runs; every run of the store was attempted once, and both studies end well."""
    import subprocess
    import sys
    import time

    def start(study: str, data: str):
        return subprocess.Popen([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(two_labs / data),
                                 "--study-dir", str(two_labs / study), "--run-store", str(two_labs / "store"),
                                 *SMALL], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)

    first = start("first", "a.csv")
    deadline = time.monotonic() + 120
    while not list((two_labs / "store").glob("runs-*.sqlite.lock")) and time.monotonic() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)  # the first holds the store's lock, computing its runs
    second = start("second", "b.csv")
    err_first = first.communicate(timeout=900)[1]
    err_second = second.communicate(timeout=900)[1]
    assert first.returncode == 0, err_first[-2000:]
    assert second.returncode == 0, err_second[-2000:]
    assert "waiting for the shared run store" in err_second
    runs = _runs(two_labs)
    assert len(runs) == 32 and {r[1] for r in runs} == {"ok"} and {r[2] for r in runs} == {1}


def test_calibrate_shows_its_fe_runs_as_they_finish(two_labs, capsys):
    """`calibrate` printed nothing until it was done (minutes on a new dataset); its FE runs now advance a
    progress display like the pipeline's (`--progress log`: plain lines)."""
    status = cli.main(["calibrate", "--data", str(two_labs / "a.csv"), "--study-dir", str(two_labs / "shown"),
                       "--run-store", str(two_labs / "store"), *SMALL, "--progress", "log"])
    err = capsys.readouterr().err
    assert status == 0, err
    assert "[calibrate] 32/32 done" in err and "(FE runs)" in err
