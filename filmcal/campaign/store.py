"""SQLite store of campaign runs: one row per design point and model settings.

The store is plain data: inputs and outputs as JSON text, status, failure
reason, timings and provenance (model settings hash, package version,
timestamps). Opening it runs no code from it. One campaign writes at a time
(`filmcal.campaign.StoreLock`, taken by `Campaign.run`); each finished run is
committed in its own transaction, in write-ahead-log mode, so that killing
the campaign at any moment loses at most the runs in flight, and other
processes can read the store while it is being written. A run that finished
``ok`` is never downgraded: the update is guarded in the query and by a
trigger in the database itself.

Any output column of any store can feed a surrogate or a calibration:
`load_output_column` returns the ok runs' values of one output with their
inputs.
"""
from __future__ import annotations

import csv
import json
import numbers
import math
import os
import sqlite3
import urllib.parse
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Literal

import numpy as np

from filmcal._errors import DamagedFileError, InputError
from filmcal._io import atomic_path
from filmcal._validation import check_choice
from filmcal.campaign.design import DesignValue, canonical_json

__all__ = ["RunStatus", "STATUSES", "RunRecord", "RunCounts", "RunStore", "OutputColumn", "load_output_column"]

SCHEMA_VERSION = 1
STATUSES = ("ok", "failed", "pending")
RunStatus = Literal["ok", "failed", "pending"]

_SCHEMA = f"""
CREATE TABLE IF NOT EXISTS store_info (
    key   TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS model_settings (
    settings_hash TEXT PRIMARY KEY,
    settings_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS runs (
    point_id        TEXT PRIMARY KEY,
    settings_hash   TEXT NOT NULL REFERENCES model_settings (settings_hash),
    inputs_json     TEXT NOT NULL,
    outputs_json    TEXT,
    status          TEXT NOT NULL CHECK (status IN {STATUSES}),
    reason          TEXT,
    elapsed_s       REAL,
    attempts        INTEGER NOT NULL DEFAULT 0,
    package_version TEXT NOT NULL,
    created_at      TEXT NOT NULL,
    finished_at     TEXT
);
CREATE INDEX IF NOT EXISTS runs_by_settings ON runs (settings_hash, status);
"""
# A finished ok run is never downgraded, whoever writes to the store.
_KEEP_OK_TRIGGER = """
CREATE TRIGGER IF NOT EXISTS runs_keep_ok BEFORE UPDATE OF status ON runs
WHEN OLD.status = 'ok' AND NEW.status <> 'ok'
BEGIN SELECT RAISE(IGNORE); END
"""

# Bookkeeping columns of an exported CSV, after the inputs and outputs.
RUN_COLUMNS = ("status", "reason", "elapsed_s", "attempts", "settings_hash",
               "package_version", "created_at", "finished_at")


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _package_version() -> str:
    from filmcal._versions import __version__

    return __version__


def _json_outputs(outputs: Mapping[str, Any]) -> str:
    """Outputs as JSON, with non-finite floats stored as null."""
    def plain(value: Any) -> Any:
        return None if isinstance(value, float) and not math.isfinite(value) else value

    return canonical_json({name: plain(value) for name, value in outputs.items()})


@dataclass(frozen=True)
class RunRecord:
    """One run of a design point, as stored.

    Attributes
    ----------
    point_id : str
        Hash of the inputs and of the model settings.
    settings_hash : str
        Hash of the model name and settings.
    inputs, outputs : dict
        Model parameters and model outputs (empty until the run finished).
    status : {"ok", "failed", "pending"}
        Outcome of the last attempt; pending until a run finished.
    reason : str or None
        Why the run failed.
    elapsed_s : float or None
        Wall-clock time of the last attempt.
    attempts : int
        Number of finished attempts.
    package_version : str
        filmcal version that produced the row's current state.
    created_at, finished_at : str or None
        ISO 8601 UTC timestamps: point added, last attempt finished.
    """

    point_id: str
    settings_hash: str
    inputs: dict[str, DesignValue]
    outputs: dict[str, Any]
    status: RunStatus
    reason: str | None
    elapsed_s: float | None
    attempts: int
    package_version: str
    created_at: str
    finished_at: str | None


@dataclass(frozen=True)
class RunCounts:
    """Number of runs per status."""

    ok: int
    failed: int
    pending: int

    @property
    def total(self) -> int:
        """All runs."""
        return self.ok + self.failed + self.pending

    def as_dict(self) -> dict[str, int]:
        """``{"ok", "failed", "pending", "total"}`` counts."""
        return {**asdict(self), "total": self.total}

    @classmethod
    def from_statuses(cls, statuses: Iterable[RunStatus]) -> "RunCounts":
        """Count the statuses of an iterable."""
        statuses = list(statuses)
        return cls(*(statuses.count(status) for status in STATUSES))


