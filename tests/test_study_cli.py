"""A lab's own film lot through the command line: its TOML film type and CSV dataset calibrated into a study,
then curves, corrections and the report from that study; options that select posteriors, never recalibrate."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from filmcal.fem import Film, get_model
from filmcal.hertz import hertz_radius_mm

pytestmark = pytest.mark.slow

TRUE_E_MPA = 3000.0
THICKNESS_MM = 0.1
CASES = [(375.0, 40.0), (375.0, 90.0), (525.0, 60.0), (525.0, 100.0)]  # off Table 1's (R, F) grid


def cli(*args: str, timeout: float = 900) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "filmcal.cli", *args], capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """LOT7 (activation 45 MPa, 0.1 mm thick): imprints made with the FE model at a known E, two repeats per
    case with Gaussian scatter, calibrated into a new study folder through the CLI."""
    folder = tmp_path_factory.mktemp("lab")
    (folder / "films.toml").write_text('[LOT7]\nrange_mpa = [45, 120]\nthickness_mm = 0.1\n'
                                       'description = "a lot unknown to filmcal"\n')
    rng = np.random.default_rng(11)
    rows = ["film,sphere_radius_mm,force_kn,measured_radius_mm,repeat,measurement_std_mm"]
    for r, f in CASES:
        fe = get_model(r, film_thickness_mm=THICKNESS_MM).solve(Film(TRUE_E_MPA, 0.33), f * 1e3)
        for repeat in (1, 2):
            rows.append(f"LOT7,{r:g},{f:g},{fe.contact_radius_mm + rng.normal(0, 0.02):.4f},{repeat},0.01")
    (folder / "lab.csv").write_text("\n".join(rows) + "\n")
    study = folder / "study"
    common = ["--film", "LOT7", "--films-file", str(folder / "films.toml"), "--data", str(folder / "lab.csv"),
              "--study-dir", str(study), "--train-runs", "40", "--test-runs", "8", "--max-steps", "3000",
              "--workers", "2", "--imprint-model", "edge", "--json"]  # one model: the options select posteriors
    first = cli("calibrate", *common)
    assert first.returncode == 0, first.stderr[-3000:]
    return folder, study, common, json.loads(first.stdout)


def _artefacts(study) -> dict:
    return json.loads((study / "study.json").read_text())["artefacts"]


def test_the_lab_lot_is_calibrated_from_its_csv(lab):
    _, _, _, out = lab
    assert out["film"]["name"] == "LOT7" and out["film"]["thickness_mm"] == THICKNESS_MM
    assert out["dataset"]["name"] == "lab" and len(out["dataset"]["sha256"]) == 64
    lo, hi = out["modulus_mpa"]["ci90"]
    assert lo <= TRUE_E_MPA <= hi  # the known modulus inside the 90 % interval
    assert out["n_data"] == 2 * len(CASES)


def test_curves_correct_and_report_of_the_user_film(lab, tmp_path):
    folder, study, _, out = lab
    curves = cli("curves", "--film", "LOT7", "--study-dir", str(study), "--forces-kn", "60", "--offsets-mm=-3",
                 "--json")
    assert curves.returncode == 0, curves.stderr[-2000:]
    row = dict(zip(*(lambda d: (d["columns"], d["rows"][0]))(json.loads(curves.stdout))))
    assert 0 < row["ratio_lo"] <= row["ratio_median"] <= row["ratio_hi"] < 1
    # a sphere imprint of the lot at the calibrated modulus: corrected, the Hertz area lies in the 90 % interval
    e = out["modulus_mpa"]["median"]
    measured = get_model(450.0, film_thickness_mm=THICKNESS_MM).solve(Film(e, 0.33), 70e3).contact_radius_mm
    before = len(_artefacts(study))
    sphere = cli("correct", "--film", "LOT7", "--study-dir", str(study), "--sphere-radius-mm", "450", "--force-kn",
                 "70", "--measured-radius-mm", f"{measured:.4f}", "--json")
    assert sphere.returncode == 0, sphere.stderr[-2000:]
    lo, hi = json.loads(sphere.stdout)["area_ci90_mm2"]
    assert lo <= np.pi * hertz_radius_mm(450.0, 70e3) ** 2 <= hi
    wheel = cli("correct", "--film", "LOT7", "--study-dir", str(study), "--measured-area-mm2", "150",
                "--offset-mm=-3", "--force-kn", "60", "--json")
    assert wheel.returncode == 0, wheel.stderr[-2000:]
    assert len(_artefacts(study)) == before  # correcting computed no new artefact
    report = cli("report", "--study-dir", str(study), "--out-dir", str(tmp_path / "rep"), "--json")
    assert report.returncode == 0, report.stderr[-2000:]
    assert "LOT7" in (tmp_path / "rep" / "report.html").read_text()


def test_correct_uses_the_posterior_the_options_select_and_never_recalibrates(lab):
    folder, study, common, _ = lab
    free = cli("calibrate", *common, "--poisson", "free")
    assert free.returncode == 0, free.stderr[-2000:]
    assert json.loads(free.stdout)["poisson_mode"] == "free"
    artefacts = _artefacts(study)
    kinds = [e["kind"] for e in artefacts.values()]
    assert kinds.count("posterior") == 2 and kinds.count("radius-surrogate") == 3  # the surrogate was reused
    base = ["correct", "--film", "LOT7", "--study-dir", str(study), "--sphere-radius-mm", "450", "--force-kn", "70",
            "--measured-radius-mm", "8.0", "--json"]
    ambiguous = cli(*base)
    assert ambiguous.returncode == 2 and "poisson" in ambiguous.stderr and len(ambiguous.stderr.splitlines()) == 1
    chosen = cli(*base, "--poisson", "free")
    assert chosen.returncode == 0, chosen.stderr[-2000:]
    assert _artefacts(study) == artefacts  # nothing recalibrated, nothing rewritten


def test_another_seed_in_the_same_folder_computes_beside(lab):
    _, study, common, first = lab
    before = _artefacts(study)
    again = cli("calibrate", *common, "--seed", "1")
    assert again.returncode == 0, again.stderr[-2000:]
    after = _artefacts(study)
    assert set(before) < set(after)  # new surrogate and posterior beside the old ones
    assert all(after[k]["sha256"] == v["sha256"] for k, v in before.items())  # the old ones untouched
    assert json.loads(again.stdout)["posterior_file"] != first["posterior_file"]
