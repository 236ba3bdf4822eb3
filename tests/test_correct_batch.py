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


def test_malformed_batches_are_refused_whole_and_a_byte_order_mark_is_read(quick_study, tmp_path):
    """A row longer than the header (a decimal comma) ended in AttributeError (exit 70); a repeated column
    was corrected silently with its last value (force_kn 100 then 50: corrected at 50 kN, the 100 lost); a
    spreadsheet's byte-order mark made 'film' unknown."""
    study, _, _ = quick_study
    cli = [sys.executable, "-m", "filmcal.cli", "correct", "--study-dir", str(study), "--progress", "quiet"]
    out = tmp_path / "out.csv"
    for name, text, words in (
            ("comma.csv", "film,force_kn,measured_area_mm2,offset_mm\nHS,100,150,5,-3\n",
             "line 2: 5 cells for 4 columns (a decimal comma?"),
            ("twice.csv", "film,force_kn,force_kn,measured_area_mm2,offset_mm\nHS,100,50,150,-3\n",
             "column(s) force_kn appear more than once")):
        (tmp_path / name).write_text(text)
        p = subprocess.run(cli + ["--batch", str(tmp_path / name), "--out", str(out)], capture_output=True, text=True)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and words in p.stderr, p.stderr
        assert not out.exists()
    plain, marked = tmp_path / "plain.csv", tmp_path / "marked.csv"
    plain.write_text("film,force_kn,measured_area_mm2,offset_mm\nHS,100,150,-3\n")
    marked.write_bytes(b"\xef\xbb\xbf" + plain.read_bytes().replace(b"\n", b"\r\n"))
    answers = []
    for src in (plain, marked):
        p = subprocess.run(cli + ["--batch", str(src), "--out", str(out), "--json"], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        assert json.loads(p.stdout) == {"out": str(out), "provenance": f"{out}.provenance.json", "rows": 1,
                                        "corrected": 1, "failed": 0}
        with open(out, newline="") as fh:
            answers.append(list(csv.DictReader(fh))[0]["area_mm2"])
    assert answers[0] == answers[1]


def test_a_repeated_measurement_is_answered_once_and_alike(quick_study, tmp_path):
    """10 000 rows of one case ran at 40 rows a second; identical rows now share one answer, which is the
    single row's to the digit, and a different row between them keeps its own."""
    study, _, _ = quick_study
    src, out = tmp_path / "day.csv", tmp_path / "out.csv"
    src.write_text("film,force_kn,measured_area_mm2,offset_mm\n" + "HS,100,150,-3\n" * 5000 + "HS,100,140,-3\n"
                   + "HS,100,150,-3\n" * 4999)
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--study-dir", str(study), "--batch", str(src),
                        "--out", str(out), "--progress", "quiet"], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 10_000 and rows[5000]["measured_area_mm2"] == "140"
    assert len({r["area_mm2"] for r in rows}) == 2 and rows[5000]["area_mm2"] != rows[0]["area_mm2"]
    one = tmp_path / "one.csv"
    one.write_text("film,force_kn,measured_area_mm2,offset_mm\nHS,100,150,-3\n")
    subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--study-dir", str(study), "--batch", str(one),
                    "--out", str(tmp_path / "one_out.csv"), "--progress", "quiet"], check=True, capture_output=True)
    with open(tmp_path / "one_out.csv", newline="") as fh:
        assert list(csv.DictReader(fh))[0]["area_mm2"] == rows[-1]["area_mm2"]


def test_a_batch_cell_written_with_an_underscore_or_a_full_width_digit_is_not_a_number():
    """Python's float reads 1_0 as 10 and a full-width 1 as 1; a batch row with either is not corrected."""
    import pytest

    from filmcal.study.batch import _number

    assert _number({"force_kn": " 100 "}, "force_kn") == 100.0
    for text in ("1_00", "\uff11\uff10\uff10"):
        with pytest.raises(ValueError, match="not a number"):
            _number({"force_kn": text}, "force_kn")


def test_a_batch_with_the_old_std_column_is_read_with_one_note_and_the_new_name(tmp_path):
    """DESIGN.md names the column measured_area_std_mm2 (as `filmcal scan` writes it); the old
    measurement_std_mm2 is read for one release, with a FutureWarning naming the new one."""
    import warnings

    import pytest

    from filmcal.study.batch import read_batch

    old = tmp_path / "old.csv"
    old.write_text("film,force_kn,measured_area_mm2,offset_mm,measurement_std_mm2\nHS,100,150,-3,2\n")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        header, rows = read_batch(old)
    assert [str(w.message) for w in caught if w.category is FutureWarning][0].count("measured_area_std_mm2") == 1
    assert "measured_area_std_mm2" in header and "measurement_std_mm2" not in header
    assert rows[0]["measured_area_std_mm2"] == "2"
    both = tmp_path / "both.csv"
    both.write_text("film,force_kn,measured_area_mm2,offset_mm,measurement_std_mm2,measured_area_std_mm2\n"
                    "HS,100,150,-3,2,2\n")
    with pytest.raises(ValueError, match="measurement_std_mm2"):
        read_batch(both)


