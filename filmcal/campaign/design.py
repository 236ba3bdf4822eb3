"""Design points for a campaign: reading, normalising and identifying them.

A design is a table: one row per point, one column per model parameter.
Values are finite numbers (stored as float), booleans or strings. A point is
identified by a hash of its values and of the model settings, so the same
point run with the same model settings is recognised in a store, whatever
the order of its columns or the row it came from.
"""
from __future__ import annotations

import csv
import hashlib
import os
from collections.abc import Mapping, Sequence
from numbers import Real
from pathlib import Path
from typing import Any, Union

import numpy as np

from filmcal._io import canonical_json, json_hash
from filmcal._validation import as_finite, plain_float

__all__ = [
    "DesignValue",
    "read_design_csv",
    "as_design_points",
    "canonical_json",
    "settings_hash",
    "point_id",
]

DesignValue = Union[float, bool, str]
_TRUE_WORDS = ("true", "yes")
_FALSE_WORDS = ("false", "no")


def settings_hash(model_name: str, settings: Mapping[str, Any]) -> str:
    """Hash (16 hex digits) of a model's name and settings.

    Parameters
    ----------
    model_name : str
        Name of the model, e.g. ``"filmcal.fem:evaluate_point"``.
    settings : mapping
        JSON-representable settings that change the model's outputs.
    """
    return json_hash({"model": str(model_name), "settings": dict(settings)})


def point_id(inputs: Mapping[str, DesignValue], settings_hash_: str) -> str:
    """Stable id (16 hex digits) of one design point under given model settings.

    The id hashes the point's values (numbers as float, so ``450`` and
    ``450.0`` are the same point) together with `settings_hash_`.
    """
    values = {name: _design_value(value, f"input {name}") for name, value in inputs.items() if value is not None}
    text = settings_hash_ + "\n" + canonical_json(values)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _design_value(value: Any, where: str) -> DesignValue:
    """Normalise one design value: bool, finite float or str."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, str):
        return value
    if isinstance(value, (Real, np.number)):
        return as_finite(where, value)
    raise ValueError(f"{where} must be a number, a boolean or a string, got {type(value).__name__}")


def _design_point(row: Mapping[Any, Any], row_number: int) -> dict[str, DesignValue]:
    point: dict[str, DesignValue] = {}
    for name, value in row.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"design column names must be non-empty strings, got {name!r}")
        if value is None:
            continue
        point[name] = _design_value(value, f"design row {row_number}, column {name}")
    return point


def as_design_points(design: Any) -> list[dict[str, DesignValue]]:
    """Return a design as a list of point dicts ``{column: value}``.

    Parameters
    ----------
    design : path, sequence of mappings, mapping of columns, or structured array
        A CSV file (see `read_design_csv`), a list of ``{column: value}``
        dicts, a dict ``{column: sequence of values}``, or a numpy structured
        array. Numbers become floats; a value of None leaves the column out
        of that point (the model's default applies).

    Returns
    -------
    list of dict
        One dict per design point, in design order.

    Raises
    ------
    ValueError
        If the design is empty, or holds a non-finite number or a value that
        is neither a number, a boolean nor a string.
    """
    if isinstance(design, (str, os.PathLike)):
        return read_design_csv(design)
    if isinstance(design, np.ndarray) and design.dtype.names:
        rows = [{name: record[name].item() for name in design.dtype.names} for record in design]
    elif isinstance(design, Mapping):
        rows = _rows_from_columns(design)
    elif isinstance(design, Sequence) and all(isinstance(row, Mapping) for row in design):
        rows = list(design)
    else:
        raise ValueError("design must be a CSV path, a list of dicts, a dict of columns "
                         f"or a structured array, got {type(design).__name__}")
    if not rows:
        raise ValueError("design has no points")
    return [_design_point(row, i + 1) for i, row in enumerate(rows)]


def _rows_from_columns(columns: Mapping[Any, Any]) -> list[dict[Any, Any]]:
    arrays = {name: np.asarray(values, dtype=object).reshape(-1) for name, values in columns.items()}
    lengths = {name: values.size for name, values in arrays.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"design columns differ in length: {lengths}")
    n = next(iter(lengths.values()), 0)
    return [{name: values[i] for name, values in arrays.items()} for i in range(n)]


def _parse_cell(text: str) -> DesignValue | None:
    """A CSV cell as a float, a bool (true/false/yes/no), a string, or None if empty."""
    text = text.strip()
    if not text:
        return None
    try:
        return plain_float(text)
    except ValueError:
        pass
    if text.lower() in _TRUE_WORDS:
        return True
    if text.lower() in _FALSE_WORDS:
        return False
    return text


def read_design_csv(path: str | os.PathLike) -> list[dict[str, DesignValue]]:
    """Read a design from a CSV file with a header row.

    Cells that parse as numbers become floats; ``true``/``false`` (or
    ``yes``/``no``, any case) become booleans; other text stays a string; an
    empty cell leaves the column out of that point.

    Parameters
    ----------
    path : path-like
        The CSV file, e.g. as written by ``filmcal doe --out``.

    Returns
    -------
    list of dict
        One dict per data row, in file order.

    Raises
    ------
    FileNotFoundError
        If the file does not exist.
    ValueError
        If the file has no header or no data rows, a row has more or fewer
        cells than the header, or a number is not finite (``nan``, ``inf``).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"design file not found: {path}")
    # utf-8-sig: a spreadsheet's byte-order mark is not part of the first column's name
    with path.open(newline="", encoding="utf-8-sig") as stream:
        reader = csv.DictReader(stream)
        if not reader.fieldnames:
            raise ValueError(f"design file {path} has no header row")
        header = [name.strip() for name in reader.fieldnames]
        if len(set(header)) != len(header) or "" in header:
            raise ValueError(f"design file {path} has empty or repeated column names: {', '.join(header)}")
        reader.fieldnames = header
        rows = []
        for row in reader:
            if None in row:
                raise ValueError(f"design file {path}, line {reader.line_num}: more cells than columns")
            if any(text is None for text in row.values()):  # DictReader's filler for a short row
                given = sum(text is not None for text in row.values())
                raise ValueError(f"design file {path}, line {reader.line_num}: {given} cells for {len(header)} "
                                 "columns (leave a cell empty, with its comma, to leave a value out)")
            rows.append({name: _parse_cell(text or "") for name, text in row.items()})
    if not rows:
        raise ValueError(f"design file {path} has no data rows")
    return [_design_point(row, i + 1) for i, row in enumerate(rows)]
