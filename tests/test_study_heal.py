"""States heal: a surrogate deleted from a finished study is made again by the stage that makes it."""
from __future__ import annotations

import hashlib
import json
import shutil

from filmcal import cli


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _sphere_correction(capsys, study) -> dict:
    assert cli.main(["correct", "--film", "HS", "--imprint-model", "edge", "--measured-radius-mm", "6.6",
                     "--sphere-radius-mm", "450", "--force-kn", "75", "--study-dir", str(study), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_a_deleted_surrogate_is_refitted_the_same_and_said(quick_study, tmp_path, capsys):
    study, _, _ = quick_study
    copy = tmp_path / "s"
    shutil.copytree(study, copy)
    manifest = json.loads((copy / "study.json").read_text())
    key, = {e["surrogate"] for e in manifest["artefacts"].values()
            if e["kind"] == "posterior" and e["spec"]["model"] == "edge/small"}
    npz = copy / "surrogates" / f"{key}.npz"
    before = _sha(npz)
    npz.unlink()

    # the sphere correction needs it: refused with what to run, nothing guessed
    assert cli.main(["correct", "--film", "HS", "--imprint-model", "edge", "--measured-radius-mm", "6.6",
                     "--sphere-radius-mm", "450", "--force-kn", "75", "--study-dir", str(copy)]) == 2
    assert "is missing" in capsys.readouterr().err

    # the rerun remakes it from the recorded FE runs (same runs, same seed: the same fit), says so, records it
    assert cli.main(["pipeline", "--quick", "--films", "HS", "--study-dir", str(copy), "--no-report"]) == 0
    err = capsys.readouterr().err
    assert f"{key}.npz of surrogate {key}" in err and "was missing: refitted" in err
    assert _sha(npz) == before
    rebuilt = json.loads((copy / "study.json").read_text())["rebuilt"]
    assert rebuilt[-1]["artefact"] == f"surrogates/{key}" and rebuilt[-1]["missing"] == [f"{key}.npz"]
    assert _sphere_correction(capsys, copy) == _sphere_correction(capsys, study) | {
        "provenance": _sphere_correction(capsys, copy)["provenance"]}