def test_the_old_std_option_sets_the_new_one_with_one_note():
    out = subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--measured-area-mm2", "150",
                          "--offset-mm=-3", "--force-kn", "100", "--measurement-std-mm2", "-1",
                          "--study-dir", "no-such-study"], capture_output=True, text=True)
    lines = out.stderr.strip().splitlines()
    assert out.returncode == 2
    assert "--measurement-std-mm2 is renamed --measured-area-std-mm2" in lines[0]
    assert "measured_area_std_mm2" in lines[-1] or "measured-area-std-mm2" in lines[-1], lines


def test_an_interrupted_batch_writes_the_rows_it_corrected_and_marks_the_others(quick_study, tmp_path, monkeypatch,
                                                                               capsys):
    """Ctrl-C in the third of four distinct rows wrote nothing: an hour of rough rows was lost with the table.
    Now --out holds the rows corrected (as an uninterrupted batch gives them), the others with empty numbers
    and their status saying why, the provenance says how many were not reached, and the exit is 130."""
    import shutil

    import filmcal.study.correct as correct_module
    from filmcal.cli import main

    study = tmp_path / "study"
    shutil.copytree(quick_study[0], study)
    src, out, whole = tmp_path / "day.csv", tmp_path / "out.csv", tmp_path / "whole.csv"
    src.write_text("film,force_kn,measured_area_mm2,offset_mm\nHS,100,150,-3\nHS,100,140,-3\nHS,100,150,0\n"
                   "HS,100,130,-3\n")
    args = ["correct", "--study-dir", str(study), "--batch", str(src), "--progress", "quiet"]
    assert main(args + ["--out", str(whole)]) == 0
    real, calls = correct_module.correct_measurement, []

    def interrupted_at_the_third(*a, **k):
        calls.append(1)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(correct_module, "correct_measurement", interrupted_at_the_third)
    capsys.readouterr()
    assert main(args + ["--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "interrupted after 2 of 4 rows" in err and "the same command run again finishes it" in err
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    with open(whole, newline="") as fh:
        expected = list(csv.DictReader(fh))
    assert rows[:2] == expected[:2] and [r["status"] for r in rows] == ["ok", "ok"] + 2 * ["not corrected: interrupted"]
    assert all(r["area_mm2"] == "" and r["measured_area_mm2"] for r in rows[2:])
    provenance = json.loads((tmp_path / "out.csv.provenance.json").read_text())
    assert provenance["not_reached"] == 2 and provenance["failed"] == 0 and provenance["rows"] == 4
    def interrupted_at_once(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(correct_module, "correct_measurement", interrupted_at_once)
    before = out.read_bytes()
    capsys.readouterr()
    assert main(args + ["--out", str(out)]) == 130  # interrupted at its first row: the earlier table is kept
    assert "before any row was corrected" in capsys.readouterr().err and out.read_bytes() == before
    monkeypatch.setattr(correct_module, "correct_measurement", real)
    assert main(args + ["--out", str(out)]) == 0  # run again: the whole table
    with open(out, newline="") as fh:
        assert list(csv.DictReader(fh)) == expected


def test_a_study_of_other_versions_is_said_once_after_the_answer_and_never_beside_a_refusal(quick_study, tmp_path):
    """Reading a study made under other package versions says so in one note, once however often the command
    opens the study, after its answer; a refused command says its one error line only."""
    import shutil

    study, _, _ = quick_study
    copy = tmp_path / "study"
    shutil.copytree(study, copy)
    manifest = json.loads((copy / "study.json").read_text())
    manifest["software"]["numpy"] = "0.1"
    (copy / "study.json").write_text(json.dumps(manifest))
    cli = [sys.executable, "-m", "filmcal.cli", "correct", "--study-dir", str(copy), "--force-kn", "50",
           "--measured-radius-mm", "7.1", "--sphere-radius-mm", "450"]
    p = subprocess.run(cli + ["--film", "HS"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    notes = [line for line in p.stderr.splitlines() if ": note: " in line]
    assert len(notes) == 1 and "numpy 0.1" in notes[0], p.stderr
    refused = subprocess.run(cli + ["--film", "XX"], capture_output=True, text=True, timeout=300)
    assert refused.returncode == 2 and len(refused.stderr.strip().splitlines()) == 1, refused.stderr
    assert "unknown film 'XX'" in refused.stderr
