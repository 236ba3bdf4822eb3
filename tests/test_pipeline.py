"""The pipeline end to end (quick version, one film): results on disk, resumed without recomputing."""
from __future__ import annotations

import csv
import json
import re
import subprocess
import sys

import numpy as np

from filmcal._parallel import descendant_pids, pid_alive
from filmcal.hertz import hertz_radius_mm


def test_quick_pipeline_writes_every_stage(quick_study):
    study, summary, _ = quick_study
    hs = summary["films"]["HS"]
    assert 1500 < hs["modulus_mpa"]["median"] < 5000  # HS near the paper's 2800 MPa
    # the posterior is named relative to the study (as the manifest names it), whoever's working directory wrote it
    assert not hs["posterior_file"].startswith("/") and (study / hs["posterior_file"]).is_file()
    assert hs["modulus_mpa"]["ci90"][0] < hs["modulus_mpa"]["median"] < hs["modulus_mpa"]["ci90"][1]
    with open(study / "curves" / "curves-HS.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert {r["wheel"] for r in rows} == {"smooth", "rough Ra 1.5 um"}
    assert len(rows) == 2 * 3  # three offsets at 50 kN, smooth and rough wheel
    for row in rows:  # the film enlarges the patch, the band contains its median
        assert float(row["delta_area_lo_mm2"]) <= float(row["delta_area_median_mm2"]) <= float(row["delta_area_hi_mm2"])
        assert 0 < float(row["ratio_median"]) < 1
    for name in ("study.json", "design.json", "fe-verification.json", "wheelrail-outlines.json",
                 "crossval/crossval-HS.json", "comparison-HS.json", "summary.json", "report/report.html",
                 "report/report.pdf"):
        assert (study / name).exists(), name
    # every artefact is recorded in the manifest with its SHA-256, and the file still matches it
    from filmcal._io import sha256_file

    manifest = json.loads((study / "study.json").read_text())
    assert {e["kind"] for e in manifest["artefacts"].values()} >= {"posterior", "radius-surrogate", "curves"}
    for rel, entry in manifest["artefacts"].items():
        assert sha256_file(study / rel) == entry["sha256"], rel
    # each imprint model was calibrated, compared, and the weights sum to one
    comparison = json.loads((study / "comparison-HS.json").read_text())
    assert set(comparison["weights"]) == {"edge/small", "activation/small"}
    assert abs(sum(comparison["weights"].values()) - 1) < 1e-9
    verification = json.loads((study / "fe-verification.json").read_text())
    for case in verification["hertz"]:  # no film: the FE model reproduces Hertz (DESIGN: R450/75 kN 6.031 mm)
        a = hertz_radius_mm(case["sphere_radius_mm"], case["force_n"])
        assert abs(case["fe_radius_mm"] / a - 1) < 2e-3
    # leave-one-case-out on Table 1: the Hertz area (the truth) inside the corrected 90 % interval in >= 8 of 10
    crossval = json.loads((study / "crossval" / "crossval-HS.json").read_text())
    assert crossval["hits"] >= 8
    assert np.allclose(crossval["hertz_area_mm2"], np.pi * hertz_radius_mm(np.asarray(crossval["sphere_radius_mm"]),
                                                                             np.asarray(crossval["force_n"])) ** 2)
    design = json.loads((study / "design.json").read_text())
    for part in ("train", "test"):  # the optimised designs beat plain random Latin hypercubes
        assert design[part]["quality"]["min_distance"] > design[part]["random_lhs_median"]["min_distance"]
        assert design[part]["quality"]["phi_p"] < design[part]["random_lhs_median"]["phi_p"]


def test_quick_pipeline_resumes_by_reading(quick_study):
    _, summary, cmd = quick_study
    again = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert again.returncode == 0, again.stderr[-2000:]
    second = json.loads(again.stdout)
    assert second["films"]["HS"]["modulus_mpa"] == summary["films"]["HS"]["modulus_mpa"]
    assert second["elapsed_s"] < summary["elapsed_s"] / 2
    assert not re.search(r"\[(design|calibration|comparison|verification|curves|outlines|crossval|report)\]",
                         again.stderr), \
        again.stderr


def test_other_settings_in_the_same_folder_are_refused(quick_study):
    study, _, _ = quick_study
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--seed", "1", "--films", "HS",
                        "--study-dir", str(study)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "other settings" in p.stderr


def test_bad_input_exits_2(tmp_path):
    for extra in (["--films", "XX"], ["--films", "HS,HS"], ["--workers", "0"]):
        p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--study-dir", str(tmp_path), *extra],
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, (extra, p.stderr)


def test_correctors_from_the_study(quick_study, tmp_path):
    import pytest

    from filmcal._errors import InputError
    from filmcal.calibration import load_table1
    from filmcal.correction import read_curves_csv
    from filmcal.study import Study, correctors

    study, summary, _ = quick_study
    data = load_table1("HS")
    s = Study(study)
    assert summary["films"]["HS"]["model"] == "mixture"  # the answer to cite pools the compared models
    pinned = summary["films"]["HS"]["preferred_model"]["model"]
    [(weight, sphere_corrector, spec)] = correctors(s, "HS", "sphere", model=pinned)
    assert weight == 1.0 and spec["model"] == pinned
    sphere = sphere_corrector.correct(data.measured_radius_mm, data.sphere_radius_mm, data.force_n)
    hertz_area = np.pi * data.hertz_radius_mm**2  # the truth of the Hertzian experiments
    inside = (sphere.area_ci90_mm2[:, 0] <= hertz_area) & (hertz_area <= sphere.area_ci90_mm2[:, 1])
    assert inside.sum() >= 8
    # the corrector and the correction curves are two propagations of the same posterior
    row = next(r for r in read_curves_csv(study / "curves" / "curves-HS.csv") if r["wheel"] == "smooth")
    [(_, wheel, _)] = correctors(s, "HS", "wheel-rail", model=pinned)
    corrected = wheel.correct(row["area_film_median_mm2"], row["offset_mm"], row["force_kn"] * 1e3)
    assert abs(np.median(corrected.samples_mm2) / row["area_no_film_mm2"] - 1) < 0.01
    with pytest.raises(InputError, match="no posterior of MS"):
        correctors(s, "MS", "wheel-rail")
    # the way to make a missing one is the calibration at the study's own sizes: `calibrate`'s defaults (200 + 100
    # runs) would start a full-size campaign beside the quick study's 40 + 12
    with pytest.raises(InputError) as missing:
        correctors(s, "HS", "wheel-rail", kinematics="large")
    assert ("filmcal calibrate --film HS --study-dir" in str(missing.value) and "--kinematics large --train-runs 40 "
            "--test-runs 12 --moduli-per-case 0 --max-steps 10000" in str(missing.value))
    # unpinned: every compared model with its stacking weight
    mixture = correctors(s, "HS", "sphere")
    assert len(mixture) == 2 and abs(sum(w for w, _, _ in mixture) - 1) < 1e-9


def test_curves_command_at_a_load_outside_the_pipeline_grid(quick_study):
    from filmcal.correction import read_curves_csv

    study, _, _ = quick_study
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "curves", "--film", "HS", "--forces-kn", "120",
                        "--offsets-mm=-3", "--study-dir", str(study), "--json"], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    row = dict(zip(out["columns"], out["rows"][0]))
    assert row["delta_area_lo_mm2"] <= row["delta_area_median_mm2"] <= row["delta_area_hi_mm2"]
    assert 0 < row["ratio_lo"] <= row["ratio_median"] <= row["ratio_hi"] < 1
    at50 = next(r for r in read_curves_csv(study / "curves" / "curves-HS.csv") if r["wheel"] == "smooth" and r["offset_mm"] == -3)
    # a rim of nearly constant width around a larger patch: more area added, a smaller share of the whole
    assert row["delta_area_median_mm2"] > at50["delta_area_median_mm2"]
    assert row["ratio_median"] > at50["ratio_median"]
    for bad in (["--film", "XX"], ["--film", "HS", "--forces-kn", "-5"], ["--film", "HS", "--offsets-mm", "1:0:1"],
                ["--film", "MS"]):  # MS: no posterior in this study
        q = subprocess.run([sys.executable, "-m", "filmcal.cli", "curves", "--study-dir", str(study), *bad],
                           capture_output=True, text=True, timeout=120)
        assert q.returncode == 2 and len(q.stderr.strip().splitlines()) == 1, (bad, q.stderr)






