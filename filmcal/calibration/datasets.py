"""Datasets of sphere-on-flat film imprints: the packaged Table 1 and a lab's own CSV files.

The format (one row per imprint; UTF-8 CSV with a header; lines starting with
``#`` are comments; an empty optional cell takes its default):

=======================  ========  =============================================
column                   required  meaning
=======================  ========  =============================================
``film``                 yes       film name (``HS``, ``LOT7``; any film name)
``sphere_radius_mm``     yes       sphere radius R (mm), > 0
``force_kn``             yes       normal force F (kN), > 0
``measured_radius_mm``   one of    radius of the imprint (mm), > 0
``measured_area_mm2``    these     area of the imprint (mm^2), > 0; the radius
                         three     is that of the circle of equal area
``radius_error_mm``                measured radius minus the Hertz radius (mm):
                                   Table 1's form
``repeat``               no        number of the imprint within its case
                                   (integer >= 1; unique within a case)
``measurement_std_mm``   no        standard uncertainty of the measured radius
                                   (mm, >= 0, at most a quarter of the Hertz
                                   radius; default 0)
``flat_ra_um``           no        roughness Ra of the flat (um: 0, smooth, or
                                   0.01-30)
``sphere_modulus_mpa``   no        Young's modulus of the sphere (MPa; default
                                   steel, 210000)
``sphere_poisson``       no        its Poisson's ratio (default 0.3)
``flat_modulus_mpa``     no        the flat's (default steel)
``flat_poisson``         no        the flat's (default 0.3)
=======================  ========  =============================================

A *case* is one test condition (film, R, F, body materials, flat roughness);
its rows are repeats of one imprint. The Hertz radius of each row uses the
row's body materials, so the radius errors do too.

`load_dataset` reads a file or a packaged dataset by name (``table1``: Table
1 of the reference paper) and returns a `Dataset` that records where the
numbers came from (its source and the sha256 of its bytes). Validation is
strict: the first problem raises a `ValueError` naming the file, the line and
the column. Reading a dataset never executes anything from it.
"""
from __future__ import annotations

import csv
import hashlib
import io
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from filmcal._validation import FORCE_KN_BOUNDS, MAX_RA_UM, MIN_RA_UM, SPHERE_RADIUS_MM_BOUNDS, plain_float, plain_int
from filmcal.calibration.data import _FIELDS, RadiusErrorData, parse_load_range
from filmcal.films import FILM_TYPES, FilmType
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm, plausible_imprint_radius_mm

__all__ = ["Dataset", "load_dataset", "load_table1", "PACKAGED_DATASETS", "REQUIRED_COLUMNS", "MEASURED_COLUMNS",
           "OPTIONAL_COLUMNS"]

#: Packaged datasets by name: resource path inside the package.
PACKAGED_DATASETS: dict[str, str] = {"table1": "data/table1_radius_errors.csv"}
REQUIRED_COLUMNS = ("film", "sphere_radius_mm", "force_kn")
#: The largest repeat number a row may give (a lab's repeats of one case number in the tens).
MAX_REPEAT = 10**6
MEASURED_COLUMNS = ("measured_radius_mm", "measured_area_mm2", "radius_error_mm")
OPTIONAL_COLUMNS = ("repeat", "measurement_std_mm", "flat_ra_um", "sphere_modulus_mpa", "sphere_poisson",
                    "flat_modulus_mpa", "flat_poisson")


