"""The layout of a study folder: the one place that knows its file names.

A study folder holds::

    study.json                 the manifest: settings, dataset, films, and what every artefact was made from
    .lock                      held by the one process that writes the folder
    runs/runs-<key>.sqlite     FE campaign stores (one per FE options and film set), when the study keeps its
                               own (FILMCAL_RUN_STORE=study, or made so before); else in its shared run store
    surrogates/<key>.npz|json  radius surrogates
    surrogates/<key>-validation.json
    chains/<key>.h5            emcee chains
    posteriors/<key>.json      posteriors (samples, pointwise log-likelihood, summary)
    comparison-<film>.json     imprint-model comparison and combination of a film
    design.json  fe-verification.json  wheelrail-outlines.json
    curves/curves-<film>.csv  (curves/part-<key>.json: one wheel's rows, kept as soon as they are done)
    crossval/crossval-<film>.json
    summary.json               the last pipeline run's summary
    report/report.html|pdf

``<key>`` is the first 12 hexadecimal digits of the SHA-256 of the canonical
JSON of what made the artefact (its *spec*): an artefact made with other
settings has another key and is computed beside the old one, never mistaken
for it. The manifest maps each file to its spec and its own SHA-256.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

from filmcal._errors import UntrustedArtefactError
from filmcal._io import json_hash

__all__ = ["StudyLayout", "spec_key", "MANIFEST_NAME", "check_outside_study"]

MANIFEST_NAME = "study.json"


def spec_key(spec: dict[str, Any]) -> str:
    """The 12-hex-digit key of a spec (`filmcal._io.json_hash`, the package's one settings hash)."""
    return json_hash(spec, digits=12)


def check_outside_study(path: str | Path, option: str, study_dir: str | Path) -> None:
    """Refuse a user's output file inside a study folder (filmcal writes that folder, and records every file
    it keeps there: a file of the user's would be taken over or would overwrite one of the study's).

    Raises
    ------
    filmcal._errors.InputError
        Naming the option, the file and the study.
    """
    from filmcal._errors import InputError

    target, root = Path(path).resolve(), Path(study_dir).resolve()
    if target == root or root in target.parents:
        raise InputError(f"{option} {str(path)!r} lies inside the study folder {str(study_dir)!r}, which filmcal "
                         "writes and records: give a file outside it (nothing was written)")


class StudyLayout:
    """File names inside one study folder."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    @property
    def manifest(self) -> Path:
        return self.root / MANIFEST_NAME

    @property
    def lock(self) -> Path:
        return self.root / ".lock"

    def runs_store(self, key: str) -> Path:
        return self.root / "runs" / f"runs-{key}.sqlite"

    def surrogate(self, key: str) -> Path:
        """Stem of a surrogate's ``.npz``/``.json`` pair."""
        return self.root / "surrogates" / key

    def surrogate_validation(self, key: str) -> Path:
        return self.root / "surrogates" / f"{key}-validation.json"

    def chain(self, key: str) -> Path:
        return self.root / "chains" / f"{key}.h5"

    def posterior(self, key: str) -> Path:
        return self.root / "posteriors" / f"{key}.json"

    def comparison(self, film: str) -> Path:
        return self.root / f"comparison-{film}.json"

    @property
    def design(self) -> Path:
        return self.root / "design.json"

    @property
    def verification(self) -> Path:
        return self.root / "fe-verification.json"

    @property
    def outlines(self) -> Path:
        return self.root / "wheelrail-outlines.json"

    def curves(self, film: str) -> Path:
        return self.root / "curves" / f"curves-{film}.csv"

    @property
    def roughness_inputs(self) -> Path:
        """The roughness inputs conditioned again on the study's own roughened-flat data (when it has some)."""
        return self.root / "roughness-inputs.json"

    def rough_law(self, key: str) -> Path:
        """A rough body's boundary-element law against a film at one modulus (`filmcal.contact.rough_law_file`)."""
        return self.root / "roughlaws" / f"{key}.npz"

    def curves_part(self, key: str) -> Path:
        """One film and wheel's finished curve rows, kept until the film's CSV is complete."""
        return self.root / "curves" / f"part-{key}.json"

    def crossval(self, film: str) -> Path:
        return self.root / "crossval" / f"crossval-{film}.json"

    @property
    def summary(self) -> Path:
        return self.root / "summary.json"

    @property
    def report_dir(self) -> Path:
        return self.root / "report"

    def relative(self, path: Path) -> str:
        """`path` relative to the study folder, as recorded in the manifest.

        Raises
        ------
        filmcal._errors.UntrustedArtefactError
            If `path`, its links resolved, lies outside the study folder (a
            study reads and writes only its own files).
        """
        resolved, root = Path(path).resolve(), self.root.resolve()
        if not resolved.is_relative_to(root):
            raise UntrustedArtefactError(f"{path} leads to {resolved}, outside the study folder {root}: a study "
                                         "reads and writes only its own files; put the file itself in its place")
        return resolved.relative_to(root).as_posix()
