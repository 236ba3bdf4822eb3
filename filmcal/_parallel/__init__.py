"""One executor abstraction for every parallel stage: serial, local processes, Dask.

Everything in filmcal that runs independent units of work in parallel (FE
campaign points, pipeline stages per film or per fold, GP optimiser restarts)
goes through this package, so that deadlines, Ctrl-C and killed parents behave
the same way everywhere.

The executors
-------------
All three follow `concurrent.futures` (``submit`` returns a
`concurrent.futures.Future`) with one addition: ``submit`` takes a per-task
deadline ``timeout_s``; a task that runs longer ends with `TaskTimeoutError`
and the executor stays usable.

`SerialExecutor`
    Runs each task at once in the calling thread (debugging, cheap tasks). A
    deadline interrupts Python code with ``SIGALRM`` in the main thread.
`LocalPoolExecutor`
    Local worker processes (``spawn``), one BLAS/OpenMP thread each, so that
    ``n`` workers use ``n`` cores. An overdue task is ended by stopping its
    worker, which is replaced; the others carry on. Workers never outlive the
    parent: on Linux they ask the kernel for a signal when the parent dies
    (``prctl(PR_SET_PDEATHSIG)``), and everywhere a watchdog thread polls the
    parent's pid. Child processes started with `run_guarded` (external
    solvers) are killed with their worker.
`DaskExecutor`
    A Dask distributed cluster given by its scheduler address or a client.
    The address is checked before connecting and the connection is given a
    few seconds, so a wrong address fails fast with a `ValueError`.

Use `open_executor` to build one from command-line style options: it never
starts more processes than there are tasks.

The modules
-----------
`executor` (the contract, outcomes, `SerialExecutor`), `pool`
(`LocalPoolExecutor`), `cluster` (`DaskExecutor`), `work` (`open_executor`,
`SharedPool`, `parallel_work`, `run_tasks`), `guarded` (`run_guarded`: external
commands under a deadline) and `processes` (what a worker process does about
native threads, memory, its parent's death and its children).

Mapping with results as they complete
-------------------------------------
`Executor.map_unordered` submits tasks a bounded window at a time and yields
a `TaskOutcome` as soon as each task finishes, so that the caller can persist
every finished unit at once::

    from filmcal._parallel import open_executor

    with open_executor(workers=4, n_tasks=len(folds)) as executor:
        for outcome in executor.map_unordered(fit_fold, folds, timeout_s=600,
                                              progress=lambda done, total: ...):
            if outcome.ok:
                save(outcome.task, outcome.value)      # persisted right away
            else:
                log(outcome.task, outcome.error)       # TaskTimeoutError, WorkerDiedError, or the task's exception

On Ctrl-C (`KeyboardInterrupt` in the consuming thread) the map cancels the
tasks not started, stops the workers at once (`Executor.abort`) and re-raises:
what was already yielded is kept by the caller, the command exits in well
under 2 s. Tasks (function and arguments) must be picklable for process and
Dask executors: module-level functions, or instances of module-level classes.
"""
from __future__ import annotations

from filmcal._parallel.cluster import DaskExecutor, check_dask_address
from filmcal._parallel.executor import (Executor, SerialExecutor, TaskOutcome, TaskTimeoutError, WorkerDiedError,
                                        call_with_deadline)
from filmcal._parallel.guarded import OUTPUT_CAP_BYTES, GuardedRun, run_guarded, task_cancelled
from filmcal._parallel.pool import LocalPoolExecutor
from filmcal._parallel.processes import (NATIVE_THREAD_VARIABLES, descendant_pids, keep_freed_memory,
                                         limit_native_threads, pid_alive)
from filmcal._parallel.work import SharedPool, open_executor, parallel_work, run_tasks

__all__ = [
    "descendant_pids",
    "pid_alive",
    "TaskTimeoutError",
    "WorkerDiedError",
    "TaskOutcome",
    "Executor",
    "SerialExecutor",
    "LocalPoolExecutor",
    "DaskExecutor",
    "open_executor",
    "SharedPool",
    "parallel_work",
    "run_tasks",
    "check_dask_address",
    "call_with_deadline",
    "limit_native_threads",
    "keep_freed_memory",
    "GuardedRun",
    "run_guarded",
    "OUTPUT_CAP_BYTES",
    "task_cancelled",
    "NATIVE_THREAD_VARIABLES",
]
