"""Run a design through a model: executors (in-process, local pool, Dask), SQLite store, resume.

The campaign sees a model only as a picklable callable ``model(params) -> dict``.

>>> from filmcal.campaign import Campaign, LocalPoolExecutor  # doctest: +SKIP
>>> with LocalPoolExecutor(2) as pool:  # doctest: +SKIP
...     Campaign(model, "runs.sqlite", executor=pool).run("design.csv", timeout_s=600)
"""
from filmcal.campaign.design import as_design_points, point_id, read_design_csv, settings_hash
from filmcal.campaign.executors import (
    DaskExecutor,
    PointExecutor,
    SerialExecutor,
    TaskTimeoutError,
    WorkerDiedError,
    call_with_deadline,
)
from filmcal.campaign.pool import LocalPoolExecutor
from filmcal.campaign.runner import (
    Campaign,
    CampaignResults,
    CampaignSummary,
    PointOutcome,
    evaluate_safely,
    outcome_from_outputs,
)
from filmcal.campaign.store import RunCounts, RunRecord, RunStore

__all__ = [
    "Campaign",
    "CampaignSummary",
    "CampaignResults",
    "PointOutcome",
    "evaluate_safely",
    "outcome_from_outputs",
    "RunStore",
    "RunRecord",
    "RunCounts",
    "PointExecutor",
    "SerialExecutor",
    "LocalPoolExecutor",
    "DaskExecutor",
    "TaskTimeoutError",
    "WorkerDiedError",
    "call_with_deadline",
    "as_design_points",
    "read_design_csv",
    "point_id",
    "settings_hash",
]
