"""`filmcal campaign`: run a design through a model into an SQLite store.

``run`` evaluates every design point that has no finished run yet (a second
``run`` resumes an interrupted one) with the FE model, a Python model
(``--simulator-python module:function``) or any external command (``--simulator-command``);
``status`` counts the runs, ``export`` writes them to CSV. One ``run`` writes
to a store at a time: a second one is refused at once (exit 2) with a line
that says who holds the store.
"""
from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any, Callable

from filmcal._validation import check_choice, check_poisson, check_positive, check_range
from filmcal.commands._common import print_json
from filmcal.commands._options import VOCABULARY, add, local, renamed
from filmcal.contact.names import KINEMATICS

DEFAULT_MODEL = "filmcal.fem:evaluate_point"
REQUIRED_COLUMNS = ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn")
CONTACT_CHOICES = ("frictionless", "tied", "friction")


def _contact(name: str, value: Any) -> str:
    return check_choice(name, str(value), CONTACT_CHOICES)


def _flag(name: str, value: Any) -> bool:
    if isinstance(value, bool):
        return value
    if value in (0.0, 1.0):
        return bool(value)
    raise ValueError(f"{name} must be true or false, got {value!r}")


def _friction(name: str, value: Any) -> float:
    return check_range(name, value, 0.0, float("inf"), low_open=False)


def _within(concept: str) -> Callable[[str, Any], float]:
    """The check of a column that is a concept of the command line: the bounds its option has."""
    low, high = VOCABULARY[concept].bounds

    def check(name: str, value: Any) -> float:
        return check_range(name, value, low, high, low_open=False, high_open=False)

    return check


def _sphere_radius(name: str, value: Any) -> float:
    """A sphere the FE body takes (`filmcal fem`'s bounds and its body's smallest sphere)."""
    from filmcal.fem.mesh import MIN_SPHERE_TO_BODY, MeshSettings

    radius = _within("sphere_radius_mm")(name, value)
    smallest = round(MIN_SPHERE_TO_BODY * MeshSettings().body_size_mm, 9)
    if radius < smallest:
        raise ValueError(f"{name} must be at least {smallest:g} mm ({MIN_SPHERE_TO_BODY:g} times the FE body's "
                         f"size), got {radius:g}")
    return radius


# Design columns of the FE model and how each is checked, with the bounds `filmcal fem` gives its options; the
# values go to `evaluate_point` unchanged (forces stay in kN, as in the design).
COLUMN_CHECKS: dict[str, Callable[[str, Any], Any]] = {
    "modulus_mpa": _within("film_modulus_mpa"),
    "poisson": check_poisson,
    "sphere_radius_mm": _sphere_radius,
    "force_kn": _within("force_kn"),
    "sphere_contact": _contact,
    "flat_contact": _contact,
    "friction_coefficient": _friction,
    "kinematics": lambda name, value: check_choice(name, str(value), KINEMATICS),
    "element_size_mm": lambda name, value: check_range(name, value, 0.0, 1.0, high_open=False),  # MeshSettings
    "no_film": _flag,
    "film_thickness_mm": _within("film_thickness_mm"),
    "activation_pressure_mpa": check_positive,
}
# The FE model builds its meshes once per (radius, element size, film
# thickness) in each worker: submit points sorted by these.
FE_SETUP_COLUMNS = ("sphere_radius_mm", "element_size_mm", "film_thickness_mm")


