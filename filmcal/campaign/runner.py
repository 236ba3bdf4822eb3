"""Run a design through a model into a store: `Campaign`.

The campaign sees the model only as a picklable callable
``model(params: dict) -> dict`` returning scalar outputs (float, int, bool,
str). A run fails, with its reason recorded, when the model raises, runs past
the deadline, returns a non-finite number, or reports ``converged=False``
(then its ``reason`` output is the reason). Running a campaign again resumes
it: finished points are not recomputed, failed ones only on request.

A run holds the store's lock (`StoreLock`) from start to end, so a second
campaign on the same store is refused at once; points are evaluated with the
package's one executor abstraction (`filmcal._parallel`), each outcome stored
as soon as it arrives.
"""
from __future__ import annotations

import functools
import math
import sys
import time
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from tqdm import tqdm

from filmcal._parallel import Executor, TaskOutcome, TaskTimeoutError, open_executor
from filmcal._validation import check_positive
from filmcal.campaign.command import ModelFailure
from filmcal.campaign.design import DesignValue, as_design_points, canonical_json, point_id, settings_hash
from filmcal.campaign.lock import StoreLock
from filmcal.campaign.store import STATUSES, RunCounts, RunRecord, RunStatus, RunStore

__all__ = ["PointOutcome", "evaluate_safely", "outcome_from_outputs", "CampaignSummary", "CampaignResults", "Campaign"]

Model = Callable[[dict[str, DesignValue]], Mapping[str, Any]]
_BACKSTOP_S = 10.0  # extra executor deadline for models that enforce their own


@dataclass(frozen=True)
class PointOutcome:
    """Outcome of one model evaluation.

    Attributes
    ----------
    status : {"ok", "failed"}
    outputs : dict
        Scalar outputs of the model (empty if it raised).
    reason : str or None
        Why the run failed.
    elapsed_s : float or None
        Wall-clock time of the evaluation.
    """

    status: Literal["ok", "failed"]
    outputs: dict[str, Any] = field(default_factory=dict)
    reason: str | None = None
    elapsed_s: float | None = None


