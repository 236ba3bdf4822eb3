"""`filmcal correct --batch`: every row corrected as the single command would, bad rows marked, exit codes."""
from __future__ import annotations

import csv
import json
import subprocess
import sys


def test_a_batch_equals_single_corrections_and_marks_its_bad_rows(quick_study, tmp_path):
    study, _, _ = quick_study
    src, out = tmp_path / "day.csv", tmp_path / "out.csv"
    src.write_text("# a day's imprints\nfilm,force_kn,measured_area_mm2,offset_mm,measured_radius_mm,sphere_radius_mm\n"
                   "HS,100,150,-3,,\nHS,50,,,7.1,450\nHS,abc,150,-3,,\nHS,100,1e9,-3,,\nHS,100,150,,,\n")
    cli = [sys.executable, "-m", "filmcal.cli", "correct", "--study-dir", str(study)]
    p = subprocess.run(cli + ["--batch", str(src), "--out", str(out), "--progress", "quiet"], capture_output=True,
                       text=True)
    assert p.returncode == 1, p.stderr
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["status"].split(":")[0] for r in rows] == ["ok", "ok", "failed", "failed", "failed"]
    assert "not a number" in rows[2]["status"] and "implausible" in rows[3]["status"]
    singles = [cli + ["--film", "HS", "--force-kn", "100", "--measured-area-mm2", "150", "--offset-mm=-3", "--json"],
               cli + ["--film", "HS", "--force-kn", "50", "--measured-radius-mm", "7.1", "--sphere-radius-mm", "450",
                      "--json"]]
    for row, args in zip(rows, singles):
        single = json.loads(subprocess.run(args, capture_output=True, text=True, check=True).stdout)
        assert float(row["area_mm2"]) == single["area_mm2"]
        assert [float(row["area_ci90_low_mm2"]), float(row["area_ci90_high_mm2"])] == single["area_ci90_mm2"]
    provenance = json.loads((tmp_path / "out.csv.provenance.json").read_text())
    assert provenance["failed"] == 3 and provenance["posteriors"]["HS"]
    (tmp_path / "bad.csv").write_text("name,value\nx,1\n")
    bad = subprocess.run(cli + ["--batch", str(tmp_path / "bad.csv"), "--out", str(out)], capture_output=True,
                         text=True)
    assert bad.returncode == 2 and "needs columns film and force_kn" in bad.stderr
    mixed = subprocess.run(cli + ["--batch", str(src), "--out", str(out), "--film", "HS"], capture_output=True,
                           text=True)
    assert mixed.returncode == 2 and "--batch takes the measurements from its rows" in mixed.stderr
