"""A study's answers do not depend on the order of its manifest's entries (the workers' finishing order)."""
from __future__ import annotations

import json
import shutil

from filmcal import cli


def _correct(capsys, study) -> dict:
    assert cli.main(["correct", "--film", "HS", "--measured-area-mm2", "150", "--offset-mm=-3", "--force-kn", "50",
                     "--study-dir", str(study), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_correction_is_independent_of_the_manifest_order(quick_study, tmp_path, capsys):
    study, _, _ = quick_study
    a, b = tmp_path / "a", tmp_path / "b"
    shutil.copytree(study, a)
    shutil.copytree(study, b)
    manifest = json.loads((b / "study.json").read_text())
    assert len(manifest["artefacts"]) > 2
    manifest["artefacts"] = dict(reversed(list(manifest["artefacts"].items())))
    (b / "study.json").write_text(json.dumps(manifest))
    first, second = _correct(capsys, a), _correct(capsys, b)
    assert len(first["models"]) >= 2  # a mixture: the order of its parts is what could matter
    assert first["area_mm2"] == second["area_mm2"] and first["area_std_mm2"] == second["area_std_mm2"]
    assert first["area_ci90_mm2"] == second["area_ci90_mm2"]
