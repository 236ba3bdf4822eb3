"""A day's imprints corrected in one process: ``filmcal correct --batch IN.csv --out OUT.csv``.

One row per measurement, in the vocabulary's names: ``film``, ``force_kn`` and either ``measured_area_mm2``,
``offset_mm`` (wheel-rail) or ``measured_radius_mm``, ``sphere_radius_mm`` (sphere-on-flat); optional
``measured_area_std_mm2`` / ``measurement_std_mm``, ``offset_std_mm``, ``wheel_roughness_ra_um``,
``rail_roughness_ra_um``; the table `filmcal scan` writes is one as it stands (its other columns,
`PASSED_COLUMNS`, are kept). Every row meets the same rules as `filmcal correct` (it is corrected by
`correct_measurement`, with the correctors read once and their solves shared): a good row's answer is the
single command's to the digit, a bad row is kept with its reason in ``status``. The output repeats the input
columns and adds `OUTPUT_COLUMNS`; a sidecar ``OUT.csv.provenance.json`` says where the answers came from.
"""
from __future__ import annotations

import csv
import math
import warnings
from pathlib import Path
from typing import Any

from filmcal._validation import plain_float

__all__ = ["INPUT_COLUMNS", "PASSED_COLUMNS", "OUTPUT_COLUMNS", "INTERRUPTED_STATUS", "BatchInterrupted", "correct_batch",
           "read_batch"]

#: The columns a batch row may have (film and force_kn always).
INPUT_COLUMNS = ("film", "force_kn", "measured_area_mm2", "offset_mm", "measured_radius_mm", "sphere_radius_mm",
                 "measured_area_std_mm2", "measurement_std_mm", "offset_std_mm", "wheel_roughness_ra_um",
                 "rail_roughness_ra_um")
#: Columns a batch keeps as they are without reading them: those `filmcal scan` writes beside the measurement
#: (which imprint of which sheet, where, its halo), so its table is a batch as it stands.
PASSED_COLUMNS = ("imprint", "scan", "region_px", "x_mm", "y_mm", "equivalent_radius_mm", "halo_area_mm2",
                  "halo_coverage", "scan_status")
#: What a batch adds to each row.
OUTPUT_COLUMNS = ("area_mm2", "area_std_mm2", "area_ci90_low_mm2", "area_ci90_high_mm2", "status")
#: Old column names read for one release (each with one line naming the new one).
RENAMED_COLUMNS = {"measurement_std_mm2": "measured_area_std_mm2"}
#: The most rows one batch takes.
MAX_ROWS = 100_000


#: The status of the rows a batch did not reach before it was interrupted.
INTERRUPTED_STATUS = "not corrected: interrupted"


class BatchInterrupted(KeyboardInterrupt):
    """Ctrl-C during `correct_batch`: the rows and provenance as far as it got, the rows it did not reach
    with empty numbers and the status `INTERRUPTED_STATUS`, so that what was corrected can be written.

    A `KeyboardInterrupt`: a caller that does not look for it is interrupted as by any Ctrl-C.
    """

    def __init__(self, rows: list[dict[str, Any]], provenance: dict[str, Any]) -> None:
        super().__init__(f"interrupted after {provenance['rows'] - provenance['not_reached']} of "
                         f"{provenance['rows']} rows")
        self.rows = rows
        self.provenance = provenance


def read_batch(path: str | Path) -> tuple[list[str], list[dict[str, str]]]:
    """The header and rows of a batch file; a file that cannot be read as one raises `ValueError`."""
    path = Path(path)
    try:
        # utf-8-sig: a spreadsheet's byte-order mark is not part of the first column's name
        with open(path, newline="", encoding="utf-8-sig") as fh:
            reader = csv.DictReader(line for line in fh if not line.lstrip().startswith("#"))
            header = [h.strip() for h in (reader.fieldnames or [])]
            repeated = sorted({h for h in header if header.count(h) > 1})
            if repeated:
                raise ValueError(f"batch {path}: column(s) {', '.join(repeated)} appear more than once")
            for old, new in RENAMED_COLUMNS.items():
                if old in header and new not in header:
                    warnings.warn(FutureWarning(f"batch {path}: column {old} is renamed {new}; the old name goes "
                                                "in the next release"), stacklevel=2)
                    header[header.index(old)] = new
            reader.fieldnames = header
            rows = []
            for row in reader:
                if None in row:  # DictReader's key for the cells beyond the header
                    raise ValueError(f"batch {path}, line {reader.line_num}: {len(header) + len(row[None])} cells "
                                     f"for {len(header)} columns (a decimal comma? write 1.5, not 1,5)")
                rows.append({k: (v or "").strip() for k, v in row.items()})
                if len(rows) > MAX_ROWS:
                    raise ValueError(f"batch {path}: more than {MAX_ROWS} rows; split it")
    except FileNotFoundError:
        raise ValueError(f"batch {path}: not found") from None
    except (UnicodeDecodeError, IsADirectoryError, csv.Error) as exc:
        raise ValueError(f"batch {path}: not a CSV text file ({exc})") from None
    unknown = [h for h in header if h not in INPUT_COLUMNS and h not in PASSED_COLUMNS]
    if unknown or "film" not in header or "force_kn" not in header:
        raise ValueError(f"batch {path}: needs columns film and force_kn and takes only {', '.join(INPUT_COLUMNS)} "
                         f"(and {', '.join(PASSED_COLUMNS)}, kept as they are); found {', '.join(header) or 'no header'}")
    if not rows:
        raise ValueError(f"batch {path}: no rows")
    return header, rows