@dataclass(frozen=True)
class Dataset:
    """Measured imprints with their provenance.

    Attributes
    ----------
    name : str
        The packaged name (``table1``) or the file's stem.
    source : str
        The file's path, or ``package:filmcal/<resource>`` for a packaged dataset.
    sha256 : str
        Hash of the file's bytes (hex).
    measured_column : str
        Which of `MEASURED_COLUMNS` the file gives.
    columns : tuple of str
        The columns present.
    data : RadiusErrorData
        Every row (all films).
    """

    name: str
    source: str
    sha256: str
    measured_column: str
    columns: tuple[str, ...]
    data: RadiusErrorData

    def __len__(self) -> int:
        return len(self.data)

    @property
    def films(self) -> tuple[str, ...]:
        """The film names present, in order of first appearance."""
        return tuple(dict.fromkeys(self.data.film.tolist()))

    def select(self, film: str | FilmType | None = None,
               loads: str | tuple[float, float] | None = None) -> RadiusErrorData:
        """The rows of one film (name or `FilmType`) and load range (kN, see `parse_load_range`).

        Raises
        ------
        ValueError
            When the film is not in the dataset (the message lists those that
            are) or the load range cannot be parsed.
        """
        mask = np.ones(len(self.data), dtype=bool)
        if film is not None:
            name = film.name if isinstance(film, FilmType) else str(film)
            if name not in self.films:
                raise ValueError(f"film {name!r} is not in dataset {self.name} ({self.source}); "
                                 f"it holds {', '.join(self.films)}")
            mask &= self.data.film == name
        if loads is not None:
            low_kn, high_kn = parse_load_range(loads)
            mask &= (self.data.force_kn >= low_kn) & (self.data.force_kn <= high_kn)
        return self.data.select(mask)

    def to_dict(self) -> dict:
        """Provenance as plain JSON values (what a study's manifest records)."""
        return {"name": self.name, "source": self.source, "sha256": self.sha256, "n_rows": len(self),
                "n_cases": self.data.n_cases, "films": list(self.films), "measured_column": self.measured_column}


def _is_packaged(path_or_name: str | Path) -> bool:
    return isinstance(path_or_name, str) and path_or_name in PACKAGED_DATASETS and not Path(path_or_name).exists()


def load_dataset(path_or_name: str | Path) -> Dataset:
    """Read a dataset: a CSV file of the module's format, or a packaged one by name.

    Parameters
    ----------
    path_or_name : str or Path
        A CSV file, or the name of a packaged dataset (`PACKAGED_DATASETS`:
        ``table1``). An existing file takes precedence over a packaged name.

    Returns
    -------
    Dataset

    Raises
    ------
    ValueError
        A missing or unreadable file, or the first invalid header, line or
        cell, named by file, line and column.
    """
    if _is_packaged(path_or_name):
        resource = PACKAGED_DATASETS[str(path_or_name)]
        raw = resources.files("filmcal").joinpath(resource).read_bytes()
        return _parse(raw, name=str(path_or_name), source=f"package:filmcal/{resource}")
    path = Path(path_or_name)
    if not path.exists():
        raise ValueError(f"dataset {str(path)!r}: no such file, and no packaged dataset of that name "
                         f"(packaged: {', '.join(PACKAGED_DATASETS)})")
    if path.is_dir():
        raise ValueError(f"dataset {str(path)!r}: is a folder, give a CSV file")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise ValueError(f"dataset {str(path)!r}: cannot be read ({exc.strerror})") from None
    return _parse(raw, name=path.stem, source=str(path))