def check_fe_design(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Check design points against the FE model's columns; return them with checked values.

    Raises
    ------
    ValueError
        A required column is missing, a column is unknown, or a value is out
        of range or of the wrong kind (the message names the column and row).
    """
    columns = dict.fromkeys(name for point in points for name in point)
    unknown = [name for name in columns if name not in COLUMN_CHECKS]
    if unknown:
        raise ValueError(f"unknown design column(s) {', '.join(unknown)}; allowed: {', '.join(COLUMN_CHECKS)}")
    checked = []
    for row, point in enumerate(points, start=1):
        missing = [name for name in REQUIRED_COLUMNS if name not in point]
        if missing:
            raise ValueError(f"design row {row} lacks column(s) {', '.join(missing)} "
                             f"(required: {', '.join(REQUIRED_COLUMNS)})")
        try:
            checked.append({name: COLUMN_CHECKS[name](name, value) for name, value in point.items()})
        except ValueError as exc:
            raise ValueError(f"{exc} (design row {row})") from None
    return checked


def design_memory(points: list[dict[str, Any]], workers: int | None):
    """The FE design's memory: ``(largest point's estimate, its row, (radius, element size), workers' estimate,
    number of worker processes)``.

    Each point's FE model is estimated from its mesh settings (`filmcal.fem.memory.fe_memory`: the finest
    ``element_size_mm`` at the largest ``sphere_radius_mm`` of each kind of point); a worker process runs
    ``points / workers`` of them and keeps what `filmcal.fem.memory.fe_worker_memory` says; the workers (at most
    one per point) and the parent (`filmcal._memory.WORKER_BYTES`) together give the workers' estimate.
    """
    from filmcal._memory import MemoryEstimate, cpu_count, format_bytes, worker_memory
    from filmcal.fem import MeshSettings
    from filmcal.fem.memory import fe_memory, fe_sizes, fe_worker_memory
    from filmcal.fem.mesh import FILM_LAYERS

    worst: dict[tuple, tuple[float, int]] = {}  # kind of point -> (largest radius, its row)
    setups = set()
    for row, point in enumerate(points, start=1):
        h = float(point.get("element_size_mm") or 0.1)
        kind = (h, not point.get("no_film", False), str(point.get("kinematics") or "small"),
                str(point.get("sphere_contact") or "frictionless"), str(point.get("flat_contact") or "tied"))
        radius = float(point["sphere_radius_mm"])
        setups.add((radius, h, point.get("film_thickness_mm")))
        if kind not in worst or radius > worst[kind][0]:
            worst[kind] = (radius, row)
    largest = None
    for kind, (radius, row) in worst.items():
        estimate = fe_memory(radius, MeshSettings(element_size_mm=kind[0]), FILM_LAYERS, *kind[1:])
        if largest is None or estimate.bytes > largest[0].bytes:
            largest = (estimate, row, (radius, kind[0]))
    estimate, row, key = largest
    n = max(1, min(cpu_count() if workers is None else int(workers), len(points)))
    each = fe_worker_memory(-(-len(points) // n), estimate, fe_sizes(key[0], MeshSettings(element_size_mm=key[1]),
                                                                      FILM_LAYERS), len(setups))
    parent = worker_memory("campaign")[1]
    total = MemoryEstimate(n * each + parent, f"{n} worker processes with FE models of up to {format_bytes(each)} "
                                              "each", "filmcal.fem.memory.fe_worker_memory")
    return estimate, row, key, total, n


def check_design_memory(points: list[dict[str, Any]], workers: int | None) -> None:
    """Refuse, before any work, an FE design whose points, or whose worker processes, do not fit in the memory
    available now (`design_memory`).

    Raises
    ------
    filmcal._errors.InputError
        Naming the design row or --workers, the estimate and what to change.
    """
    from filmcal._memory import check_memory, usable_bytes

    if not points:
        return
    estimate, row, key, total, n = design_memory(points, workers)
    check_memory(estimate, f"--design row {row} (element_size_mm {key[1]:g}, sphere_radius_mm {key[0]:g})",
                 "use a coarser element_size_mm (a larger element size) in the design")
    usable = usable_bytes()
    if n > 1 and usable is not None and total.bytes > usable:
        each = (total.bytes - _parent_bytes()) / n
        fits = max(1, int((usable - _parent_bytes()) // each))
        given = "--workers " + (str(workers) if workers is not None else f"{n} (the default: one per core)")
        check_memory(total, given, f"use at most --workers {fits}, or a coarser element_size_mm in the design")


def _parent_bytes() -> float:
    from filmcal._memory import worker_memory

    return worker_memory("campaign")[1]


def default_work_dir(store: str | Path) -> Path:
    """Working folders of an external command: ``<store stem>.work`` beside the store."""
    store = Path(store)
    return store.with_name(store.stem + ".work")


def _lock_command(args: argparse.Namespace) -> str:
    """The holder's command as shown to a campaign refused by the store lock."""
    words = ["filmcal", "campaign", "run", "--design", str(args.design), "--store", str(args.store)]
    if args.simulator_command is not None:
        words += ["--simulator-command", args.simulator_command]
    elif args.simulator_python != DEFAULT_MODEL:
        words += ["--simulator-python", args.simulator_python]
    return " ".join(shlex.quote(word) for word in words)


#: Design columns of the FE model renamed in this release (old -> new), read for one release more.
RENAMED_COLUMNS = {"radius_mm": "sphere_radius_mm", "large_strain": "kinematics"}


