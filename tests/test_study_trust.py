"""`curves`, `report` and `correct` on a tampered, a symlinked and a read-only study: refused, refused, answered.

Each runs as the command line in a subprocess; a refusal is exit 2 with one line on stderr that names
what is wrong, and leaves the study and the folder around it exactly as they were (hash snapshot).
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

FILMCAL = [sys.executable, "-m", "filmcal.cli"]


def _commands(study: Path, out: Path) -> dict[str, list[str]]:
    return {
        "correct": ["correct", "--study-dir", str(study), "--film", "HS", "--force-kn", "100",
                    "--measured-area-mm2", "150", "--offset-mm", "0", "--json"],
        "curves": ["curves", "--study-dir", str(study), "--film", "HS", "--forces-kn", "100", "--offsets-mm", "0",
                   "--json"],
        "report": ["report", "--study-dir", str(study), "--out-dir", str(out / "report")],
    }


def _snapshot(folder: Path) -> dict[str, str]:
    """SHA-256 of every file under `folder` (links not followed), by relative path."""
    out = {}
    for path in sorted(folder.rglob("*")):
        if path.is_symlink():
            out[str(path.relative_to(folder))] = "link:" + os.readlink(path)
        elif path.is_file():
            out[str(path.relative_to(folder))] = hashlib.sha256(path.read_bytes()).hexdigest()
    return out


#: Where mount namespaces are not allowed (a container without CAP_SYS_ADMIN) and the folder's permissions do not
#: bind root: the command runs with the study taken as not writable, as a read-only folder answers.
AS_READ_ONLY = [sys.executable, "-c", "import sys, filmcal._io as io; from filmcal.cli import main; "
                "io._can_create_in = lambda path: False; sys.exit(main(sys.argv[1:]))"]


def _run(args: list[str], cwd: Path, read_only: Path | None = None) -> subprocess.CompletedProcess:
    command = FILMCAL + args
    if read_only is not None and _read_only_mounts():
        # a read-only bind mount of the study in a private mount namespace: read-only even for root
        command = ["unshare", "-m", "sh", "-c", 'mount --bind "$1" "$1" && mount -o remount,bind,ro "$1" && shift '
                   '&& exec "$@"', "sh", str(read_only)] + command
    elif read_only is not None and os.geteuid() == 0:
        command = AS_READ_ONLY + args
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=600)


@functools.lru_cache(maxsize=None)
def _read_only_mounts() -> bool:
    """True where a private mount namespace can mount a folder read-only (root with CAP_SYS_ADMIN)."""
    if shutil.which("unshare") is None:
        return False
    probe = subprocess.run(["unshare", "-m", "sh", "-c", "mount --bind /tmp /tmp && mount -o remount,bind,ro /tmp "
                            "&& ! touch /tmp/.filmcal-ro-probe"], capture_output=True)
    return probe.returncode == 0


@pytest.fixture(scope="module")
def studies(quick_study, tmp_path_factory):
    """Copies of the quick study: intact, one posterior's number changed, one posterior a link out of the study."""
    study, _, _ = quick_study
    root = tmp_path_factory.mktemp("trust")
    intact, tampered, linked, missing = root / "intact", root / "tampered", root / "linked", root / "missing"
    for folder in (intact, tampered, linked, missing):
        shutil.copytree(study, folder)
    # the posteriors the study recorded (other tests may have kept correction caches beside them)
    posteriors = sorted(rel for rel, e in json.loads((study / "study.json").read_text())["artefacts"].items()
                        if e["kind"] == "posterior")
    for path in (tampered / rel for rel in posteriors):  # E times 10 in every posterior
        data = json.loads(path.read_text())
        data["modulus_mpa"]["median"] = 10 * data["modulus_mpa"]["median"]
        path.write_text(json.dumps(data))
    for path in (missing / rel for rel in posteriors):
        path.unlink()
    outside = root / "elsewhere"
    outside.mkdir()
    for path in (linked / rel for rel in posteriors):
        target = outside / path.name
        path.rename(target)
        path.symlink_to(target)
    return root


@pytest.mark.parametrize("command", ["correct", "curves", "report"])
@pytest.mark.parametrize("state, says", [("tampered", "was changed after the study wrote it"),
                                         ("linked", "outside the study folder")])
def test_a_tampered_or_linked_study_is_refused(studies, tmp_path, command, state, says):
    before = _snapshot(studies)
    p = _run(_commands(studies / state, tmp_path)[command], cwd=tmp_path)
    assert p.returncode == 2, p.stderr[-2000:]
    assert len(p.stderr.strip().splitlines()) == 1 and says in p.stderr, p.stderr
    assert p.stdout == ""
    assert _snapshot(studies) == before  # the study and its neighbours unchanged
    assert list(tmp_path.iterdir()) == []  # no report, no partial file


@pytest.mark.parametrize("command", ["correct", "curves"])
def test_a_changed_or_missing_posterior_says_which_command_makes_it_again(studies, tmp_path, command):
    """`correct` and `curves` only read a study: 'delete it and run again' sent a user round in a circle (the
    deleted posterior then read 'No such file or directory; check the name'). Both now name the command that
    computes it again."""
    for state, says in (("tampered", "was changed after the study wrote it"),
                        ("missing", "is recorded in the study but missing")):
        p = _run(_commands(studies / state, tmp_path)[command], cwd=tmp_path)
        assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1, p.stderr[-2000:]
        assert says in p.stderr and f"filmcal pipeline --study-dir {studies / state}" in p.stderr, p.stderr