class _Where:
    """Formats error messages that name the file, line and column."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, message: str, line: int | None = None, column: str | None = None) -> ValueError:
        where = self.source
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column {column}"
        return ValueError(f"dataset {where}: {message}")


#: The largest measurement standard deviation of a radius a dataset may give, over the case's Hertz radius:
#: Table 1's scatter is 0.3-1.5 % of the radius; a quarter of it is a unit error (um for mm), not a scatter.
MAX_STD_OVER_HERTZ = 0.25


def _number(where: _Where, line: int, column: str, text: str, low: float = -math.inf, high: float = math.inf,
            low_open: bool = True, high_open: bool = True, what: str | None = None) -> float:
    try:
        value = plain_float(text.strip())
    except ValueError:
        raise where.error(f"{text!r} is not a number", line, column) from None
    ok = math.isfinite(value) and (value > low if low_open else value >= low) and \
        (value < high if high_open else value <= high)
    if not ok:
        raise where.error(f"must be {what or 'finite'}, got {text!r}", line, column)
    return value


def _parse(raw: bytes, name: str, source: str) -> Dataset:
    where = _Where(source)
    sha256 = hashlib.sha256(raw).hexdigest()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise where.error(f"not UTF-8 text (byte {exc.start})") from None
    numbered = [(k + 1, line) for k, line in enumerate(io.StringIO(text).read().splitlines())
                if line.strip() and not line.lstrip().startswith("#")]
    if not numbered:
        raise where.error("holds no header and no rows")
    try:
        records = list(csv.reader([line for _, line in numbered], strict=True))
    except csv.Error as exc:
        raise where.error(f"not valid CSV ({exc})") from None
    header, measured_column = _header(where, numbered[0][0], records[0])
    if len(records) < 2:
        raise where.error("holds a header but no rows")
    cols: dict[str, list] = {c: [] for c in ("film", "sphere_radius_mm", "force_n", "measured", "repeat",
                                             *_ROW_DEFAULTS)}
    lines = []
    for (line, _), record in zip(numbered[1:], records[1:]):
        if len(record) != len(header):
            raise where.error(f"has {len(record)} fields, the header has {len(header)}", line)
        for column, value in _row(where, line, dict(zip(header, (v.strip() for v in record))),
                                  measured_column).items():
            cols[column].append(value)
        lines.append(line)
    arrays = {k: np.asarray(v, dtype=float) for k, v in cols.items() if k not in ("film", "repeat")}
    hertz, radius = _radii(where, lines, arrays, measured_column)
    data = RadiusErrorData(
        film=np.asarray(cols["film"]), sphere_radius_mm=arrays["sphere_radius_mm"], force_n=arrays["force_n"],
        radius_error_mm=arrays["measured"] if measured_column == "radius_error_mm" else radius - hertz,
        hertz_radius_mm=hertz, measured_radius_mm=radius,
        measurement_std_mm=arrays["measurement_std_mm"], flat_ra_um=arrays["flat_ra_um"],
        sphere_modulus_mpa=arrays["sphere_modulus_mpa"], sphere_poisson=arrays["sphere_poisson"],
        flat_modulus_mpa=arrays["flat_modulus_mpa"], flat_poisson=arrays["flat_poisson"])
    repeat = _repeats(where, lines, data, cols["repeat"])
    data = RadiusErrorData(**{**{f: getattr(data, f) for f in _FIELDS}, "repeat": repeat})
    return Dataset(name=name, source=source, sha256=sha256, measured_column=measured_column,
                   columns=tuple(header), data=data)


def _header(where: _Where, line: int, record: list[str]) -> tuple[list[str], str]:
    """The header's column names, checked, and the one measured column among them."""
    header = [h.strip() for h in record]
    known = REQUIRED_COLUMNS + MEASURED_COLUMNS + OPTIONAL_COLUMNS
    duplicated = sorted({h for h in header if header.count(h) > 1})
    if duplicated:
        raise where.error(f"column(s) {', '.join(duplicated)} appear more than once", line)
    unknown = [h for h in header if h not in known]
    if unknown:
        hint = ("; a film's thickness is part of its definition: give thickness_mm in a --films-file, under a film "
                "name of its own" if any("thickness" in h for h in unknown) else "")
        raise where.error(f"unknown column(s) {', '.join(map(repr, unknown))}; known: {', '.join(known)}{hint}",
                          line)
    missing = [c for c in REQUIRED_COLUMNS if c not in header]
    if missing:
        raise where.error(f"missing required column(s) {', '.join(missing)}", line)
    measured = [c for c in MEASURED_COLUMNS if c in header]
    if len(measured) != 1:
        raise where.error(f"needs exactly one of {', '.join(MEASURED_COLUMNS)}, got "
                          f"{', '.join(measured) if measured else 'none'}", line)
    return header, measured[0]


#: The optional columns of a row: their values when left empty, and their limits (low, high, low open, words).
_ROW_DEFAULTS = {"measurement_std_mm": 0.0, "flat_ra_um": math.nan, "sphere_modulus_mpa": STEEL_MODULUS_MPA,
                 "sphere_poisson": STEEL_POISSON, "flat_modulus_mpa": STEEL_MODULUS_MPA,
                 "flat_poisson": STEEL_POISSON}
