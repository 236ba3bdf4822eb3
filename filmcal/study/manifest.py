"""The study's manifest and its writer lock.

The manifest (``study.json``) records the study's settings and, for every
artefact, what it was made from (its spec), when, and its SHA-256, so that a
file changed after it was written is refused rather than used. The lock is an
OS file lock on ``.lock``: one process writes a study at a time; a second is
refused at once with a message saying who holds it.
"""
from __future__ import annotations

import datetime as _dt
import fcntl
import os
import socket
import sys
import time
from pathlib import Path
from typing import Any

from filmcal._errors import DamagedFileError, InputError, UntrustedArtefactError
from filmcal._io import atomic_write_text, read_json, sha256_file
from filmcal._versions import software_versions

__all__ = ["Manifest", "StudyLock", "FORMAT", "utc_now", "remake_hint"]

FORMAT = "filmcal-study/1"

#: What to do with a damaged manifest: it is the study's record of every result and cannot be recomputed, so
#: it is never to be deleted (a study folder without it is refused as not a study).
DAMAGED_ADVICE = ("this is the study's manifest, its record of every result, and it cannot be recomputed: "
                  "restore it from a backup, or use a new --study-dir")


def utc_now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")


class Manifest:
    """The manifest of one study folder (read on open, written whole, atomically)."""

    def __init__(self, path: Path, data: dict[str, Any]) -> None:
        self.path = Path(path)
        self.data = data

    @classmethod
    def new(cls, path: Path) -> "Manifest":
        return cls(path, {"format": FORMAT, "created_utc": utc_now(), "software": software_versions(),
                          "films": {}, "artefacts": {}, "stages": {}, "settings": None})

    @classmethod
    def read(cls, path: Path) -> "Manifest":
        """Read a study's manifest.

        Raises
        ------
        filmcal._errors.DamagedFileError
            If it cannot be decoded, with advice that keeps the study (`DAMAGED_ADVICE`).
        filmcal._errors.InputError
            If it is JSON but not a study manifest of this format.
        """
        try:
            data = read_json(path)
        except DamagedFileError as exc:
            raise DamagedFileError(path, exc.reason, advice=DAMAGED_ADVICE) from exc
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise InputError(f"{path} is not a filmcal study manifest (format {FORMAT!r} expected)")
        for key in ("films", "artefacts", "stages"):
            data.setdefault(key, {})
        return cls(path, data)

    def note_writer_software(self) -> None:
        """Keep the versions of a writer that differ from the study's own (``software_later``)."""
        now = software_versions()
        if self.data.get("software") is None:
            self.data.setdefault("software_later", [])
        elif self.data["software"] == now:
            return
        later = self.data.setdefault("software_later", [])
        if all(entry.get("software") != now for entry in later):
            later.append({"software": now, "first_written_utc": utc_now()})

    def write(self) -> None:
        """Save the manifest; unchanged content leaves the file untouched (a refused or idle writer changes
        nothing on disk)."""
        import json

        from filmcal._json import json_safe

        text = json.dumps(json_safe(self.data), indent=1, allow_nan=False) + "\n"
        try:
            if self.path.read_text(encoding="utf-8") == text:
                return
        except (OSError, UnicodeDecodeError):
            pass
        atomic_write_text(self.path, text)  # the text compared: serialised once

    # ------------------------------------------------------------ artefacts
    def record(self, relpath: str, file: Path, kind: str, spec: dict, **extra: Any) -> None:
        """Record an artefact just written (its spec and SHA-256)."""
        self.data["artefacts"][relpath] = {"kind": kind, "spec": spec, "sha256": sha256_file(file),
                                           "written_utc": utc_now(), **extra}

    def entry(self, relpath: str) -> dict | None:
        return self.data["artefacts"].get(relpath)

    def forget(self, relpath: str) -> None:
        self.data["artefacts"].pop(relpath, None)

    def verify(self, relpath: str, file: Path, kind: str | None = None, spec: dict | None = None) -> dict:
        """Refuse a file that is not the one the study wrote; return its manifest entry.

        Parameters
        ----------
        relpath : str
            The file's path in the study, as recorded.
        file : Path
            The file.
        kind, spec : optional
            The kind (``"posterior"``, ``"radius-surrogate"`` ...) and spec the
            reader expects; a recorded entry of another kind or spec is refused.

        Raises
        ------
        filmcal._errors.UntrustedArtefactError
            Unrecorded, changed since it was written (SHA-256), or of another
            kind or spec than expected.
        """
        entry = self.entry(relpath)
        again = remake_hint(self.path.parent, None if entry is None else entry.get("kind"))
        if entry is None:
            raise UntrustedArtefactError(f"{file}: not recorded in the study's manifest {self.path.name}; "
                                         f"delete it and {again}")
        if kind is not None and entry.get("kind") != kind:
            raise UntrustedArtefactError(f"{file} is recorded as a {entry.get('kind')!r}, not the {kind!r} "
                                         f"read here; delete it and {again}")
        if spec is not None and entry.get("spec") != spec:
            raise UntrustedArtefactError(f"{file} was made with other settings than its manifest entry says "
                                         f"are read here; delete it and {again}")
        if not Path(file).is_file():
            raise UntrustedArtefactError(f"{file} is recorded in the study but missing; {again}")
        if sha256_file(file) != entry["sha256"]:
            raise UntrustedArtefactError(f"{file} was changed after the study wrote it (SHA-256 differs from the "
                                         f"manifest); delete it and {again}")
        return entry

    def artefacts(self, kind: str) -> dict[str, dict]:
        return {k: v for k, v in self.data["artefacts"].items() if v["kind"] == kind}