def _start_until(cmd, log, marker: str, timeout_s: float = 900):
    """Start `cmd` with stderr to `log`; return the process once `marker` appears in its stderr."""
    import time

    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=open(log, "w"))
    deadline = time.monotonic() + timeout_s
    while marker not in log.read_text() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.1)
    assert proc.poll() is None, log.read_text()[-3000:]
    return proc


def _without_curves(quick_study, tmp_path):
    """A copy of the quick study without its curves and rough laws: a rerun goes straight to the curves stage,
    which starts with the rough laws on the workers."""
    import shutil

    study = tmp_path / "study"
    shutil.copytree(quick_study[0], study)
    shutil.rmtree(study / "curves")
    shutil.rmtree(study / "roughlaws")
    return study


def test_killed_pipeline_resumes_without_losing_finished_work(quick_study, tmp_path):
    """SIGKILL inside the curves stage (worker processes running): no process of the run alive 5 s later;
    the rerun recomputes no FE run, calibration or comparison and finishes the curves."""
    import signal
    import sqlite3
    import time

    study = _without_curves(quick_study, tmp_path)
    cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", "HS", "--workers", "2",
           "--study-dir", str(study), "--no-report", "--progress", "log"]
    first = _start_until(cmd, tmp_path / "first.err", "[curves] rough wheel:")
    time.sleep(1.0)
    family = descendant_pids(first.pid)
    assert family, "the curves stage runs on worker processes"
    first.send_signal(signal.SIGKILL)  # as hard as a power cut
    first.wait(timeout=60)
    time.sleep(5.0)
    assert not [p for p in family if pid_alive(p)]
    assert not (study / "curves" / "curves-HS.csv").exists()

    def finished_runs():
        [store] = study.glob("runs/*.sqlite")
        with sqlite3.connect(store) as db:
            return dict(db.execute("SELECT point_id, finished_at FROM runs WHERE status = 'ok'").fetchall())

    runs_before = finished_runs()
    kept = {p: p.read_bytes() for p in [*study.glob("posteriors/*.json"), study / "comparison-HS.json"]}
    # (other tests may have added posteriors of other options to the shared quick study)
    assert len(runs_before) == 40 + 12 and len(kept) >= 3
    second = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert second.returncode == 0, second.stderr[-2000:]
    assert finished_runs() == runs_before  # no FE run was recomputed
    assert all(p.read_bytes() == b for p, b in kept.items())  # nor a calibration or the comparison
    assert "[curves]" in second.stderr
    assert (study / "curves" / "curves-HS.csv").exists()