def _number(row: dict, name: str, default: float | None = None) -> float | None:
    text = row.get(name, "")
    if text == "":
        return default
    try:
        value = plain_float(text.strip())
    except ValueError:
        raise ValueError(f"{name} {text!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {text}")
    return value


def _measurement(row: dict):
    from filmcal.study.correct import BodyRoughness, SphereMeasurement, WheelRailMeasurement

    status = row.get("scan_status", "")
    if status not in ("", "ok"):  # `filmcal scan` read this imprint but says why its area is not the imprint's
        raise ValueError(f"the scan says the imprint {status}; its area is not the whole imprint's")

    force = _number(row, "force_kn")
    if force is None:
        raise ValueError("force_kn is empty")
    area, offset = _number(row, "measured_area_mm2"), _number(row, "offset_mm")
    radius, sphere = _number(row, "measured_radius_mm"), _number(row, "sphere_radius_mm")
    if (area is not None or offset is not None) == (radius is not None or sphere is not None):
        raise ValueError("give either measured_area_mm2 with offset_mm (wheel-rail) or measured_radius_mm with "
                         "sphere_radius_mm (sphere-on-flat)")
    wheel_ra, rail_ra = _number(row, "wheel_roughness_ra_um"), _number(row, "rail_roughness_ra_um")
    if radius is not None or sphere is not None:
        if radius is None or sphere is None:
            raise ValueError("sphere-on-flat needs measured_radius_mm and sphere_radius_mm")
        if wheel_ra or rail_ra or _number(row, "offset_std_mm"):
            raise ValueError("roughness and offset_std_mm apply to wheel-rail rows")
        return SphereMeasurement(radius, sphere, force, _number(row, "measurement_std_mm", 0.0)), None
    if area is None or offset is None:
        raise ValueError("wheel-rail needs measured_area_mm2 and offset_mm")
    measurement = WheelRailMeasurement(area, offset, force, _number(row, "measured_area_std_mm2", 0.0),
                                       offset_std_mm=_number(row, "offset_std_mm", 0.0))
    return measurement, BodyRoughness(wheel_ra, rail_ra)


def correct_batch(study, rows: list[dict[str, str]], *, seed: int = 0, elastic_limit_mpa: float | None = None,
                  progress=None) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    """Correct every row; return the rows with `OUTPUT_COLUMNS` added, and the batch's provenance.

    A row that fails keeps empty numbers and its reason in ``status``; the others are ``ok`` (or ``ok:
    warning ...`` when the answer carries one, e.g. beyond the elastic limit).

    Raises
    ------
    BatchInterrupted
        On Ctrl-C, with every row: those corrected, and the others marked `INTERRUPTED_STATUS`. The study has
        kept the solves of the rows corrected, so the same batch run again reads them.
    """
    from filmcal._versions import __version__

    cache: dict = {}
    out, posteriors = [], {}

    def provenance() -> dict[str, Any]:
        return {"filmcal": __version__, "study": str(Path(study.root).resolve()),
                "manifest_sha256": study.manifest_sha256, "seed": seed,
                "posteriors": posteriors, "rows": len(rows),
                "failed": sum(1 for r in out if r["status"].startswith("failed")),
                "not_reached": sum(1 for r in out if r["status"] == INTERRUPTED_STATUS)}

    try:
        _correct_rows(study, rows, out, posteriors, seed, elastic_limit_mpa, cache, progress)
    except KeyboardInterrupt:
        out.extend({**row, **{name: "" for name in OUTPUT_COLUMNS[:-1]}, "status": INTERRUPTED_STATUS}
                   for row in rows[len(out):])
        raise BatchInterrupted(out, provenance()) from None
    return out, provenance()


def _correct_rows(study, rows, out: list, posteriors: dict, seed: int, elastic_limit_mpa, cache: dict,
                  progress) -> None:
    """`correct_batch`'s loop: each row's answer appended to `out` as it is known."""
    import warnings

    from filmcal._errors import InputError
    from filmcal.study.correct import ELASTIC_LIMIT_MPA, correct_measurement

    answered: dict[tuple, dict[str, Any]] = {}  # a repeated measurement has the same answer: computed once
    for k, row in enumerate(rows, 1):
        result = dict(row)
        key = tuple(row.get(name, "") for name in INPUT_COLUMNS)
        if key in answered:
            result.update(answered[key])
            out.append(result)
            if progress is not None:
                progress(k, len(rows))
            continue
        try:
            measurement, roughness = _measurement(row)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a warning is the row's status, not a line per row
                answer, _ = correct_measurement(study, row.get("film", ""), measurement, roughness=roughness,
                                                seed=seed, cache=cache,
                                                elastic_limit_mpa=elastic_limit_mpa or ELASTIC_LIMIT_MPA)
            lo, hi = answer["area_ci90_mm2"]
            result.update(area_mm2=answer["area_mm2"], area_std_mm2=answer["area_std_mm2"], area_ci90_low_mm2=lo,
                          area_ci90_high_mm2=hi,
                          status="ok" + "".join(f"; warning: {w}" for w in answer.get("warnings", [])))
            posteriors.setdefault(answer["film"], {}).update(answer["provenance"]["posteriors"])
        except (ValueError, InputError) as exc:
            result.update({name: "" for name in OUTPUT_COLUMNS[:-1]}, status=f"failed: {exc}")
        answered[key] = {name: result[name] for name in OUTPUT_COLUMNS}
        out.append(result)
        if progress is not None:
            progress(k, len(rows))
