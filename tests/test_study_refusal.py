"""A writer that is refused changes nothing on disk."""
from __future__ import annotations

import pytest

from filmcal._errors import InputError
from filmcal.study import Study


def test_a_study_refusing_other_settings_leaves_its_manifest_untouched(tmp_path):
    study = Study(tmp_path / "s", create=True)
    with study.writing("first"):
        study.set_settings({"pipeline": {"train_runs": 200}, "seed": 0})
    manifest = study.layout.manifest
    before = (manifest.read_bytes(), manifest.stat().st_mtime_ns)
    again = Study(tmp_path / "s")
    with pytest.raises(InputError, match="other settings"):
        with again.writing("second"):
            again.set_settings({"pipeline": {"train_runs": 40}, "seed": 0})
    assert (manifest.read_bytes(), manifest.stat().st_mtime_ns) == before
    assert not list(manifest.parent.glob("*.tmp"))


def test_a_new_study_whose_first_writer_is_refused_leaves_nothing_and_takes_the_next_dataset(tmp_path):
    """A refused `calibrate` (rows of different bodies) left `.lock` and a `study.json` bound to the refused
    dataset: the next, good dataset was then refused in that folder as 'differs from the one this study was
    made with'. A study that recorded something keeps its manifest (the test above)."""
    import subprocess
    import sys
    from pathlib import Path

    examples = Path(__file__).resolve().parents[1] / "examples" / "lab"
    bad = tmp_path / "bodies.csv"
    bad.write_text("film,sphere_radius_mm,force_kn,measured_radius_mm,sphere_modulus_mpa\n"
                   "LAB7,300,30,4.9,210000\nLAB7,300,50,5.7,70000\nLAB7,450,60,6.7,210000\n")
    folder = tmp_path / "study"
    cli = [sys.executable, "-m", "filmcal.cli", "calibrate", "--film", "LAB7", "--films-file",
           str(examples / "films.toml"), "--study-dir", str(folder), "--imprint-model", "edge"]
    p = subprocess.run(cli + ["--data", str(bad)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "bodies" in p.stderr, p.stderr
    assert not folder.exists()
    folder.mkdir()  # a folder the user made stays, empty
    p = subprocess.run(cli + ["--data", str(bad)], capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and list(folder.iterdir()) == []
    study = Study(folder, create=True)
    with pytest.raises(ValueError, match="no such file"):
        with study.writing("third"):
            study.dataset_rows("HS", None, tmp_path / "missing.csv")
    assert list(folder.iterdir()) == []
    with study.writing("fourth"):  # the same object writes afterwards as a new study would
        study.dataset_rows("HS", None)
    assert study.layout.manifest.exists()
