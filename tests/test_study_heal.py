"""States heal: a surrogate deleted from a finished study is made again by the stage that makes it."""
from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

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


def test_rough_laws_are_artefacts_that_a_rerun_reads_instead_of_recomputing(quick_study, tmp_path, capsys):
    """The rough wheel's boundary-element laws are kept as they are computed: a curves stage run again (after
    an interrupt, or its curves lost) reads them and gives the same curves to the last digit."""
    study, _, _ = quick_study
    copy = tmp_path / "s"
    shutil.copytree(study, copy)
    laws = {p.name: (_sha(p), p.stat().st_mtime_ns) for p in (copy / "roughlaws").glob("*.npz")}
    assert laws  # the quick pipeline has a rough wheel
    manifest = json.loads((copy / "study.json").read_text())
    kinds = {Path(rel).name: e["kind"] for rel, e in manifest["artefacts"].items() if rel.startswith("roughlaws/")}
    assert set(kinds) == set(laws) and set(kinds.values()) == {"rough-law"}
    before = (copy / "curves" / "curves-HS.csv").read_bytes()
    shutil.rmtree(copy / "curves")
    assert cli.main(["pipeline", "--quick", "--films", "HS", "--study-dir", str(copy), "--no-report",
                     "--progress", "log"]) == 0
    err = capsys.readouterr().err
    assert "pressure-closure laws (BEM)" not in err  # none computed
    assert {p.name: (_sha(p), p.stat().st_mtime_ns) for p in (copy / "roughlaws").glob("*.npz")} == laws
    assert (copy / "curves" / "curves-HS.csv").read_bytes() == before
