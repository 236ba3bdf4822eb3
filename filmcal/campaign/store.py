"""SQLite store of campaign runs: one row per design point and model settings.

The store is plain data: inputs and outputs as JSON text, status, failure
reason, timings and provenance (model settings hash, package version,
timestamps). Opening it runs no code from it. One process writes (the one
running the campaign); each finished run is committed in its own
transaction, in write-ahead-log mode, so that killing the campaign at any
moment loses at most the runs in flight, and other processes can read the
store while it is being written.
"""
from __future__ import annotations

import csv
import json
import math
import os
import sqlite3
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Literal

from filmcal._validation import check_choice
from filmcal.campaign.design import DesignValue, canonical_json

__all__ = ["RunStatus", "STATUSES", "RunRecord", "RunCounts", "RunStore"]

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

# Bookkeeping columns of an exported CSV, after the inputs and outputs.
RUN_COLUMNS = ("status", "reason", "elapsed_s", "attempts", "settings_hash",
               "package_version", "created_at", "finished_at")


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


def _package_version() -> str:
    import filmcal

    return filmcal.__version__


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
        raises `FileNotFoundError` (for commands that only read a store).

    Raises
    ------
    FileNotFoundError
        If `create` is False and the file does not exist.
    ValueError
        If the file is not a campaign store (or not an SQLite database), or
        was written with another store schema version.
    """

    def __init__(self, path: str | os.PathLike, *, create: bool = True) -> None:
        self.path = Path(path)
        if not create and not self.path.is_file():
            raise FileNotFoundError(f"campaign store not found: {self.path}")
        self._conn = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
        try:
            self._prepare()
        except sqlite3.DatabaseError as exc:
            self._conn.close()
            raise ValueError(f"{self.path} is not a campaign store ({exc})") from None
        except ValueError:
            self._conn.close()
            raise

    def _prepare(self) -> None:
        conn = self._conn
        conn.execute("PRAGMA journal_mode=WAL")
        # NORMAL in WAL mode: a committed transaction survives a killed
        # process; only a power failure can lose the last ones.
        conn.execute("PRAGMA synchronous=NORMAL")
        conn.execute("PRAGMA foreign_keys=ON")
        tables = {row[0] for row in conn.execute("SELECT name FROM sqlite_master WHERE type='table'")}
        if tables and "store_info" not in tables:
            raise ValueError(f"{self.path} is an SQLite database but not a campaign store")
        if not tables:
            with self._transaction():
                for statement in _SCHEMA.split(";"):
                    conn.execute(statement)
                conn.execute("INSERT OR IGNORE INTO store_info VALUES ('schema_version', ?)", (str(SCHEMA_VERSION),))
        row = conn.execute("SELECT value FROM store_info WHERE key='schema_version'").fetchone()
        if row is None or row[0] != str(SCHEMA_VERSION):
            found = None if row is None else row[0]
            raise ValueError(f"{self.path} has store schema version {found}, expected {SCHEMA_VERSION}")

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
        """Close the database connection."""
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
                       reason: str | None, elapsed_s: float | None) -> None:
        """Store the outcome of one finished run, in its own transaction.

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
        """
        check_choice("status", status, ("ok", "failed"))
        with self._transaction() as conn:
            cursor = conn.execute(
                "UPDATE runs SET status=?, outputs_json=?, reason=?, elapsed_s=?, attempts=attempts+1, "
                "package_version=?, finished_at=? WHERE point_id=?",
                (status, _json_outputs(outputs), reason, elapsed_s, _package_version(), _now(), point_id),
            )
            if cursor.rowcount != 1:
                raise KeyError(f"no run with point_id {point_id} in {self.path}")

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
        with Path(path).open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(header)
            for record in records:
                row = [record.point_id]
                row += [_cell(record.inputs.get(name)) for name in input_names]
                row += [_cell(record.outputs.get(name)) for name in output_names]
                row += [_cell(getattr(record, name)) for name in RUN_COLUMNS]
                writer.writerow(row)
        return len(records)


def _union(mappings: Iterable[Mapping[str, Any]]) -> list[str]:
    """Keys of all mappings, in order of first appearance."""
    names: dict[str, None] = {}
    for mapping in mappings:
        names.update(dict.fromkeys(mapping))
    return list(names)


def _cell(value: Any) -> str:
    """A CSV cell: empty for missing, true/false for booleans, repr for floats."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)
    return str(value)