@pytest.mark.parametrize("command", ["correct", "curves", "report"])
def test_a_read_only_study_is_answered_as_the_writable_one(studies, tmp_path, command):
    study, twin = tmp_path / "ro", tmp_path / "rw"
    shutil.copytree(studies / "intact", study)
    shutil.copytree(studies / "intact", twin)
    (tmp_path / "out").mkdir()
    writable = _run(_commands(twin, tmp_path / "out")[command], cwd=tmp_path / "out")
    assert writable.returncode == 0, writable.stderr[-2000:]
    before = _snapshot(study)
    if not _read_only_mounts() and os.geteuid() != 0:  # an ordinary user: the folder's permissions suffice
        for path in [study, *study.rglob("*")]:
            path.chmod(path.stat().st_mode & ~0o222)
    p = _run(_commands(study, tmp_path / "out")[command], cwd=tmp_path / "out", read_only=study)
    assert p.returncode == 0, p.stderr[-2000:]
    assert _snapshot(study) == before
    if command == "report":
        assert (tmp_path / "out" / "report" / "report.html").is_file()
        assert (tmp_path / "out" / "report" / "report.pdf").is_file()
    else:  # the same numbers as from the writable copy (whose caches its manifest now records)
        answer, expected = json.loads(p.stdout), json.loads(writable.stdout)
        for d in (answer, expected):
            d.pop("provenance", None)
            d["posterior_files"] = [Path(f).name for f in d.get("posterior_files", [])]
        assert answer == expected


def test_a_report_of_a_read_only_study_without_out_dir_is_refused_before_any_figure(studies, tmp_path):
    """It drew for 15 s and then failed on the read-only folder: now one line before any work names --out-dir."""
    study = tmp_path / "ro"
    shutil.copytree(studies / "intact", study)
    shutil.rmtree(study / "report", ignore_errors=True)
    before = _snapshot(study)
    if not _read_only_mounts() and os.geteuid() != 0:
        for path in [study, *study.rglob("*")]:
            path.chmod(path.stat().st_mode & ~0o222)
    p = _run(["report", "--study-dir", str(study)], cwd=tmp_path, read_only=study)
    assert p.returncode == 2, p.stderr[-2000:]
    assert len(p.stderr.strip().splitlines()) == 1 and "--out-dir" in p.stderr, p.stderr
    assert _snapshot(study) == before


def test_a_report_into_the_study_other_than_its_report_folder_is_refused(studies, tmp_path):
    """`report --out-dir STUDY/figs` wrote unrecorded files among the study's own; STUDY/report, the default,
    stays allowed when given."""
    study = studies / "intact"
    before = _snapshot(study)
    p = _run(["report", "--study-dir", str(study), "--out-dir", str(study / "figs")], cwd=tmp_path)
    assert p.returncode == 2 and "lies inside the study folder" in p.stderr, p.stderr[-2000:]
    assert len(p.stderr.strip().splitlines()) == 1 and _snapshot(study) == before


def test_a_kept_cache_is_adopted_as_an_artefact_only_when_it_is_the_file_the_study_wrote(tmp_path):
    """`filmcal correct` keeps its rough laws under the manifest's caches; the pipeline takes such a law over as
    its artefact (the entry moves, the file stays) instead of solving it again, but not one of another spec
    and not one changed since it was written."""
    from filmcal._errors import InputError
    from filmcal.study import Study
    from filmcal.study.core import _write_cache

    study = Study(tmp_path / "study", create=True)
    spec = {"kind": "rough-law", "film": None, "modulus_mpa": None}
    path = study.layout.rough_law("k1")
    _write_cache(study, path, spec, {"law": 1}, "a test")
    with study.writing("a test"):
        assert study.adopt(path, "rough-law", {**spec, "modulus_mpa": 1.0}) is None  # another spec
        assert study.adopt(path, "rough-law", spec) == path
        assert study.verified(path, kind="rough-law", spec=spec) == path
        assert study.layout.relative(path) not in study.manifest.data.get("caches", {})
        assert study.adopt(path, "rough-law", spec) is None  # an artefact already
    changed = study.layout.rough_law("k2")
    _write_cache(study, changed, spec, {"law": 2}, "a test")
    changed.write_text('{"law": 3}')
    with study.writing("a test"), pytest.raises(InputError, match="changed after the study wrote it"):
        study.adopt(changed, "rough-law", spec)
    # the pipeline does not stop there: a changed kept law, or a file recorded nowhere (a write interrupted
    # before its record), is not held, and is solved again
    from filmcal.study.core import StudyRoughLaws

    stray = study.layout.rough_law("k3")
    stray.write_text("half a law")
    with study.writing("a test"):
        store = StudyRoughLaws(study)
        assert not store.held(changed, spec) and not store.held(stray, spec)
        assert study.layout.relative(changed) not in study.manifest.data["caches"]
        assert store.held(path, spec)  # the adopted one
