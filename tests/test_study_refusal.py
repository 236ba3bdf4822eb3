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