def test_ctrl_c_in_a_parallel_stage_and_a_second_writer(quick_study, tmp_path):
    """Ctrl-C inside the curves stage: exit 130 within 2 s with one line, no worker left. A second pipeline on
    the same folder while the first runs: refused at once with exit 2, one line naming the holder."""
    import signal
    import time

    study = _without_curves(quick_study, tmp_path)
    cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", "HS", "--workers", "2",
           "--study-dir", str(study), "--no-report", "--progress", "log"]
    first = _start_until(cmd, tmp_path / "first.err", "[curves] rough wheel:")
    t0 = time.monotonic()
    second = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert second.returncode == 2 and len(second.stderr.strip().splitlines()) == 1, second.stderr
    assert "being written by pid" in second.stderr and time.monotonic() - t0 < 30
    family = descendant_pids(first.pid)
    sent = time.monotonic()
    first.send_signal(signal.SIGINT)
    first.wait(timeout=30)
    assert time.monotonic() - sent < 2.0 and first.returncode == 130
    err = (tmp_path / "first.err").read_text().strip().splitlines()
    assert err[-1] == "filmcal pipeline: interrupted" and "Traceback" not in "\n".join(err)
    time.sleep(1.0)
    assert not [p for p in family if pid_alive(p)]


def test_correct_a_scanned_sphere_imprint(quick_study, tmp_path):
    """A scan of Table 1's HS imprint at R450 / 75 kN: the Hertz area lies in the corrected 90 % interval,
    and the outline without film is a circle of the corrected radius."""
    from PIL import Image

    from filmcal.calibration import load_table1

    study, _, _ = quick_study
    data = load_table1("HS")
    k = int(np.flatnonzero((data.sphere_radius_mm == 450) & (data.force_n == 75e3))[0])
    r_mm, dpi = float(data.measured_radius_mm[k]), 600.0
    px = 25.4 / dpi
    n = int(2 * r_mm / px) + 80
    y, x = (np.mgrid[0:n, 0:n] + 0.5 - n / 2) * px
    sub = np.linspace(-0.375, 0.375, 4) * px  # 4 x 4 supersampling: an anti-aliased edge, as a scanner gives
    cover = np.mean([(x + dx) ** 2 + (y + dy) ** 2 <= r_mm**2 for dx in sub for dy in sub], axis=0)
    rgb = np.stack([250 - 40 * cover, 250 - 200 * cover, 250 - 150 * cover], axis=-1).astype(np.uint8)
    Image.fromarray(rgb).save(tmp_path / "scan.png", dpi=(dpi, dpi))
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--scan",
                        str(tmp_path / "scan.png"), "--sphere-radius-mm", "450", "--force-kn", "75", "--study-dir",
                        str(study), "--outline-out", str(tmp_path / "outline.csv"), "--json"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    assert abs(out["measured_area_mm2"] / (np.pi * r_mm**2) - 1) < 0.005
    lo, hi = out["area_ci90_mm2"]
    assert lo <= np.pi * data.hertz_radius_mm[k] ** 2 <= hi
    with open(tmp_path / "outline.csv") as fh:
        mean = [(float(r["x_mm"]), float(r["y_mm"])) for r in csv.DictReader(fh) if r["part"] == "mean"]
    xy = np.asarray(mean)
    radius = np.hypot(*(xy - xy.mean(axis=0)).T)
    assert np.ptp(radius) < 0.05 and abs(np.pi * radius.mean() ** 2 / out["area_mm2"] - 1) < 0.01


