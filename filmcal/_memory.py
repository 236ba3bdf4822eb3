"""Memory bounds before work: what a run will need against what the machine has now.

Every size a user controls (an FE mesh, a roughness map's pixels, a number of
worker processes) is turned into a `MemoryEstimate` by the stage that knows
its cost (each estimator states its model, fitted to measured peaks:
`filmcal.fem.memory`, `filmcal.contact.roughness.law_memory`, `worker_memory`
below); `check_memory` compares it with `available_bytes` before anything
runs and refuses it in one line that says the limit and why.

Available memory
----------------
`available_bytes` is the kernel's estimate of what can be allocated without
swapping (``MemAvailable`` of ``/proc/meminfo``), lowered to what the
process's control group still allows when that is less: cgroup v2
``memory.max - memory.current`` or v1 ``memory.limit_in_bytes -
memory.usage_in_bytes``, the usage without the reclaimable inactive page cache
(``inactive_file`` of ``memory.stat``). Elsewhere: ``os.sysconf`` physical
pages (total, not free: an upper bound) or, without it, None (no check).

A run may use `USABLE_FRACTION` (80 %) of the available memory: the rest is
the margin for the estimate's error (the estimators are fitted within about
15 %), for other programs and for the page cache.

Worker processes
----------------
`check_workers` caps ``--workers`` at `MAX_WORKERS_PER_CORE` (4) times the
cores this process may run on (more processes than that only share the cores
and multiply the memory), then checks ``workers x`` the resident memory of one
worker process of the command (`worker_memory`, measured), with the parent's, against the available memory.
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from filmcal._errors import InputError

__all__ = ["MemoryEstimate", "available_bytes", "total_bytes", "check_memory", "format_bytes", "usable_bytes",
           "USABLE_FRACTION", "MAX_WORKERS_PER_CORE", "cpu_count", "max_workers", "check_workers", "worker_memory",
           "WORKER_BASE_BYTES", "WORKER_BYTES", "format_seconds"]

#: The share of the available memory a run may plan to use.
USABLE_FRACTION = 0.8
#: Worker processes allowed per core.
MAX_WORKERS_PER_CORE = 4

_GIB = 2.0 ** 30
_CGROUP = Path("/sys/fs/cgroup")


@dataclass(frozen=True)
class MemoryEstimate:
    """A run's estimated peak memory.

    Attributes
    ----------
    bytes : float
        Estimated peak resident memory of the run (bytes).
    what : str
        What needs it, for the message (e.g. ``"FE: 27018 film unknowns, dense film stiffness"``).
    model : str
        How the number was derived (the fitted model, for the docs and the bench).
    seconds : float, optional
        Estimated run time where it is known (said in the message).
    """

    bytes: float
    what: str
    model: str = ""
    seconds: float | None = None

    @property
    def gib(self) -> float:
        return self.bytes / _GIB


def format_bytes(n: float) -> str:
    """``6.1 GiB``, ``850 MiB``: the unit the messages use."""
    if n >= 0.95 * _GIB:
        return f"{n / _GIB:.2g} GiB" if n < 10 * _GIB else f"{n / _GIB:.0f} GiB"
    return f"{n / 2**20:.0f} MiB"


def format_seconds(s: float) -> str:
    """``40 s``, ``12 min``, ``3.5 h``."""
    if s < 120:
        return f"{s:.0f} s"
    if s < 7200:
        return f"{s / 60:.0f} min"
    return f"{s / 3600:.1f} h"


def _read_int(path: Path) -> int | None:
    try:
        text = path.read_text().strip()
    except (OSError, ValueError):
        return None
    if text == "max":
        return None
    try:
        return int(text)
    except ValueError:
        return None


def _inactive_file(stat: Path, key: str) -> int:
    try:
        for line in stat.read_text().splitlines():
            name, _, value = line.partition(" ")
            if name == key:
                return int(value)
    except (OSError, ValueError):
        pass
    return 0


def _cgroup_dirs() -> list[tuple[Path, int]]:
    """(folder, version) of this process's memory control group: the mount's root and the path of
    /proc/self/cgroup under it (in a container both are the same group)."""
    out: list[tuple[Path, int]] = []
    try:
        lines = Path("/proc/self/cgroup").read_text().splitlines()
    except OSError:
        lines = []
    for line in lines:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, rel = parts
        rel = rel.lstrip("/")
        if controllers == "":  # v2 unified
            out += [(_CGROUP / rel, 2), (_CGROUP, 2)]
        elif "memory" in controllers.split(","):
            out += [(_CGROUP / "memory" / rel, 1), (_CGROUP / "memory", 1)]
    return out


def cgroup_free_bytes() -> int | None:
    """What the memory control group still allows (limit - usage without inactive page cache); None: no limit."""
    best: int | None = None
    for folder, version in _cgroup_dirs():
        if version == 2:
            limit, usage = _read_int(folder / "memory.max"), _read_int(folder / "memory.current")
            cache = _inactive_file(folder / "memory.stat", "inactive_file")
        else:
            limit, usage = _read_int(folder / "memory.limit_in_bytes"), _read_int(folder / "memory.usage_in_bytes")
            cache = _inactive_file(folder / "memory.stat", "total_inactive_file")
        if limit is None or usage is None or limit >= 2**60:  # no limit ("max", or v1's huge number)
            continue
        free = max(0, limit - max(0, usage - cache))
        best = free if best is None else min(best, free)
    return best


def _meminfo() -> dict[str, int]:
    out: dict[str, int] = {}
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                name, _, rest = line.partition(":")
                fields = rest.split()
                if fields and fields[0].isdigit():
                    out[name] = int(fields[0]) * (1024 if fields[1:2] == ["kB"] else 1)
    except OSError:
        pass
    return out


def total_bytes() -> int | None:
    """The machine's memory (or its control group's limit when lower), bytes; None when unknown."""
    total = _meminfo().get("MemTotal")
    if total is None:
        try:
            total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (AttributeError, ValueError, OSError):
            total = None
    for folder, version in _cgroup_dirs():
        limit = _read_int(folder / ("memory.max" if version == 2 else "memory.limit_in_bytes"))
        if limit is not None and limit < 2**60:
            total = limit if total is None else min(total, limit)
    return total


def available_bytes() -> int | None:
    """Memory a new allocation can take now without swapping (bytes); None when unknown (no check then).

    ``MemAvailable`` (Linux), lowered to the control group's free memory when that is less; elsewhere
    the physical memory from ``os.sysconf`` (an upper bound)."""
    info = _meminfo()
    avail = info.get("MemAvailable")
    if avail is None and "MemFree" in info:  # kernels before 3.14
        avail = info["MemFree"] + info.get("Cached", 0)
    if avail is None:
        try:
            avail = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
        except (AttributeError, ValueError, OSError):
            avail = None
    group = cgroup_free_bytes()
    if group is not None:
        avail = group if avail is None else min(avail, group)
    return avail


def usable_bytes(available: int | None = None) -> float | None:
    """`USABLE_FRACTION` of the available memory (bytes); None when unknown."""
    avail = available_bytes() if available is None else available
    return None if avail is None else USABLE_FRACTION * avail


def check_memory(estimate: MemoryEstimate, options: str, advice: str) -> MemoryEstimate:
    """Refuse a run whose estimated peak exceeds `USABLE_FRACTION` of the memory available now.

    Parameters
    ----------
    estimate : MemoryEstimate
    options : str
        The options and values that set the size, as the user wrote them (``"--element-size-mm 0.02 with
        --film-layers 8"``): the message starts with them.
    advice : str
        What to change (``"use a coarser mesh or fewer layers"``).

    Returns
    -------
    MemoryEstimate
        The estimate, when it fits.

    Raises
    ------
    InputError
        One line: the options, the estimate and what needs it, the available memory and the machine's, the
        fraction allowed, the advice.
    """
    avail = available_bytes()
    if avail is None or estimate.bytes <= USABLE_FRACTION * avail:
        return estimate
    total = total_bytes()
    of = f" of {format_bytes(total)}" if total else ""
    took = f", about {format_seconds(estimate.seconds)} of work" if estimate.seconds else ""
    raise InputError(
        f"{options} needs about {format_bytes(estimate.bytes)} ({estimate.what}{took}), more than the "
        f"{format_bytes(USABLE_FRACTION * avail)} a run may use now ({USABLE_FRACTION:.0%} of the "
        f"{format_bytes(avail)} available{of}): {advice}")


# --- worker processes ---------------------------------------------------------------------------------

def cpu_count() -> int:
    """Cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def max_workers() -> int:
    """The most worker processes allowed: `MAX_WORKERS_PER_CORE` per core."""
    return MAX_WORKERS_PER_CORE * cpu_count()


#: Peak resident memory (bytes) of one worker process, and of the parent process, of each command that
#: runs local workers: measured (``python bench/memory.py --workers``: the peak RSS of every process of the
#: command's tree, polled) and rounded up. A worker's memory grows with the tasks it has run (glibc keeps
#: up to 256 MB of freed heap, `filmcal._parallel.keep_freed_memory`, and the FE model keeps its last 8
#: models): these are the values after about ten tasks each. campaign: FE points at the paper's mesh
#: (0.1 mm, 2 layers; 8 workers on 96 points: 448-526 MiB each); calibrate: FE points, GP fits and chains
#: (404 MiB); pipeline: every stage, with the rough wheel's boundary-element laws (585 MiB); curves:
#: wheel-rail solves with synthetic roughness laws (273 MiB).
WORKER_BYTES: dict[str, tuple[float, float]] = {  # command: (per worker, parent)
    "campaign": (480 * 2**20, 80 * 2**20),
    "calibrate": (420 * 2**20, 250 * 2**20),
    "pipeline": (600 * 2**20, 560 * 2**20),
    "curves": (300 * 2**20, 300 * 2**20),
}
#: A spawned worker that has imported numpy and scipy and run little (commands not in `WORKER_BYTES`).
WORKER_BASE_BYTES = 120 * 2**20


def worker_memory(command: str) -> tuple[float, float]:
    """(peak memory of one worker process, of the parent process) of `command` (bytes, measured:
    `WORKER_BYTES`)."""
    return WORKER_BYTES.get(command, (WORKER_BASE_BYTES, WORKER_BASE_BYTES))


def check_workers(workers: int | None, option: str = "--workers", command: str = "",
                  per_worker_bytes: float | None = None, parent_bytes: float | None = None,
                  processes: bool = True, what: str = "", memory: bool = True) -> int | None:
    """Check a number of worker processes before any work; return it.

    ``None`` is the commands' default, one per core. More than `max_workers` (4 per core) is refused; so is a
    number whose workers (`worker_memory` of `command`, or `per_worker_bytes`) with the parent process
    (`parent_bytes`) need more than `USABLE_FRACTION` of the available memory. With ``processes=False``
    (threads of one process), or ``memory=False`` (the caller checks the workers' memory itself), only the
    core cap applies. `what` says what each worker holds (the message).

    Raises
    ------
    InputError
        Naming `option`, the limit and why.
    """
    cores = cpu_count()
    n = cores if workers is None else int(workers)
    given = f"{option} {n}" + (" (the default: one per core)" if workers is None else "")
    cap = max_workers()
    if n > cap:
        raise InputError(f"{option} {n}: this machine has {cores} core{'s' if cores != 1 else ''}; at most {cap} "
                         f"({MAX_WORKERS_PER_CORE} per core: more {'processes' if processes else 'threads'} only "
                         "share the cores" + (" and multiply the memory)" if processes else ")"))
    if not processes or not memory or n <= 1:
        return workers
    each, parent = worker_memory(command)
    each = each if per_worker_bytes is None else float(per_worker_bytes)
    parent_bytes = parent if parent_bytes is None else float(parent_bytes)
    need = n * each + parent_bytes
    avail = available_bytes()
    if avail is not None and need > USABLE_FRACTION * avail:
        fits = max(1, int(math.floor((USABLE_FRACTION * avail - parent_bytes) / each)))
        check_memory(MemoryEstimate(need, f"{n} worker processes of about {format_bytes(each)} each{what}"),
                     given, f"use at most {option} {fits}")
    return workers