_ROW_LIMITS = {"measurement_std_mm": (0.0, math.inf, False, "finite and >= 0 mm"),
               "flat_ra_um": (0.0, math.inf, False, "finite and >= 0 um"),
               "sphere_modulus_mpa": (0.0, math.inf, True, "finite and > 0 MPa"),
               "flat_modulus_mpa": (0.0, math.inf, True, "finite and > 0 MPa"),
               "sphere_poisson": (-1.0, 0.5, True, "in (-1, 0.5)"),
               "flat_poisson": (-1.0, 0.5, True, "in (-1, 0.5)")}


def _row(where: _Where, line: int, cell: dict[str, str], measured_column: str) -> dict[str, Any]:
    """One row's values, checked: film, sphere radius, force (N), measured value, repeat and the optional ones."""
    film = cell["film"]
    if not film:
        raise where.error("is empty; give the film's name", line, "film")
    try:
        FilmType(film)
    except ValueError as exc:
        raise where.error(str(exc), line, "film") from None
    out: dict[str, Any] = {"film": film}
    # the command line's bounds: a sphere of 1 mm to 100 m, 1 N to 2 MN (beyond them a unit error)
    out["sphere_radius_mm"] = _number(where, line, "sphere_radius_mm", cell["sphere_radius_mm"],
                                      SPHERE_RADIUS_MM_BOUNDS[0], SPHERE_RADIUS_MM_BOUNDS[1], False, True,
                                      f"in {SPHERE_RADIUS_MM_BOUNDS[0]:g}-{SPHERE_RADIUS_MM_BOUNDS[1]:g} mm")
    out["force_n"] = 1000.0 * _number(where, line, "force_kn", cell["force_kn"], FORCE_KN_BOUNDS[0],
                                      FORCE_KN_BOUNDS[1], False, True,
                                      f"in {FORCE_KN_BOUNDS[0]:g}-{FORCE_KN_BOUNDS[1]:g} kN")
    if measured_column == "radius_error_mm":
        out["measured"] = _number(where, line, measured_column, cell[measured_column])
    else:
        out["measured"] = _number(where, line, measured_column, cell[measured_column], 0.0,
                                  what="finite and > 0")
    rep = cell.get("repeat", "")
    out["repeat"] = None
    if rep:
        try:
            out["repeat"] = plain_int(rep)
        except ValueError:
            raise where.error(f"must be an integer >= 1, got {rep!r}", line, "repeat") from None
        if not 1 <= out["repeat"] <= MAX_REPEAT:
            raise where.error(f"must be an integer in 1-{MAX_REPEAT}, got {rep!r}", line, "repeat")
    for column, default in _ROW_DEFAULTS.items():
        text = cell.get(column, "")
        if not text:
            out[column] = default
            continue
        low, high, low_open, what = _ROW_LIMITS[column]
        value = _number(where, line, column, text, low, high, low_open, True, what)
        if column == "flat_ra_um" and not (value == 0.0 or MIN_RA_UM <= value <= MAX_RA_UM):
            raise where.error(f"must be 0 (smooth) or in [{MIN_RA_UM:g}, {MAX_RA_UM:g}] um, got {text!r}", line,
                              column)
        out[column] = value
    return out


