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


def _copy_of(quick_study, tmp_path) -> tuple[Path, dict, str]:
    """A copy of the quick study, its manifest, and the key of its HS edge/small posterior's surrogate."""
    copy = tmp_path / "s"
    shutil.copytree(quick_study[0], copy)
    manifest = json.loads((copy / "study.json").read_text())
    key, = {e["surrogate"] for e in manifest["artefacts"].values()
            if e["kind"] == "posterior" and e["spec"]["model"] == "edge/small"}
    return copy, manifest, key


def test_a_deleted_surrogate_is_refitted_the_same_and_said(quick_study, tmp_path, capsys):
    copy, manifest, key = _copy_of(quick_study, tmp_path)
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
    assert _sphere_correction(capsys, copy) == _sphere_correction(capsys, quick_study[0]) | {
        "provenance": _sphere_correction(capsys, copy)["provenance"]}


def test_a_surrogate_recorded_without_a_rule_is_refitted_by_the_rule_it_was_made_with(quick_study, tmp_path, capsys):
    """A study's surrogates made before the evidence chose their output transform are recorded without a
    `transform_rule`; such a surrogate, lost, is refitted by sign (log while every excess is positive: HS's
    edge excesses are), as it was made, not under today's rule."""
    copy, manifest, key = _copy_of(quick_study, tmp_path)
    assert json.loads((copy / "surrogates" / f"{key}.json").read_text())["params"]["output_transform"] == "auto"
    for entry in manifest["artefacts"].values():
        if entry["kind"] == "radius-surrogate":
            assert entry.pop("transform_rule") == "evidence"
    (copy / "study.json").write_text(json.dumps(manifest))
    (copy / "surrogates" / f"{key}.npz").unlink()
    assert cli.main(["pipeline", "--quick", "--films", "HS", "--study-dir", str(copy), "--no-report"]) == 0
    assert "was missing: refitted" in capsys.readouterr().err
    saved = json.loads((copy / "surrogates" / f"{key}.json").read_text())
    assert saved["params"]["output_transform"] == "log" and saved["output_transform"]["kind"] == "log"
    entry = json.loads((copy / "study.json").read_text())["artefacts"][f"surrogates/{key}.json"]
    assert entry["transform_rule"] == "sign"


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
