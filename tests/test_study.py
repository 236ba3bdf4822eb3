"""The Study: FE runs into validated radius surrogates, artefacts keyed by what made them, one writer, integrity."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from filmcal._errors import InputError
from filmcal.fem import Film, get_model
from filmcal.study import FESettings, Study, seed_for
from filmcal.surrogate.radius import FERadiusModel, SurrogateDomain

DOMAIN = SurrogateDomain(modulus_mpa=(1500.0, 6000.0), poisson=(0.32, 0.34), radius_levels_mm=(450.0, 600.0),
                         force_kn=(50.0, 100.0))
FE = FESettings(n_train=30, n_test=12, seed=3, domain=DOMAIN)


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    root = tmp_path_factory.mktemp("study") / "s"
    study = Study(root, create=True)
    with study.writing():
        model, validation, key = study.radius_model(FE, "contact_radius_mm", workers=2)
    return study, model, validation, key


def test_surrogate_reproduces_held_out_fe_runs(built):
    _, _, validation, _ = built
    assert validation.n == 12
    assert validation.area_rms_relative_error < 0.005
    assert validation.radius_max_error_mm < 0.03


def test_radius_model_agrees_with_the_fe_model(built):
    _, model, _, _ = built
    mean, std = model.predict(np.array([2500.0, 4000.0]), 0.33, 450.0, 75e3)
    fe, fe_std = FERadiusModel().predict(np.array([2500.0, 4000.0]), 0.33, 450.0, 75e3)
    direct = [get_model(450.0).solve(Film(e, 0.33), 75e3).contact_radius_mm for e in (2500.0, 4000.0)]
    assert np.allclose(fe, direct) and np.all(fe_std == 0)
    assert np.all(np.abs(mean - fe) < 0.02)
    assert np.all(std > 0)


def test_outside_the_domain_is_nan(built):
    _, model, _, _ = built
    mean, _ = model.predict(500.0, 0.33, 450.0, 75e3)
    assert np.isnan(mean)


def test_same_settings_reuse_other_settings_are_computed_beside(built):
    study, model, _, key = built
    reopened = Study(study.root)
    with reopened.writing():
        again, _, key2 = reopened.radius_model(FE, "contact_radius_mm", workers=1)
    assert key2 == key
    x = (3000.0, 0.33, 450.0, 75e3)
    assert again.predict(*x)[0] == model.predict(*x)[0]
    # another seed: another key, a new surrogate beside the old one, the old one untouched
    from dataclasses import replace

    other = replace(FE, seed=4, n_train=20, n_test=6)
    with reopened.writing():
        _, _, key3 = reopened.radius_model(other, "contact_radius_mm", workers=2)
    assert key3 != key
    kinds = [e["kind"] for e in Study(study.root).manifest.data["artefacts"].values()]
    assert kinds.count("radius-surrogate") == 6  # json, npz and validation of each


def test_a_changed_artefact_is_refused_with_its_name(built, tmp_path):
    study, _, _, key = built
    path = study.layout.surrogate_validation(key)
    original = path.read_bytes()
    try:
        data = json.loads(original)
        data["summary"]["q2"] = 1.0
        path.write_text(json.dumps(data))
        with pytest.raises(InputError, match=path.name):
            with Study(study.root).writing():
                Study(study.root).radius_model(FE, "contact_radius_mm")
    finally:
        path.write_bytes(original)


def test_missing_or_foreign_folder_is_an_error(tmp_path):
    with pytest.raises(InputError, match="not a study folder"):
        Study(tmp_path)
    with pytest.raises(InputError, match="does not exist"):
        Study(tmp_path / "typo")
    (tmp_path / "x.txt").write_text("mine")
    with pytest.raises(InputError, match="files but no study manifest"):
        Study(tmp_path, create=True)


def test_one_writer_at_a_time(tmp_path):
    root = tmp_path / "s"
    study = Study(root, create=True)
    with study.writing():  # makes the folder and its manifest
        pass
    holder = textwrap.dedent(f"""
        import sys, time
        from filmcal.study import Study
        with Study({str(root)!r}).writing("holder"):
            print("held", flush=True)
            time.sleep(30)
    """)
    proc = subprocess.Popen([sys.executable, "-c", holder], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "held"
        with pytest.raises(InputError, match=r"being written by pid \d+ .*holder"):
            with study.writing():
                pass
    finally:
        proc.kill()
        proc.wait()
    with study.writing():  # free again once the holder is gone
        pass



def test_a_run_waits_for_a_brief_holder_that_keeps_a_cache(tmp_path):
    """A command keeping a cache holds the writer lock for a moment: a run started then waits for it instead of
    stopping, while another brief writer is refused at once (it keeps nothing) and a run's own hold refuses a
    run at once, as before."""
    root = tmp_path / "s"
    study = Study(root, create=True)
    with study.writing():
        pass

    def hold(brief: bool, seconds: float) -> subprocess.Popen:
        holder = textwrap.dedent(f"""
            import time
            from filmcal.study import Study
            with Study({str(root)!r}).writing("holder", brief={brief}):
                print("held", flush=True)
                time.sleep({seconds})
        """)
        proc = subprocess.Popen([sys.executable, "-c", holder], stdout=subprocess.PIPE, text=True)
        assert proc.stdout.readline().strip() == "held"
        return proc

    proc = hold(True, 1.5)
    try:
        with pytest.raises(InputError, match=r"being written by pid \d+ .*holder\); wait"):
            with Study(root).writing("another cache", brief=True):
                pass
        t0 = time.monotonic()
        with Study(root).writing("a run"):
            waited = time.monotonic() - t0
        assert 0.5 < waited < 30
        assert proc.wait(timeout=30) == 0
    finally:
        proc.kill()
        proc.wait()
    proc = hold(False, 30)
    try:
        t0 = time.monotonic()
        with pytest.raises(InputError, match="holder"):
            with Study(root).writing("a run"):
                pass
        assert time.monotonic() - t0 < 5
    finally:
        proc.kill()
        proc.wait()


def test_a_run_is_not_refused_in_the_moment_a_brief_holder_names_itself_or_leaves(tmp_path):
    """The lock file is empty between a holder's taking the lock and naming itself, and again as it releases
    it: a run that reads it then waits on, as for a named brief holder."""
    root = tmp_path / "s"
    study = Study(root, create=True)
    with study.writing():
        pass
    holder = textwrap.dedent(f"""
        import time
        from filmcal.study.manifest import StudyLock
        lock = StudyLock({str(study.layout.lock)!r})
        print("holding", flush=True)
        end = time.monotonic() + 20
        while time.monotonic() < end:
            try:
                lock.acquire("keeping a cache", brief=True)
            except Exception:
                continue
            time.sleep(0.002)
            lock.release()
            time.sleep(0.002)
    """)
    proc = subprocess.Popen([sys.executable, "-c", holder], stdout=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "holding"
        for _ in range(40):  # refused 3 times in 10 when the empty file was taken for a run's hold
            with Study(root).writing("a run"):
                pass
    finally:
        proc.kill()
        proc.wait()

def test_other_settings_are_refused_naming_what_differs(tmp_path):
    study = Study(tmp_path / "s", create=True)
    with study.writing():
        study.set_settings({"seed": 0, "train_runs": 200})
    with pytest.raises(InputError, match="seed 0 -> 1"):
        with study.writing():
            study.set_settings({"seed": 1, "train_runs": 200})


def test_seed_streams_are_independent_and_reproducible():
    assert seed_for(0, "design-train") == seed_for(0, "design-train")
    values = {seed_for(s, name) for s in (0, 1) for name in ("design-train", "design-test", "chain-HS")}
    assert len(values) == 6


def test_spec_like_pipeline_takes_the_study_s_own_sizes(tmp_path):
    study = Study(tmp_path / "s", create=True)
    assert study.spec_like_pipeline("HS").fe.n_train == 200  # a study without pipeline settings: calibrate's
    with study.writing():
        study.set_settings({"pipeline": {"train_runs": 40, "test_runs": 12, "max_steps": 3000}, "seed": 7})
    spec = study.spec_like_pipeline("HS", "activation", "large", "50-100")
    assert (spec.imprint, spec.fe.kinematics, spec.loads, spec.max_steps) == ("activation", "large", "50-100", 3000)
    assert (spec.fe.n_train, spec.fe.n_test, spec.fe.seed) == (40, 12, 7)