def test_curves_with_a_measured_roughness_law(quick_study, tmp_path):
    """A compliant film-wheel law in series with the film spreads the load: larger film area, same bare area."""
    study, _, _ = quick_study
    law = tmp_path / "law.csv"
    law.write_text("closure_um,pressure_mpa\n0,0\n5,50\n12,200\n20,500\n30,1000\n")
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "curves", "--film", "HS", "--forces-kn", "50",
                        "--offsets-mm=-3", "--roughness-law", str(law), "--study-dir", str(study), "--json"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    out = json.loads(p.stdout)
    smooth, rough = (dict(zip(out["columns"], r)) for r in out["rows"])
    assert (smooth["wheel"], rough["wheel"]) == ("smooth", "rough, measured law")
    assert rough["area_no_film_mm2"] == smooth["area_no_film_mm2"]
    assert rough["delta_area_median_mm2"] > smooth["delta_area_median_mm2"] + 2.0
    law.write_text("closure_um,pressure_mpa\n0,0\n5,-1\n")
    bad = subprocess.run([sys.executable, "-m", "filmcal.cli", "curves", "--film", "HS", "--roughness-law", str(law),
                          "--study-dir", str(study)], capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1


def test_curves_name_the_transfer_fit_they_were_made_with(quick_study, monkeypatch):
    """Every wheel-rail answer carries the shipped transfer term, so curves made with another fit (an earlier
    filmcal's) are stale: the curves' spec names each chosen model's fit, the pipeline's curves record the
    shipped one, and another fit gives another spec (so the stage makes the curves again)."""
    from dataclasses import replace

    import filmcal.contact.transfer as transfer
    from filmcal.study import PipelineSettings, Study
    from filmcal.study.stages import curve_spec

    study_dir, _, _ = quick_study
    study = Study(study_dir)
    recorded = study.manifest.entry("curves/curves-HS.csv")["spec"]
    shipped = transfer.load_transfer_fit()
    assert recorded["transfer"] == {model: shipped.digest(model) for model in recorded["weights"]}
    settings = PipelineSettings.quick()
    assert curve_spec(study, "HS", settings)["transfer"] == recorded["transfer"]
    other = replace(shipped, coefficients={k: [c * 1.01 for c in v] for k, v in shipped.coefficients.items()})
    monkeypatch.setattr(transfer, "load_transfer_fit", lambda: other)
    assert curve_spec(study, "HS", settings)["transfer"] != recorded["transfer"]


def test_what_the_application_makes_names_its_revision(quick_study, monkeypatch):
    """A study keeps what the application model made (curves, the rough wheel's laws and growths, outlines)
    under specs that name the application's revision: a filmcal whose readings or solvers changed (another
    revision) finds none of them current and makes them again, instead of serving the old numbers."""
    from filmcal.contact import names
    from filmcal.study import PipelineSettings, Study
    from filmcal.study.stages import curve_spec

    study_dir, _, _ = quick_study
    study = Study(study_dir)
    made = {"curves": 0, "curves-part": 0, "curves-growth": 0, "rough-law": 0, "outlines": 0}
    for entry in study.manifest.data["artefacts"].values():
        if entry["kind"] in made:
            assert entry["spec"]["application_model_revision"] == names.APPLICATION_MODEL_REVISION, entry["kind"]
            made[entry["kind"]] += 1
    assert all(made.values()), made
    settings = PipelineSettings.quick()
    recorded = study.manifest.entry("curves/curves-HS.csv")["spec"]["application_model_revision"]
    assert curve_spec(study, "HS", settings)["application_model_revision"] == recorded
    monkeypatch.setattr(names, "APPLICATION_MODEL_REVISION", names.APPLICATION_MODEL_REVISION + 1)
    assert curve_spec(study, "HS", settings)["application_model_revision"] != recorded


def test_a_study_made_before_the_cases_runs_goes_on_with_its_own_design(tmp_path):
    """A full study recorded without ``moduli_per_case`` (made before the runs at the data's cases) is continued
    with its own design, said in one line, not refused; other settings still differ and are refused as before."""
    import warnings
    from dataclasses import replace

    import pytest

    from filmcal._errors import InputError
    from filmcal.study import PipelineSettings, Study
    from filmcal.study.stages import DesignKeptNote, _kept_design

    old = PipelineSettings(moduli_per_case=0)
    assert "moduli_per_case" not in old.record()  # what such a study recorded
    study = Study(tmp_path / "st", create=True)
    with study.writing("test"):
        study.set_settings({"pipeline": old.record(), "seed": 0})
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            kept = _kept_design(study, PipelineSettings())
        assert kept.moduli_per_case == 0 and kept.record() == old.record()
        assert [w.category for w in caught] == [DesignKeptNote]
        study.set_settings({"pipeline": kept.record(), "seed": 0})  # accepted
        other = replace(PipelineSettings(), train_runs=100)
        assert _kept_design(study, other) is other
        with pytest.raises(InputError, match="other settings"):
            study.set_settings({"pipeline": other.record(), "seed": 0})