class RunStore:
    """A campaign store in an SQLite file.

    Parameters
    ----------
    path : path-like
        The SQLite file.
    create : bool
        Create the file if it does not exist. With False, a missing file
        raises `FileNotFoundError`.
    readonly : bool
        Open for reading only (status, export, output columns): the file is
        never changed, and an empty or foreign file is never turned into a
        store.

    Raises
    ------
    FileNotFoundError
        If the file does not exist and may not be created.
    filmcal._errors.InputError
        If the path is a folder or an empty file, the file is an SQLite
        database but not a campaign store, or was written with another store
        schema version.
    filmcal._errors.DamagedFileError
        If the file is not an SQLite database (garbled).
    """

    def __init__(self, path: str | os.PathLike, *, create: bool = True, readonly: bool = False) -> None:
        self.path = Path(path)
        self.readonly = bool(readonly)
        if (readonly or not create) and not self.path.exists():
            raise FileNotFoundError(f"campaign store not found: {self.path}")
        if self.path.exists() and not self.path.is_file():
            raise InputError(f"campaign store {self.path} is a folder, not a file")
        if (readonly or not create) and self.path.stat().st_size == 0:
            raise InputError(f"{self.path} is an empty file, not a campaign store")
        try:
            if readonly:
                uri = f"file:{urllib.parse.quote(str(self.path.resolve()))}?mode=ro"
                self._conn = sqlite3.connect(uri, uri=True, timeout=30.0, isolation_level=None)
            else:
                self._conn = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
        except sqlite3.Error as exc:
            raise InputError(f"cannot open the campaign store {self.path}: {exc}") from None
        try:
            self._prepare()
        except sqlite3.DatabaseError as exc:
            self._conn.close()
            # a garbled store and a file that never was one look alike: never advise deleting it
            raise DamagedFileError(self.path, f"not a campaign store, or a garbled one: {exc}") from None
        except ValueError:
            self._conn.close()
            raise

    def _prepare(self) -> None:
        conn = self._conn
        tables = {row[0] for row in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if tables and "store_info" not in tables:
            raise InputError(f"{self.path} is an SQLite database but not a campaign store")
        if not tables and self.readonly:
            raise InputError(f"{self.path} is not a campaign store (it holds no runs table)")
        if not self.readonly:
            conn.execute("PRAGMA journal_mode=WAL")
            # NORMAL in WAL mode: a committed transaction survives a killed
            # process; only a power failure can lose the last ones.
            conn.execute("PRAGMA synchronous=NORMAL")
            conn.execute("PRAGMA foreign_keys=ON")
        if not tables:
            with self._transaction():
                for statement in _SCHEMA.split(";"):
                    conn.execute(statement)
                conn.execute("INSERT OR IGNORE INTO store_info VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
        row = conn.execute("SELECT value FROM store_info WHERE key='schema_version'").fetchone()
        if row is None or row[0] != str(SCHEMA_VERSION):
            found = None if row is None else row[0]
            raise InputError(f"{self.path} has store schema version {found}, expected {SCHEMA_VERSION}")
        if not self.readonly:
            conn.execute(_KEEP_OK_TRIGGER)

    @contextmanager
    def _transaction(self) -> Iterator[sqlite3.Connection]:
        """Run the block as one write transaction: all of it is committed, or none."""
        self._conn.execute("BEGIN IMMEDIATE")
        try:
            yield self._conn
        except BaseException:
            self._conn.execute("ROLLBACK")
            raise
        self._conn.execute("COMMIT")

    def close(self) -> None:
        """Close the database connection.

        A writer leaves the file in rollback-journal mode when it is the last
        one open, so that readers (`campaign status`, an archived copy on a
        read-only medium) create no ``-wal``/``-shm`` files beside it; while
        another connection is open the store stays in WAL mode.
        """
        if not self.readonly:
            try:
                self._conn.execute("PRAGMA busy_timeout=0")
                self._conn.execute("PRAGMA journal_mode=DELETE")
            except sqlite3.Error:  # another connection is open: it switches back when it closes
                pass
        self._conn.close()

    def __enter__(self) -> "RunStore":
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    # -- writing

    def add_points(self, points: Mapping[str, Mapping[str, DesignValue]], settings_hash: str,
                   settings: Mapping[str, Any]) -> None:
        """Add design points not yet in the store as pending runs (one transaction).

        Parameters
        ----------
        points : mapping
            ``{point_id: inputs}``.
        settings_hash : str
            Hash of the model name and settings the points are run with.
        settings : mapping
            The model name and settings themselves, kept for provenance.
        """
        now, version = _now(), _package_version()
        with self._transaction() as conn:
            conn.execute("INSERT OR IGNORE INTO model_settings VALUES (?, ?)",
                         (settings_hash, canonical_json(dict(settings))))
            conn.executemany(
                "INSERT OR IGNORE INTO runs (point_id, settings_hash, inputs_json, status, "
                "package_version, created_at) VALUES (?, ?, ?, 'pending', ?, ?)",
                [(pid, settings_hash, canonical_json(dict(inputs)), version, now)
                 for pid, inputs in points.items()],
            )

    def record_outcome(self, point_id: str, status: RunStatus, outputs: Mapping[str, Any],
                       reason: str | None, elapsed_s: float | None) -> bool:
        """Store the outcome of one finished run, in its own transaction.

        A run already stored as ok is left as it is (it is never downgraded
        nor overwritten); the method then returns False.

        Parameters
        ----------
        point_id : str
            A point already added with `add_points`.
        status : {"ok", "failed"}
            Outcome of the run.
        outputs : mapping
            Model outputs (non-finite floats are stored as null).
        reason : str or None
            Why the run failed.
        elapsed_s : float or None
            Wall-clock time of the run.

        Returns
        -------
        bool
            True if the outcome was stored, False if the run was already ok.
        """
        check_choice("status", status, ("ok", "failed"))
        with self._transaction() as conn:
            cursor = conn.execute(
                "UPDATE runs SET status=?, outputs_json=?, reason=?, elapsed_s=?, attempts=attempts+1, "
                "package_version=?, finished_at=? WHERE point_id=? AND status<>'ok'",
                (status, _json_outputs(outputs), reason, elapsed_s, _package_version(), _now(), point_id),
            )
            if cursor.rowcount == 1:
                return True
            if conn.execute("SELECT 1 FROM runs WHERE point_id=?", (point_id,)).fetchone() is None:
                raise KeyError(f"no run with point_id {point_id} in {self.path}")
            return False

    # -- reading

    def statuses(self, settings_hash: str | None = None) -> dict[str, RunStatus]:
        """``{point_id: status}`` of all runs, or of those with `settings_hash`."""
        query, args = "SELECT point_id, status FROM runs", ()
        if settings_hash is not None:
            query, args = query + " WHERE settings_hash=?", (settings_hash,)
        return dict(self._conn.execute(query, args).fetchall())

    def counts(self, settings_hash: str | None = None) -> RunCounts:
        """Number of ok, failed and pending runs (of one model settings hash, or all)."""
        return RunCounts.from_statuses(self.statuses(settings_hash).values())

    def records(self, settings_hash: str | None = None, status: RunStatus | None = None) -> list[RunRecord]:
        """The stored runs, in the order their points were added.

        Parameters
        ----------
        settings_hash : str, optional
            Only runs with these model settings.
        status : {"ok", "failed", "pending"}, optional
            Only runs with this status.
        """
        conditions, args = [], []
        if settings_hash is not None:
            conditions.append("settings_hash=?")
            args.append(settings_hash)
        if status is not None:
            conditions.append("status=?")
            args.append(check_choice("status", status, STATUSES))
        where = f" WHERE {' AND '.join(conditions)}" if conditions else ""
        rows = self._conn.execute(
            "SELECT point_id, settings_hash, inputs_json, outputs_json, status, reason, elapsed_s, "
            f"attempts, package_version, created_at, finished_at FROM runs{where} ORDER BY rowid",
            args,
        ).fetchall()
        return [RunRecord(pid, sh, json.loads(inputs), json.loads(outputs) if outputs else {}, *rest)
                for pid, sh, inputs, outputs, *rest in rows]

    def export_csv(self, path: str | os.PathLike, settings_hash: str | None = None) -> int:
        """Write the runs to a CSV file; return the number of rows written.

        Columns: ``point_id``, the inputs, the outputs (an output named like an
        input or a bookkeeping column gets the prefix ``output_``), then
        status, reason, elapsed_s, attempts, settings_hash, package_version,
        created_at, finished_at. Missing values are empty cells.
        """
        records = self.records(settings_hash)
        input_names = _union(record.inputs for record in records)
        taken = {"point_id", *input_names, *RUN_COLUMNS}
        output_names = _union(record.outputs for record in records)
        output_columns = {name: f"output_{name}" if name in taken else name for name in output_names}
        header = ["point_id", *input_names, *output_columns.values(), *RUN_COLUMNS]
        with atomic_path(path) as tmp, Path(tmp).open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(header)
            for record in records:
                row = [record.point_id]
                row += [_cell(record.inputs.get(name)) for name in input_names]
                row += [_cell(record.outputs.get(name)) for name in output_names]
                row += [_cell(getattr(record, name)) for name in RUN_COLUMNS]
                writer.writerow(row)
        return len(records)

    def settings_hashes(self) -> dict[str, dict[str, Any]]:
        """``{settings_hash: {"model": ..., "settings": ...}}`` of every model setting in the store."""
        return {h: json.loads(text) for h, text in
                self._conn.execute("SELECT settings_hash, settings_json FROM model_settings ORDER BY rowid")}

    def output_column(self, output: str, inputs: Iterable[str] | None = None,
                      settings_hash: str | None = None) -> "OutputColumn":
        """One output of the ok runs, with their inputs: training data for a surrogate.

        Parameters
        ----------
        output : str
            Name of the output (e.g. ``"contact_radius_mm"``, or any numeric
            key printed by an external command).
        inputs : iterable of str, optional
            Input columns to return (default: all inputs of those runs); every
            returned run must have all of them.
        settings_hash : str, optional
            Model settings whose runs to use. Required when the store holds
            that output for runs of more than one model setting.

        Returns
        -------
        OutputColumn

        Raises
        ------
        filmcal._errors.InputError
            If no ok run has a finite value of `output` (the message lists the
            outputs there are), a requested input is missing, or the runs span
            several model settings and `settings_hash` was not given.
        """
        records = [r for r in self.records(settings_hash, "ok")
                   if isinstance(r.outputs.get(output), (int, float)) and not isinstance(r.outputs[output], bool)
                   and math.isfinite(r.outputs[output])]
        if not records:
            names = _union(r.outputs for r in self.records(settings_hash, "ok"))
            raise InputError(f"output {output!r}: no ok run in {self.path} has a finite value of it; "
                             f"outputs there: {', '.join(names) or 'none'}")
        hashes = list(dict.fromkeys(r.settings_hash for r in records))
        if len(hashes) > 1:
            raise InputError(f"output {output!r} comes from {len(hashes)} model settings in {self.path}; "
                             f"choose one with settings_hash (one of {', '.join(hashes)})")
        names = list(inputs) if inputs is not None else _union(r.inputs for r in records)
        missing = [name for name in names if any(name not in r.inputs for r in records)]
        if missing:
            raise InputError(f"inputs {', '.join(missing)} are missing from some runs in {self.path}")
        return OutputColumn(
            name=output,
            settings_hash=hashes[0],
            point_id=np.array([r.point_id for r in records], dtype=str),
            inputs={name: _array([r.inputs[name] for r in records]) for name in names},
            values=np.array([float(r.outputs[output]) for r in records]),
        )


@dataclass(frozen=True)
class OutputColumn:
    """The ok runs' values of one output, with the inputs that produced them.

    Attributes
    ----------
    name : str
        The output.
    settings_hash : str
        Model settings of these runs.
    point_id : ndarray of str
    inputs : dict of str to ndarray
        One array per input column (float where all values are numbers).
    values : ndarray of float
        The output, one value per run.
    """

    name: str
    settings_hash: str
    point_id: np.ndarray
    inputs: dict[str, np.ndarray]
    values: np.ndarray

    def __len__(self) -> int:
        return len(self.values)

    def input_matrix(self, names: Iterable[str] | None = None) -> np.ndarray:
        """Inputs as an ``(n_runs, n_inputs)`` float array, columns in the order of `names`."""
        names = list(names) if names is not None else list(self.inputs)
        return np.column_stack([np.asarray(self.inputs[name], dtype=float) for name in names])


def load_output_column(store_path: str | os.PathLike, output: str, inputs: Iterable[str] | None = None,
                       settings_hash: str | None = None) -> OutputColumn:
    """Read one output column of a campaign store (read-only); see `RunStore.output_column`."""
    with RunStore(store_path, readonly=True) as store:
        return store.output_column(output, inputs, settings_hash)


def _array(values: list[Any]) -> np.ndarray:
    if all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        return np.array(values, dtype=float)
    return np.array(values, dtype=object)


def _union(mappings: Iterable[Mapping[str, Any]]) -> list[str]:
    """Keys of all mappings, in order of first appearance."""
    names: dict[str, None] = {}
    for mapping in mappings:
        names.update(dict.fromkeys(mapping))
    return list(names)


def _cell(value: Any) -> str:
    """A CSV cell: empty for missing, true/false for booleans, repr for floats.

    Text that a spreadsheet would run as a formula (starting with =, +, -, @, a tab or a carriage return)
    is written with a leading apostrophe; numbers are numbers and never escaped.
    """
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Real):
        return repr(float(value)) if isinstance(value, float) else str(value)
    text = str(value)
    return "'" + text if text[:1] in ("=", "+", "-", "@", "\t", "\r") else text
