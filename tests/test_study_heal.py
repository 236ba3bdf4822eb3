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


def test_what_an_earlier_wheel_rail_model_made_is_made_again_and_said(quick_study, tmp_path, capsys):
    """A study whose curves, rough laws and growths an earlier revision of the wheel-rail model made (recorded
    without its revision, as an older filmcal did): the rerun says so, makes them again under this revision,
    and, the code being the same here, gets the same curves to the last digit."""
    from filmcal.contact.names import APPLICATION_MODEL_REVISION
    from filmcal.study.layout import spec_key

    study, _, _ = quick_study
    copy = tmp_path / "s"
    shutil.copytree(study, copy)
    manifest = json.loads((copy / "study.json").read_text())
    kinds = ("curves", "curves-part", "curves-growth", "rough-law")
    for rel, entry in list(manifest["artefacts"].items()):
        if entry["kind"] in kinds:
            key = spec_key(entry["spec"])
            del entry["spec"]["application_model_revision"]
            if key in rel:  # named by the key of its spec: an earlier revision's has another name
                old = rel.replace(key, spec_key(entry["spec"]))
                (copy / rel).rename(copy / old)
                manifest["artefacts"][old] = manifest["artefacts"].pop(rel)
    (copy / "study.json").write_text(json.dumps(manifest))
    before = _sha(copy / "curves" / "curves-HS.csv")
    laws = {p: p.stat().st_mtime_ns for p in (copy / "roughlaws").glob("*.npz")}
    assert cli.main(["pipeline", "--quick", "--films", "HS", "--study-dir", str(copy), "--no-report"]) == 0
    assert "HS: the curves were made by an earlier revision of the wheel-rail model; made again" in capsys.readouterr().err
    after = json.loads((copy / "study.json").read_text())["artefacts"]
    assert after["curves/curves-HS.csv"]["spec"]["application_model_revision"] == APPLICATION_MODEL_REVISION
    for kind in kinds[1:]:  # made again beside the earlier revision's
        assert any(e["spec"].get("application_model_revision") == APPLICATION_MODEL_REVISION
                   for e in after.values() if e["kind"] == kind), kind
    solved = [rel for rel, e in after.items() if e["kind"] == "rough-law"
              and e["spec"].get("application_model_revision") == APPLICATION_MODEL_REVISION]
    assert solved and not {copy / rel for rel in solved} & set(laws)  # solved again, beside the earlier ones
    assert _sha(copy / "curves" / "curves-HS.csv") == before
