"""The README's first command, whole, at its smallest size: in the fast tier, so that the fast tier fails
wherever the main job would (another Python, other releases of numpy, scipy, scikit-learn or ArviZ)."""
from __future__ import annotations

import json

from filmcal import cli
from filmcal._versions import software_versions


def test_first_command_runs_every_stage_at_smoke_size(tmp_path, capsys):
    study = tmp_path / "study"
    status = cli.main(["pipeline", "--smoke", "--films", "HS", "--study-dir", str(study), "--workers", "2",
                       "--progress", "quiet", "--json"])
    out, err = capsys.readouterr()
    assert status == 0, err[-3000:]
    summary = json.loads(out)
    # every stage of the job ran: design, FE runs + surrogate + calibration, comparison, verification,
    # curves, outlines, cross-validation (none at this size) and the report
    for stage in ("design", "calibration", "comparison", "verification", "curves", "outlines", "crossval",
                  "report"):
        assert stage in summary["stages_s"], stage
    hs = summary["films"]["HS"]
    # the paper matched HS with E = 2800 MPa (section 2.2): even 20 FE runs and short chains land within a
    # factor of two of it, whichever imprint model the comparison prefers
    assert 1400 < hs["modulus_mpa"]["median"] < 5600
    assert hs["modulus_mpa"]["ci90"][0] < hs["modulus_mpa"]["median"] < hs["modulus_mpa"]["ci90"][1]
    assert set(hs["imprint_weights"]) == {"edge/small", "activation/small"}
    # the answer to cite is the weighted mixture (as `filmcal calibrate` gives it), the preferred model beside it
    assert hs["model"] == "mixture" and hs["preferred_model"]["model"] in hs["imprint_weights"]
    assert abs(sum(hs["imprint_weights"].values()) - 1) < 1e-9
    assert (study / "curves" / "curves-HS.csv").is_file()
    assert (study / "report" / "report.html").stat().st_size > 10_000
    # the study records the versions that made its numbers
    assert json.loads((study / "study.json").read_text())["software"] == software_versions()

    # a study read under other versions says so in one line, and answers as before
    args = ["correct", "--film", "HS", "--sphere-radius-mm", "450", "--force-kn", "75", "--measured-radius-mm",
            "7.12", "--study-dir", str(study), "--json"]
    assert cli.main(args) == 0
    before, err = capsys.readouterr()
    assert "note" not in err
    manifest = json.loads((study / "study.json").read_text())
    manifest["software"]["numpy"] = "1.26.0"
    (study / "study.json").write_text(json.dumps(manifest))
    assert cli.main(args) == 0
    after, err = capsys.readouterr()
    notes = [line for line in err.splitlines() if "note:" in line]
    assert len(notes) == 1 and "numpy 1.26.0 (now " in notes[0], err
    after, before = json.loads(after), json.loads(before)
    # the manifest's record changed, so its hash in the provenance did; the answer did not
    assert after["provenance"].pop("manifest_sha256") != before["provenance"].pop("manifest_sha256")
    assert after == before
