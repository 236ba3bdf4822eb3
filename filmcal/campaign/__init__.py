"""Run a design through a model: any model, one writer per store, resume.

The campaign sees a model as a picklable callable ``model(params) -> dict``:
a Python function (``module:function``) or an external command run from a
template (`CommandModel`). Points are evaluated with the package's executor
abstraction (`filmcal._parallel`: serial, local processes, Dask) and every
outcome is committed to an SQLite store (`RunStore`) as soon as it arrives.
A campaign holds the store's lock (`StoreLock`) while it runs.

>>> from filmcal.campaign import Campaign, CommandModel  # doctest: +SKIP
>>> model = CommandModel("python3 sim.py --e {modulus_mpa}", "runs.work", timeout_s=600)  # doctest: +SKIP
>>> Campaign(model, "runs.sqlite", workers=2).run("design.csv", timeout_s=600)  # doctest: +SKIP
>>> load_output_column("runs.sqlite", "contact_radius_mm").input_matrix()  # doctest: +SKIP
"""
from filmcal._parallel import (
    DaskExecutor,
    Executor,
    LocalPoolExecutor,
    SerialExecutor,
    TaskTimeoutError,
    WorkerDiedError,
    call_with_deadline,
    open_executor,
)
from filmcal.campaign.command import CommandModel, ModelFailure
from filmcal.campaign.design import as_design_points, point_id, read_design_csv, settings_hash
from filmcal.campaign.lock import StoreBusyError, StoreLock
from filmcal.campaign.runner import (
    Campaign,
    CampaignResults,
    CampaignSummary,
    PointOutcome,
    evaluate_safely,
    outcome_from_outputs,
)
from filmcal.campaign.store import OutputColumn, RunCounts, RunRecord, RunStore, load_output_column

__all__ = [
    "Campaign",
    "CampaignSummary",
    "CampaignResults",
    "PointOutcome",
    "evaluate_safely",
    "outcome_from_outputs",
    "CommandModel",
    "ModelFailure",
    "RunStore",
    "RunRecord",
    "RunCounts",
    "OutputColumn",
    "load_output_column",
    "StoreLock",
    "StoreBusyError",
    "Executor",
    "SerialExecutor",
    "LocalPoolExecutor",
    "DaskExecutor",
    "open_executor",
    "TaskTimeoutError",
    "WorkerDiedError",
    "call_with_deadline",
    "as_design_points",
    "read_design_csv",
    "point_id",
    "settings_hash",
]