def _renamed_columns(points: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Design points with old column names renamed (one note line per old name)."""
    old = {name for point in points for name in point if name in RENAMED_COLUMNS}
    for name in sorted(old):
        sys.stderr.write(f"filmcal campaign run: note: design column {name} is renamed {RENAMED_COLUMNS[name]}; "
                         "the old name goes in the next release\n")
    def value(name: str, v: Any) -> Any:
        if name == "large_strain":  # true/false -> large/small
            return "large" if _flag(name, v) else "small"
        return v

    return [{RENAMED_COLUMNS.get(k, k): value(k, v) for k, v in point.items()} for point in points]


def _run(args: argparse.Namespace) -> int:
    from filmcal._errors import InputError
    from filmcal._io import check_output_dir
    from filmcal._parallel import DaskExecutor, check_dask_address
    from filmcal._progress import Progress
    from filmcal.campaign import Campaign, CommandModel, read_design_csv
    from filmcal.campaign.simulator import import_model

    # every option is checked, and the Dask scheduler reached, before any
    # work and before any file is written
    if args.dask is not None:
        args.dask = check_dask_address(args.dask)
    if args.template_file and args.simulator_command is None:
        raise InputError("--template-file needs --simulator-command")
    if args.work_dir is not None and args.simulator_command is None:
        raise InputError("--work-dir needs --simulator-command")
    points = read_design_csv(args.design)
    if args.simulator_command is None and args.simulator_python == DEFAULT_MODEL:
        points = _renamed_columns(points)
    if args.simulator_command is not None:
        work_dir = Path(args.work_dir) if args.work_dir else default_work_dir(args.store)
        check_output_dir(work_dir, "--work-dir")
        model = CommandModel.from_files(args.simulator_command, work_dir, args.template_file or (), args.timeout_s)
        model.check_design(points)
        settings, group_by, model_name = model.settings(), (), None
    else:
        group_by = ()
        if args.simulator_python == DEFAULT_MODEL:
            points = check_fe_design(points)
            group_by = FE_SETUP_COLUMNS
            if args.dask is None:
                check_design_memory(points, args.workers)
        model = import_model(args.simulator_python)
        settings, model_name = None, args.simulator_python
    executor = DaskExecutor(args.dask) if args.dask is not None else None
    try:
        campaign = Campaign(model, args.store, settings=settings, executor=executor,
                            workers=None if executor is not None else args.workers,
                            group_by=group_by, model_name=model_name)
        with Progress(args.progress).stage("campaign") as stage:
            def advance(done: int, total: int) -> None:
                stage.set_total(total)
                stage.advance()

            summary = campaign.run(points, retry_failed=args.retry_failed, timeout_s=args.timeout_s,
                                   progress=advance, lock_command=_lock_command(args))
    except BaseException:
        if executor is not None:
            executor.abort()
        raise
    if executor is not None:
        executor.shutdown()
    if args.json:
        print_json({"store": str(args.store), "settings_hash": campaign.settings_hash, **summary.as_dict()})
    else:
        counts = summary.counts
        print(f"{summary.n_points} points: {counts.ok} ok, {counts.failed} failed, {counts.pending} pending "
              f"(ran {summary.n_run} in {summary.elapsed_s:.1f} s, {summary.n_skipped} already done) "
              f"-> {args.store}")
    if summary.n_run and not summary.n_run_ok and not summary.counts.ok:
        failed = campaign.records(status="failed")
        reason = (failed[0].reason if failed else None) or "no reason recorded"
        print(f"filmcal campaign run: every point failed (the first: {reason});"
              " fix the simulator and rerun with --retry-failed", file=sys.stderr)
        return 1
    return 0


def _status(args: argparse.Namespace) -> int:
    from dataclasses import asdict

    from filmcal.campaign import RunStore, StoreLock

    with RunStore(args.store, readonly=True) as store:
        counts = store.counts()
    holder = StoreLock(args.store).running_holder()
    if args.json:
        print_json({**counts.as_dict(), "running": None if holder is None else asdict(holder)})
    else:
        running = "" if holder is None else f"; a campaign is running: {holder.describe()}"
        print(f"{args.store}: {counts.ok} ok, {counts.failed} failed, {counts.pending} pending "
              f"({counts.total} total){running}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from filmcal._io import check_distinct_files
    from filmcal.campaign import RunStore

    check_distinct_files((args.store, "--store"), (args.out, "--out"))
    with RunStore(args.store, readonly=True) as store:
        n_rows = store.export_csv(args.out)
    if args.json:
        print_json({"out": str(args.out), "rows": n_rows})
    else:
        print(f"wrote {n_rows} runs to {args.out}")
    return 0


ACTIONS = {"run": _run, "status": _status, "export": _export}


def run(args: argparse.Namespace) -> int:
    """Carry out the chosen campaign action; return the exit status."""
    return ACTIONS[args.action](args)


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Register ``filmcal campaign`` and its actions run, status and export."""
    parser = subparsers.add_parser(
        "campaign",
        help="run a design through the FE model into an SQLite store (resumable)",
        description="Evaluate a design (CSV: modulus_mpa, poisson, sphere_radius_mm, force_kn, plus optional FE "
                    "options) with the FE model, in parallel, storing one row per point in SQLite. "
                    "Running again resumes: finished points are not recomputed.",
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    run_parser = actions.add_parser(
        "run", help="evaluate the design points that have no finished run yet",
        description="Evaluate every design point without a finished run in the store, with the FE model "
                    f"(design columns {', '.join(REQUIRED_COLUMNS)}, force in kN; optional "
                    f"{', '.join(name for name in COLUMN_CHECKS if name not in REQUIRED_COLUMNS)}), "
                    "a Python model (--simulator-python) or an external command (--simulator-command: a shell "
                    "command template "
                    "with {column} placeholders, run in a fresh folder per point, printing one JSON object "
                    "whose numeric values are the outputs, or writing outputs.json). A point whose model "
                    "raises, does not converge, exits non-zero, prints no JSON, returns NaN or runs past "
                    "--timeout-s is stored as failed with its reason. One run writes to a store at a time: "
                    "a second is refused (exit 2).",
    )
    local(run_parser, "--design", required=True, help="design CSV file (e.g. from `filmcal doe --out`)")
    local(run_parser, "--store", required=True, help="SQLite store of the runs (created if missing)")
    where = run_parser.add_mutually_exclusive_group()
    add(where, "workers", extra="(default: number of CPUs; never more than points to run)")
    add(where, "dask")
    local(run_parser, "--timeout-s", type=float, metavar="T",
          help="deadline of each point in seconds; a point past it fails with 'timeout after T s' "
               "(an external command's process group is killed)")
    local(run_parser, "--retry-failed", action="store_true", help="evaluate again the points that failed")
    model = run_parser.add_mutually_exclusive_group()
    add(model, "simulator_python", default=DEFAULT_MODEL, extra=f"(default: {DEFAULT_MODEL}, the FE model)")
    add(model, "simulator_command", extra="; e.g. 'python3 sim.py --e {modulus_mpa} --r {sphere_radius_mm}'; "
                                          "values are shell-quoted, so do not quote placeholders")
    local(run_parser, "--template-file", action="append", metavar="FILE",
          help="input file template rendered into each point's folder ({column} placeholders; "
               "NAME.tmpl is written as NAME); repeat for several files")
    local(run_parser, "--work-dir", metavar="DIR",
          help="folder of the per-point working folders of --simulator-command "
               "(default: <store name without suffix>.work beside the store)")
    add(run_parser, "progress", default="auto")
    add(run_parser, "json", action="store_true")
    renamed(run_parser, "--model", "--simulator-python")
    renamed(run_parser, "--command", "--simulator-command")
    renamed(run_parser, "--no-progress", "--progress quiet", "progress", flag_value="quiet")

    status_parser = actions.add_parser(
        "status", help="count the ok, failed and pending runs of a store",
        description="Count the runs of a store by status (ok, failed, pending) and in total, and say which "
                    "campaign is running on it, if any (JSON key running: pid, host, command, started_at). "
                    "Reading never changes the store.",
    )
    local(status_parser, "--store", required=True, help="SQLite store of the runs")
    add(status_parser, "json", action="store_true", help="print the counts as one JSON object")

    export_parser = actions.add_parser(
        "export", help="write the runs of a store to CSV",
        description="Write one CSV row per run: point_id, inputs, outputs, status, reason, elapsed_s, "
                    "attempts, settings_hash, package_version, created_at, finished_at.",
    )
    local(export_parser, "--store", required=True, help="SQLite store of the runs")
    local(export_parser, "--out", required=True, help="CSV file to write")
    add(export_parser, "json", action="store_true", help="print the file name and row count as JSON")

    parser.set_defaults(func=run)
    return parser
