"""The pipeline end to end (quick version, one film): results on disk, resumed without recomputing."""
from __future__ import annotations

import csv
import json
import subprocess
import sys


def test_quick_pipeline_runs_and_resumes(tmp_path):
    cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", "HS", "--workers", "2",
           "--study-dir", str(tmp_path), "--json"]
    first = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    summary = json.loads(first.stdout)
    hs = summary["films"]["HS"]
    assert 1500 < hs["modulus_mpa"]["median"] < 5000  # HS near the paper's 2800 MPa
    assert hs["modulus_mpa"]["ci90"][0] < hs["modulus_mpa"]["median"] < hs["modulus_mpa"]["ci90"][1]
    with open(hs["curves_file"]) as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 3  # three offsets at 50 kN
    for row in rows:  # the film enlarges the patch, the band contains its median
        assert float(row["delta_area_lo_mm2"]) <= float(row["delta_area_median_mm2"]) <= float(row["delta_area_hi_mm2"])
        assert 0 < float(row["ratio_median"]) < 1
    assert (tmp_path / "summary.json").exists()

    second = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert second.returncode == 0, second.stderr[-2000:]
    again = json.loads(second.stdout)
    assert again["films"]["HS"]["modulus_mpa"] == hs["modulus_mpa"]
    assert again["elapsed_s"] < summary["elapsed_s"]


def test_bad_film_exits_2(tmp_path):
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "pipeline", "--films", "XX", "--study-dir",
                        str(tmp_path)], capture_output=True, text=True)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1