#: How long a run waits for a brief holder of a study's writer lock (a command keeping a cache) before it is
#: refused, in seconds.
BRIEF_WAIT_S = 60.0


class StudyLock:
    """An exclusive OS lock on a study's ``.lock`` file, held for a whole run, or for a moment to keep a cache
    (``brief``).

    The lock file names its holder on its first line; a second line ``brief`` marks a moment's hold, which a
    run waits for (up to `BRIEF_WAIT_S`) instead of being refused, and another brief writer does not (it keeps
    nothing, as when the study is read-only).
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self._fh = None

    def acquire(self, what: str = "", *, brief: bool = False) -> None:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fh = open(self.path, "a+", encoding="utf-8")
        deadline = None
        while True:
            try:
                fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                fh.seek(0)
                lines = fh.read().splitlines()
                deadline = time.monotonic() + BRIEF_WAIT_S if deadline is None else deadline
                # an empty file: a holder between taking the lock and naming itself, or releasing it
                unnamed = not lines
                if brief or not (unnamed or lines[1:2] == ["brief"]) or time.monotonic() > deadline:
                    fh.close()
                    holder = (lines[0].strip() if lines else "") or "another process"
                    raise InputError(f"study {self.path.parent} is being written by {holder}; wait for it to "
                                     "finish or use another --study-dir") from None
                time.sleep(0.05)
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()} on {socket.gethostname()} since {utc_now()}"
                 f" ({what or ' '.join(sys.argv[:3])})" + ("\nbrief" if brief else ""))
        fh.flush()
        self._fh = fh

    def release(self) -> None:
        if self._fh is not None:
            self._fh.seek(0)
            self._fh.truncate()
            fcntl.flock(self._fh.fileno(), fcntl.LOCK_UN)
            self._fh.close()
            self._fh = None

    @property
    def held(self) -> bool:
        return self._fh is not None


def remake_hint(root: Path, kind: str | None) -> str:
    """How to make a study's artefact of `kind` again (`correct`, `curves` and `report` only read a study's
    results)."""
    where = f"--study-dir {root}"
    if kind == "report":
        return f"run `filmcal report {where}` to write it again"
    if kind in ("curves", "curves-part", "curves-growth", "rough-law"):
        return f"run `filmcal pipeline {where}` (or the `filmcal curves` that made it) to compute it again"
    if kind in ("posterior", "radius-surrogate", "chain", "comparison"):
        return f"run `filmcal pipeline {where}` (or the `filmcal calibrate` that made it) to compute it again"
    return f"run `filmcal pipeline {where}` to compute it again"