def _output_value(value: Any) -> Any:
    """A model output as a plain scalar (bool, int, float, str or None)."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    raise TypeError(f"unsupported output type {type(value).__name__}")


def outcome_from_outputs(raw: Any, elapsed_s: float | None) -> PointOutcome:
    """Classify what a model returned as an ok or a failed run.

    Parameters
    ----------
    raw : object
        The model's return value; expected a mapping of scalar outputs.
    elapsed_s : float or None
        Wall-clock time of the evaluation.

    Returns
    -------
    PointOutcome
        Failed if `raw` is not a mapping, holds ``converged=False`` (reason:
        its ``reason`` output), a non-finite number, or a non-scalar value;
        ok otherwise.
    """
    if not isinstance(raw, Mapping):
        return PointOutcome("failed", {}, f"model returned {type(raw).__name__}, expected a dict of outputs",
                            elapsed_s)
    outputs: dict[str, Any] = {}
    problems: list[str] = []
    for name, value in raw.items():
        try:
            outputs[str(name)] = _output_value(value)
        except TypeError as exc:
            problems.append(f"output {name}: {exc}")
    if outputs.get("converged") is False:
        return PointOutcome("failed", outputs, str(outputs.get("reason") or "model did not converge"), elapsed_s)
    non_finite = [f"{name}={value}" for name, value in outputs.items()
                  if isinstance(value, float) and not math.isfinite(value)]
    if non_finite:
        problems.append(f"non-finite output {', '.join(non_finite)}")
    if problems:
        return PointOutcome("failed", outputs, "; ".join(problems), elapsed_s)
    return PointOutcome("ok", outputs, None, elapsed_s)


def evaluate_safely(model: Model, params: Mapping[str, DesignValue], point_id: str | None = None) -> PointOutcome:
    """Evaluate ``model(params)`` and classify the result; an exception becomes a failed run.

    A `TaskTimeoutError` raised into the model by a deadline passes through, so
    that the executor reports the timeout. A `ModelFailure` becomes a failed
    run whose reason is its message as is.

    Parameters
    ----------
    model : callable
        ``model(params) -> dict`` of scalar outputs; a model whose class sets
        ``takes_point_id = True`` (e.g. `CommandModel`) is called as
        ``model(params, point_id=...)``.
    params : mapping
        The design point (a copy is passed to the model).
    point_id : str, optional
        The point's id in the store.

    Returns
    -------
    PointOutcome
    """
    start = time.perf_counter()
    try:
        if getattr(model, "takes_point_id", False):
            raw = model(dict(params), point_id=point_id)
        else:
            raw = model(dict(params))
    except TaskTimeoutError:
        raise
    except ModelFailure as exc:
        return PointOutcome("failed", {}, str(exc), time.perf_counter() - start)
    except Exception as exc:
        return PointOutcome("failed", {}, f"{type(exc).__name__}: {exc}", time.perf_counter() - start)
    return outcome_from_outputs(raw, time.perf_counter() - start)


def evaluate_point_task(model: Model, item: tuple[str, Mapping[str, DesignValue]]) -> PointOutcome:
    """The task the executor runs for one point: ``item = (point_id, params)``."""
    pid, params = item
    return evaluate_safely(model, params, pid)


def _point_outcome(outcome: TaskOutcome, timeout_s: float | None) -> PointOutcome:
    """A finished task as a run outcome, turning executor errors into failed runs."""
    if outcome.ok:
        return outcome.value
    error = outcome.error
    if isinstance(error, TaskTimeoutError):
        return PointOutcome("failed", {}, str(error), error.timeout_s)
    return PointOutcome("failed", {}, f"{type(error).__name__}: {error}", None)


@dataclass(frozen=True)
class CampaignSummary:
    """What one `Campaign.run` did.

    Attributes
    ----------
    n_points : int
        Distinct points of the design (repeated rows count once).
    n_skipped : int
        Points already finished before the run (ok, or failed and not retried).
    n_run, n_run_ok, n_run_failed : int
        Points evaluated by this run, and how many of them ended ok or failed.
    counts : RunCounts
        Status of the design's points after the run.
    elapsed_s : float
        Wall-clock time of the run.
    """

    n_points: int
    n_skipped: int
    n_run: int
    n_run_ok: int
    n_run_failed: int
    counts: RunCounts
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        """Flat dict: the counts of this run plus ok, failed, pending, total after it."""
        summary = asdict(self)
        del summary["counts"]
        return {**summary, **self.counts.as_dict()}


def _column(values: list[Any]) -> np.ndarray:
    """Values as an array: bool if all are booleans, float (None -> nan) if all are numbers, else object."""
    if values and all(isinstance(v, bool) for v in values):
        return np.array(values, dtype=bool)
    if all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in values):
        return np.array([np.nan if v is None else v for v in values], dtype=float)
    return np.array(values, dtype=object)


@dataclass(frozen=True)
class CampaignResults:
    """Stored runs as arrays, one entry per run.

    Attributes
    ----------
    point_id : ndarray of str
    inputs, outputs : dict of str to ndarray
        One array per input and output name: bool when all values are
        booleans, float when all are numbers (a missing value is nan), object
        otherwise.
    status : ndarray of str
    reason : ndarray of object
        None for runs that did not fail.
    elapsed_s : ndarray of float
    """

    point_id: np.ndarray
    inputs: dict[str, np.ndarray]
    outputs: dict[str, np.ndarray]
    status: np.ndarray
    reason: np.ndarray
    elapsed_s: np.ndarray

    def __len__(self) -> int:
        return len(self.point_id)

    @classmethod
    def from_records(cls, records: list[RunRecord]) -> "CampaignResults":
        """Arrange stored records as arrays."""
        def columns(mappings: list[dict[str, Any]]) -> dict[str, np.ndarray]:
            names = dict.fromkeys(name for mapping in mappings for name in mapping)
            return {name: _column([mapping.get(name) for mapping in mappings]) for name in names}

        return cls(
            point_id=np.array([r.point_id for r in records], dtype=str),
            inputs=columns([r.inputs for r in records]),
            outputs=columns([r.outputs for r in records]),
            status=np.array([r.status for r in records], dtype=str),
            reason=np.array([r.reason for r in records], dtype=object),
            elapsed_s=np.array([np.nan if r.elapsed_s is None else r.elapsed_s for r in records], dtype=float),
        )


def _qualified_name(model: Callable[..., Any]) -> str:
    """``module:qualname`` of a function, or of the class of a callable object."""
    target = model if hasattr(model, "__qualname__") else type(model)
    return f"{getattr(target, '__module__', '?')}:{target.__qualname__}"


def _sort_key(value: DesignValue | None) -> tuple[int, float, str]:
    """Order numbers before strings before missing values."""
    if value is None:
        return (2, 0.0, "")
    if isinstance(value, str):
        return (1, 0.0, value)
    return (0, float(value), "")


def _foreign_file(path: Path) -> bool:
    """True for a file with content that is not SQLite. An empty file, or a store another campaign is creating
    right now, is left to the lock and the store (a concurrent writer is waited for, not refused)."""
    try:
        with open(path, "rb") as fh:
            head = fh.read(16)
    except (FileNotFoundError, IsADirectoryError):
        return False
    return bool(head) and head != b"SQLite format 3\x00"


class Campaign:
    """Evaluate a design through a model, storing every run in an SQLite store.

    Parameters
    ----------
    model : callable
        ``model(params: dict) -> dict`` of scalar outputs, or a `CommandModel`
        (an external command). With a process pool or Dask it must be
        picklable (a module-level function or class instance).
    store_path : path-like
        SQLite file of the runs; created by the first `run`.
    settings : mapping, optional
        JSON-representable model settings that are not design columns but
        change the outputs (mesh options, solver tolerances...). Together with
        `model_name` they form the settings hash: points run with other
        settings are other runs.
    executor : filmcal._parallel.Executor, optional
        Where to evaluate points; used as is and left running. By default
        each `run` opens one from `workers` or `dask` (`open_executor`), never
        with more processes than points to run, and closes it at the end.
    workers : int, optional
        Local worker processes when no executor is given (default: CPUs).
    dask : str, optional
        Dask scheduler address when no executor is given.
    group_by : sequence of str
        Design columns by which points are sorted before they are submitted,
        so that a worker meets points with equal values consecutively and can
        reuse per-value setup (e.g. a mesh per sphere radius).
    model_name : str, optional
        Name of the model in the settings hash; defaults to the model's
        ``model_name`` attribute or its ``module:qualname``.

    Examples
    --------
    >>> campaign = Campaign(model, "runs.sqlite", executor=SerialExecutor())  # doctest: +SKIP
    >>> summary = campaign.run([{"sphere_radius_mm": 450.0, "force_kn": 75.0}])  # doctest: +SKIP
    >>> campaign.status()  # doctest: +SKIP
    RunCounts(ok=1, failed=0, pending=0)
    """

    def __init__(self, model: Model, store_path: str | Path, *, settings: Mapping[str, Any] | None = None,
                 executor: Executor | None = None, workers: int | None = None, dask: Any = None,
                 group_by: Iterable[str] = ("sphere_radius_mm",), model_name: str | None = None) -> None:
        if not callable(model):
            raise ValueError(f"model must be callable, got {type(model).__name__}")
        if executor is not None and not isinstance(executor, Executor):
            raise ValueError(f"executor must be a filmcal._parallel.Executor, got {type(executor).__name__}")
        if executor is not None and (workers is not None or dask is not None):
            raise ValueError("give an executor, or workers/dask to open one, not both")
        if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
            raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
        self.model = model
        self.store_path = Path(store_path)
        self.settings = dict(settings or {})
        self.executor = executor
        self.workers = workers
        self.dask = dask
        self.group_by = tuple(group_by)
        self.model_name = model_name or getattr(model, "model_name", None) or _qualified_name(model)
        self.settings_hash = settings_hash(self.model_name, self.settings)

    def run(self, design: Any, *, retry_failed: bool = False, timeout_s: float | None = None,
            progress: bool | Callable[[int, int], None] = True, lock_command: str | None = None,
            wait_for_lock_s: float = 0.0, on_wait: Callable | None = None) -> CampaignSummary:
        """Evaluate the design points that have no finished run yet.

        The store's lock is held for the whole run: a second campaign on the
        same store is refused at once with `StoreBusyError`.

        Parameters
        ----------
        design : path, list of dicts, dict of columns or structured array
            The design (see `filmcal.campaign.as_design_points`).
        retry_failed : bool
            Evaluate again the points whose last run failed.
        timeout_s : float, optional
            Deadline of each evaluation; a run past it fails with reason
            ``"timeout after <timeout_s> s"``. A model that enforces its own
            deadline (``enforces_timeout = True``, e.g. `CommandModel`) gets
            a few seconds more from the executor as a backstop.
        progress : bool or callable
            True: show a progress bar on stderr (only when stderr is a
            terminal and the run lasts more than a moment). A callable is
            called as ``progress(done, total)`` after each stored point.
        lock_command : str, optional
            What to show a process refused by the lock (default: this
            process's command line).
        wait_for_lock_s : float
            Wait this long for another campaign on the store to finish before refusing (a shared run
            store: the points it finished are then skipped here, not computed twice).
        on_wait : callable, optional
            Called once with the holder (`filmcal.campaign.lock.LockHolder` or None) when this run waits.

        Returns
        -------
        CampaignSummary

        Raises
        ------
        StoreBusyError
            If another process is running a campaign on the store.
        """
        points = as_design_points(design)
        timeout_s = None if timeout_s is None else check_positive("timeout_s", timeout_s)
        start = time.perf_counter()
        unique = {point_id(point, self.settings_hash): point for point in points}
        if _foreign_file(self.store_path):  # refused before its lock file is made
            RunStore(self.store_path, readonly=True).close()  # raises, naming what the file is
        with StoreLock(self.store_path, lock_command, wait_s=wait_for_lock_s, on_wait=on_wait), \
                RunStore(self.store_path) as store:
            store.add_points(unique, self.settings_hash, self._settings_record())
            stored = store.statuses(self.settings_hash)
            wanted = ("pending", "failed") if retry_failed else ("pending",)
            todo = [pid for pid in unique if stored[pid] in wanted]
            todo.sort(key=lambda pid: tuple(_sort_key(unique[pid].get(c)) for c in self.group_by))
            n_ok, n_failed = self._evaluate(store, [(pid, unique[pid]) for pid in todo], timeout_s, progress)
            stored = store.statuses(self.settings_hash)
        return CampaignSummary(
            n_points=len(unique), n_skipped=len(unique) - len(todo), n_run=n_ok + n_failed,
            n_run_ok=n_ok, n_run_failed=n_failed,
            counts=RunCounts.from_statuses(stored[pid] for pid in unique),
            elapsed_s=time.perf_counter() - start,
        )

    def _settings_record(self) -> dict[str, Any]:
        return {"model": self.model_name, "settings": self.settings}

    def _evaluate(self, store: RunStore, todo: list[tuple[str, dict[str, DesignValue]]],
                  timeout_s: float | None, progress: bool | Callable[[int, int], None]) -> tuple[int, int]:
        """Evaluate the points; store each outcome as soon as it arrives."""
        if not todo:
            return 0, 0
        executor = self.executor
        if executor is None:
            executor = open_executor(self.workers, dask=self.dask, n_tasks=len(todo))
        deadline = timeout_s
        if timeout_s is not None and getattr(self.model, "enforces_timeout", False):
            deadline = timeout_s + _BACKSTOP_S
        counts = {"ok": 0, "failed": 0}
        report = progress if callable(progress) else None
        bar = tqdm(total=len(todo), desc="campaign", unit="pt", file=sys.stderr, delay=1.0,
                   disable=report is not None or not (progress and sys.stderr.isatty()))
        finished = False
        try:
            task = functools.partial(evaluate_point_task, self.model)
            for outcome in executor.map_unordered(task, todo, timeout_s=deadline):
                result = _point_outcome(outcome, timeout_s)
                pid = outcome.task[0]
                store.record_outcome(pid, result.status, result.outputs, result.reason, result.elapsed_s)
                counts[result.status] += 1
                bar.update(1)
                bar.set_postfix(failed=counts["failed"], refresh=False)
                if report is not None:
                    report(counts["ok"] + counts["failed"], len(todo))
            finished = True
        finally:
            bar.close()
            if self.executor is None:
                if finished:
                    executor.shutdown(wait=True)
                else:
                    executor.abort()
        return counts["ok"], counts["failed"]

    def _open_store(self) -> RunStore:
        return RunStore(self.store_path, readonly=True)

    def status(self) -> RunCounts:
        """Number of ok, failed and pending runs of this model and settings in the store."""
        with self._open_store() as store:
            return store.counts(self.settings_hash)

    def records(self, status: RunStatus | None = None) -> list[RunRecord]:
        """Stored runs of this model and settings (optionally only those with `status`)."""
        with self._open_store() as store:
            return store.records(self.settings_hash, status)

    def results(self, status: RunStatus | None = "ok") -> CampaignResults:
        """Stored runs of this model and settings as arrays; by default the ok ones.

        Parameters
        ----------
        status : {"ok", "failed", "pending"} or None
            Only runs with this status; None for all.
        """
        if status is not None and status not in STATUSES:
            raise ValueError(f"status must be one of {', '.join(STATUSES)} or None; got {status!r}")
        return CampaignResults.from_records(self.records(status))

    def export_csv(self, path: str | Path) -> int:
        """Write the runs of this model and settings to CSV; return the number of rows.

        See `RunStore.export_csv` for the columns.
        """
        with self._open_store() as store:
            return store.export_csv(path, self.settings_hash)

    def __repr__(self) -> str:
        return (f"Campaign(model={self.model_name}, store_path={str(self.store_path)!r}, "
                f"settings={canonical_json(self.settings)})")