def _radii(where: _Where, lines: list[int], arrays: dict[str, np.ndarray],
           measured_column: str) -> tuple[np.ndarray, np.ndarray]:
    """The Hertz and the measured radius of every row (mm), the measured ones checked against Hertz's."""
    hertz = hertz_radius_mm(arrays["sphere_radius_mm"], arrays["force_n"], arrays["sphere_modulus_mpa"],
                            arrays["sphere_poisson"], arrays["flat_modulus_mpa"], arrays["flat_poisson"])
    hertz = np.atleast_1d(np.asarray(hertz, dtype=float))
    if measured_column == "measured_radius_mm":
        radius = arrays["measured"]
    elif measured_column == "measured_area_mm2":
        radius = np.sqrt(arrays["measured"] / math.pi)
    else:
        radius = hertz + arrays["measured"]
        bad = np.flatnonzero(radius <= 0.0)
        if bad.size:
            raise where.error(f"gives a measured radius {radius[bad[0]]:g} mm <= 0 (Hertz radius "
                              f"{hertz[bad[0]]:.4g} mm)", lines[bad[0]], measured_column)
    bad = np.flatnonzero(arrays["measurement_std_mm"] > MAX_STD_OVER_HERTZ * hertz)
    if bad.size:
        i = bad[0]
        raise where.error(f"gives a measurement_std_mm of {arrays['measurement_std_mm'][i]:g} mm, more than "
                          f"{MAX_STD_OVER_HERTZ:g} of the Hertz radius {hertz[i]:.3f} mm (an imprint's scatter is a "
                          "few percent of its radius): check the units (mm)", lines[i], "measurement_std_mm")
    lo, hi = plausible_imprint_radius_mm(hertz)
    bad = np.flatnonzero((radius < lo) | (radius > hi))
    if bad.size:
        i = bad[0]
        raise where.error(f"gives a measured radius {radius[i]:g} mm where a film imprint lies within "
                          f"{lo[i]:.2f}-{hi[i]:.2f} mm (Hertz radius {hertz[i]:.3f} mm): check the units",
                          lines[i], measured_column)
    return hertz, radius


def _repeats(where: _Where, lines: list[int], data: RadiusErrorData, given: list[int | None]) -> np.ndarray:
    """Each row's repeat number: as given, unique within a case; unnumbered rows take the next free numbers."""
    repeat = np.zeros(len(data), dtype=int)
    used: dict[int, dict[int, int]] = {}
    for i, (case, rep) in enumerate(zip(data.case_index, given)):
        if rep is None:
            continue
        first = used.setdefault(int(case), {}).get(rep)
        if first is not None:
            raise where.error(f"repeat {rep} of this case (film {data.film[i]}, R {data.sphere_radius_mm[i]:g} mm, "
                              f"F {data.force_kn[i]:g} kN) already appears on line {first}", lines[i], "repeat")
        used[int(case)][rep] = lines[i]
        repeat[i] = rep
    next_free: dict[int, int] = {}  # per case, no free number below it (linear in the rows, not quadratic)
    for i, (case, rep) in enumerate(zip(data.case_index, given)):
        if rep is None:
            taken = used.setdefault(int(case), {})
            nxt = next_free.get(int(case), 1)
            while nxt in taken:
                nxt += 1
            taken[nxt] = lines[i]
            repeat[i] = nxt
            next_free[int(case)] = nxt + 1
    return repeat


def load_table1(film: str | None = None, loads: str | tuple[float, float] | None = None) -> RadiusErrorData:
    """Load Table 1 of the reference paper, optionally filtered.

    Parameters
    ----------
    film : str, optional
        Film type, one of ``MS``, ``HS``, ``HHS`` (case-insensitive). All films
        when omitted.
    loads : str or (float, float), optional
        Load range in kN, inclusive, e.g. ``"50-100"``; see `parse_load_range`.
        All loads when omitted.

    Returns
    -------
    RadiusErrorData
        The selected rows with the Hertz and measured radii of each.

    Raises
    ------
    ValueError
        For an unknown film type (the message lists the known ones) or a load
        range that cannot be parsed.
    """
    data = load_dataset("table1").data
    mask = np.ones(len(data), dtype=bool)
    if film is not None:
        key = str(film).strip().upper()
        if key not in FILM_TYPES:
            raise ValueError(f"film must be one of {', '.join(FILM_TYPES)} (case-insensitive); got {film!r}")
        mask &= data.film == key
    if loads is not None:
        low_kn, high_kn = parse_load_range(loads)
        mask &= (data.force_kn >= low_kn) & (data.force_kn <= high_kn)
    return data.select(mask)
