"""Memory bounds before work: estimated against measured peak memory at the largest allowed settings.

Every size a user controls is checked before anything runs against an estimate of the run's peak memory
(`filmcal._memory`; the FE mesh: `filmcal.fem.memory`, a roughness map's boundary-element laws:
`filmcal.contact.roughness.rough_law_cost`, worker processes: `filmcal._memory.WORKER_BYTES`). This bench
runs the command line in a subprocess at the largest settings the checks allow on this machine and prints,
for each, the estimate, the measured peak (the subprocess's peak RSS from ``wait4``; for worker processes
the largest sum of the RSS of the command's whole process tree, polled every 0.1 s), their ratio (target:
within 30 %), and the machine's memory.

By default the bench runs every setting the checks allow on this machine now (on 24 GiB: the FE at 0.02 mm
with 8 film layers up to R 2419 mm, estimated 18.2 GiB, measured 16.9 GiB in 112 s). A setting whose
estimate exceeds ``--max-gib`` or whose estimated time exceeds ``--max-s`` (default 180 s) is not run: the
bench says so and runs the largest setting within the budget instead.

* ``fem``: the corner of the bounds (0.02 mm, 8 film layers, R 100000 mm), the largest radius allowed at
  0.02 mm / 8 layers, the largest within the budget, and points across element size, layers, radius and
  kinematics;
* ``maps``: ``wheelrail --wheel-roughness-map`` at the pixel cap (2048 x 2048), with and without a film,
  a map just above the cap (refused), the largest film case within the time budget, and what 1 and 8 draws of
  a 1024 x 1024 map hold (they share its split: before 29 Nov 2026 each held its own, 16 against 128 MiB);
* ``workers``: ``campaign run --workers`` at the cap (4 per core) and at 2, on designs of 12 default-mesh
  points per worker (4 with ``--quick``; the campaign's estimate, `filmcal.commands.campaign.design_memory`),
  and one worker more than the cap (refused).

Run: ``python bench/memory.py [--quick] [--only fem|maps|workers] [--max-gib GIB] [--max-s 180]``
(``--quick``: smaller settings and at most 4 GiB, about a minute).
"""
from __future__ import annotations

import argparse
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from filmcal import _memory
from filmcal.contact.roughness import rough_law_cost
from filmcal.contact.surface_files import MAX_MAP_PIXELS
from filmcal.fem import MeshSettings
from filmcal.fem.memory import fe_memory

GIB = 2.0**30
FILMCAL = [sys.executable, "-m", "filmcal.cli"]
ROWS: list[tuple] = []


def _load() -> str:
    try:
        return "load %.2f %.2f %.2f" % os.getloadavg()
    except OSError:
        return "load n/a"


def peak_of(argv: list[str], tree: bool = False, env: dict | None = None) -> tuple[int, float, int, str]:
    """Run `argv`; return (exit status, wall s, peak bytes, last stderr line). ``tree``: the largest sum of the
    RSS of the process and all its descendants (polled), else the process's own peak RSS (``wait4``)."""
    t0 = time.perf_counter()
    with tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=err, env=env)
        total_peak = 0
        while True:  # wait4 (not Popen.poll) reaps the child: its rusage holds the peak RSS
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG if tree else 0)
            if pid:
                break
            total_peak = max(total_peak, _tree_rss(proc.pid))
            time.sleep(0.1)
        proc.returncode = os.waitstatus_to_exitcode(status)
        err.seek(0)
        lines = [line for line in err.read().decode(errors="replace").splitlines() if line.strip()]
    peak = total_peak if tree else usage.ru_maxrss * 1024
    return proc.returncode, time.perf_counter() - t0, peak, lines[-1] if lines else ""


def _tree_rss(pid: int) -> int:
    total, stack = 0, [pid]
    while stack:
        p = stack.pop()
        try:
            with open(f"/proc/{p}/status") as fh:
                total += next(int(line.split()[1]) for line in fh if line.startswith("VmRSS")) * 1024
            for task in os.listdir(f"/proc/{p}/task"):
                with open(f"/proc/{p}/task/{task}/children") as fh:
                    stack += [int(x) for x in fh.read().split()]
        except (OSError, StopIteration):
            continue
    return total


def row(case: str, estimate: float, measured: float | None, seconds: float | None, est_seconds: float | None,
        note: str = "") -> None:
    ratio = f"{measured / estimate:6.2f}" if measured else "     -"
    meas = f"{measured / GIB:8.2f}" if measured else "       -"
    secs = f"{seconds:6.0f}" if seconds is not None else "     -"
    est_s = f"{est_seconds:6.0f}" if est_seconds else "     -"
    ROWS.append((case, estimate, measured))
    print(f"{case:<58} {estimate / GIB:8.2f} {meas} {ratio} {est_s} {secs}  {note}", flush=True)


def header(title: str) -> None:
    print(f"\n{title} ({_load()})")
    print(f"{'case':<58} {'est GiB':>8} {'meas GiB':>8} {'m/est':>6} {'est s':>6} {'wall s':>6}  note")


# --- FE --------------------------------------------------------------------------------------------------

def fem_args(radius: float, h: float, layers: int, film: bool = True, kinematics: str = "small") -> list[str]:
    force = 75 if radius <= 1000 else 5  # the contact inside the refined zone
    return [*FILMCAL, "fem", "--json", "--sphere-radius-mm", f"{radius:g}", "--force-kn", str(force),
            "--element-size-mm", f"{h:g}", "--film-layers", str(layers), "--kinematics", kinematics,
            *(["--film-modulus-mpa", "2800"] if film else ["--no-film"])]


def fe_estimate(radius: float, h: float, layers: int, film: bool = True, kinematics: str = "small") -> float:
    return fe_memory(radius, MeshSettings(element_size_mm=h), layers, film, kinematics).bytes


def largest_radius(h: float, layers: int, limit: float) -> float:
    """The largest sphere radius (50-100000 mm) whose FE estimate at (h, layers) is at most `limit` bytes."""
    lo, hi = 50.0, 1e5
    if fe_estimate(hi, h, layers) <= limit:
        return hi
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if fe_estimate(mid, h, layers) <= limit else (lo, mid)
    return math.floor(lo)


def measure_fem(case: str, radius: float, h: float, layers: int, film: bool = True, kinematics: str = "small",
                budget: float = 8 * GIB) -> None:
    estimate = fe_estimate(radius, h, layers, film, kinematics)
    if estimate > budget:
        row(case, estimate, None, None, None, f"not run: above this bench's {budget / GIB:g} GiB budget")
        return
    code, wall, peak, last = peak_of(fem_args(radius, h, layers, film, kinematics))
    row(case, estimate, peak, wall, None, "" if code in (0, 1) else f"exit {code}: {last[-120:]}")


def fem_section(quick: bool, budget: float) -> None:
    header("filmcal fem: estimate (filmcal.fem.memory) against the peak RSS of the command")
    usable = _memory.usable_bytes()
    corner = fe_estimate(1e5, 0.02, 8)
    code, _, _, line = peak_of(fem_args(1e5, 0.02, 8))
    row("0.02 mm, 8 layers, R 100000 (the bounds' corner)", corner, None, None, None,
        "refused: exit 2" if code == 2 else f"allowed here (exit {code})")
    if code == 2:
        print(f"    {line}")
    r_allowed = largest_radius(0.02, 8, usable)
    r_budget = largest_radius(0.02, 8, min(usable, budget))
    measure_fem(f"0.02 mm, 8 layers, R {r_allowed:g} (largest R allowed here)", r_allowed, 0.02, 8, budget=budget)
    if quick:
        points = [(450, 0.05, 8, True, "small"), (1e5, 0.1, 8, True, "small")]
    else:
        if r_budget < r_allowed:
            measure_fem(f"0.02 mm, 8 layers, R {r_budget:g} (largest within the budget)", r_budget, 0.02, 8,
                        budget=budget)
        points = [(450, 0.02, 8, True, "small"), (1e5, 0.05, 8, True, "small"), (1e5, 0.035, 4, True, "small"),
                  (1e5, 0.02, 1, False, "small"), (450, 0.05, 8, True, "large"), (60, 0.02, 4, True, "small")]
    for radius, h, layers, film, kin in points:
        label = f"{h:g} mm, {layers} layers, R {radius:g}" + ("" if film else ", no film") + (
            ", large strain" if kin == "large" else "")
        measure_fem(label, radius, h, layers, film, kin, budget)


# --- roughness maps ---------------------------------------------------------------------------------------

def write_map(path: Path, n: int) -> None:
    """A self-affine height map (Ra about 1.5 um at 1 um pixels, roll-off 50 um) as a 16-bit PNG."""
    from PIL import Image

    rng = np.random.default_rng(0)
    q = 2 * np.pi * np.hypot(np.fft.fftfreq(n)[:, None], np.fft.rfftfreq(n)[None, :])
    qr = 2 * np.pi / 50.0
    amp = (np.maximum(q, qr) / qr) ** -1.8
    amp[q > 2 * np.pi / 4.0] = 0.0
    amp[0, 0] = 0.0
    h = np.fft.irfft2(amp * (rng.standard_normal(q.shape) + 1j * rng.standard_normal(q.shape)), s=(n, n))
    h = (h - h.min()) / (h.max() - h.min())
    Image.fromarray(np.round(h * 65535).astype(np.uint16)).save(path)


def draws_held(path: Path, draws: int) -> tuple[float, float]:
    """The memory (bytes) that ``draws`` draws' bodies of the map at ``path`` hold together (as `curves` and
    `correct` hold them while the laws are solved; tracemalloc), and the map's own heights."""
    import tracemalloc

    from filmcal.contact.rough_imprint import RoughnessInputs
    from filmcal.contact.surface_files import read_surface_file
    from filmcal.correction.roughness import draw_bodies

    surface = read_surface_file(path, pixel_um=1.0, height_range_um=15.0)
    tracemalloc.start()
    held = [draw_bodies(RoughnessInputs(250.0 + 10 * k, 0.5, 0.8, 50.0, 4.0, k), wheel=surface)
            for k in range(draws)]
    current = tracemalloc.get_traced_memory()[0]
    tracemalloc.stop()
    del held
    return current, surface.heights_um.nbytes


def wheelrail_args(path: Path, film: bool) -> list[str]:
    return [*FILMCAL, "wheelrail", "--json", "--offset-mm", "0", "--force-kn", "100",
            *(["--film-modulus-mpa", "2800"] if film else ["--no-film"]), "--wheel-roughness-map", str(path),
            "--roughness-pixel-um", "1", "--roughness-height-range-um", "15"]


def map_section(quick: bool, budget: float, max_s: float, folder: Path) -> None:
    from filmcal.commands._common import ROUGH_COMMAND_BASE_BYTES

    header("filmcal wheelrail --wheel-roughness-map: estimate (rough_law_cost) against the peak RSS")
    side = int(math.isqrt(MAX_MAP_PIXELS))
    above = folder / "above.png"
    from PIL import Image

    Image.new("L", (side + 1, side + 1)).save(above)
    code, _, _, line = peak_of(wheelrail_args(above, True))
    big = rough_law_cost((side + 1) ** 2, 1, 0, 1, ROUGH_COMMAND_BASE_BYTES["wheelrail"])
    row(f"{side + 1} x {side + 1} px, film (above the pixel cap)", big.bytes, None, None, big.seconds,
        "refused: exit 2" if code == 2 else f"exit {code}")
    if code == 2:
        print(f"    {line}")
    sizes = [(512, True), (1024, False)] if quick else [(side, False), (side, True), (1448, True), (1024, True)]
    for n, film in sizes:
        cost = rough_law_cost(n * n, 1 if film else 0, 0 if film else 1, 1, ROUGH_COMMAND_BASE_BYTES["wheelrail"])
        label = f"{n} x {n} px, {'film' if film else 'no film (steel law)'}" + (
            " (the cap)" if n == side else "")
        if cost.bytes > budget or cost.seconds > max_s:
            row(label, cost.bytes, None, None, cost.seconds, f"not run: above this bench's budget "
                                                             f"({budget / GIB:g} GiB, {max_s:g} s)")
            continue
        path = folder / f"map{n}.png"
        if not path.exists():
            write_map(path, n)
        code, wall, peak, last = peak_of(wheelrail_args(path, film))
        row(label, cost.bytes, peak, wall, cost.seconds, "" if code in (0, 1) else f"exit {code}: {last[-120:]}")
    n = 512 if quick else 1024
    path = folder / f"map{n}.png"
    if not path.exists():
        write_map(path, n)
    one, heights = draws_held(path, 1)
    eight, _ = draws_held(path, 8)
    print(f"  the draws of a {n} x {n} map share its split (micro part and waviness): 1 draw holds "
          f"{one / 2**20:.0f} MiB, 8 draws {eight / 2**20:.0f} MiB (ratio {eight / one:.2f}; the map's heights "
          f"{heights / 2**20:.0f} MiB)")


# --- workers ----------------------------------------------------------------------------------------------

def workers_section(quick: bool, folder: Path) -> None:
    header("filmcal campaign run --workers: estimate (design_memory) against the largest RSS sum of its process tree")
    cap = _memory.max_workers()
    per, parent = _memory.worker_memory("campaign")
    design, store = folder / "design.csv", folder / "runs.sqlite"
    design.write_text("modulus_mpa,poisson,sphere_radius_mm,force_kn\n2800,0.33,450,75\n")
    code, _, _, line = peak_of([*FILMCAL, "campaign", "run", "--design", str(design), "--store", str(store),
                                "--workers", str(cap + 1)])
    row(f"--workers {cap + 1} (one above the cap, {_memory.cpu_count()} cores)", (cap + 1) * per + parent, None, None,
        None, "refused: exit 2" if code == 2 else f"exit {code}")
    if code == 2:
        print(f"    {line}")
    for n in ([2, cap] if not quick else [cap]):
        points = (4 if quick else 12) * n
        subprocess.run([*FILMCAL, "doe", "--samples", str(points), "--seed", "0", "--param", "modulus_mpa=500:5000",
                        "--param", "poisson=0.3:0.35", "--param", "sphere_radius_mm=300:600", "--param",
                        "force_kn=25:100", "--out", str(design)], check=True, capture_output=True)
        if store.exists():
            store.unlink()
        from filmcal.campaign import read_design_csv
        from filmcal.commands.campaign import check_fe_design, design_memory

        estimate = design_memory(check_fe_design(read_design_csv(design)), n)[3]
        code, wall, peak, last = peak_of([*FILMCAL, "campaign", "run", "--design", str(design), "--store", str(store),
                                          "--workers", str(n), "--progress", "quiet"], tree=True)
        row(f"--workers {n}, {points} FE points at the paper's mesh" + (" (the cap)" if n == cap else ""),
            estimate.bytes, peak, wall, None, "" if code == 0 else f"exit {code}: {last[-120:]}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller settings (about a minute)")
    parser.add_argument("--only", choices=["fem", "maps", "workers"], help="one section")
    parser.add_argument("--max-gib", type=float, default=None,
                        help="largest estimate run (GiB; default: what a run may use on this machine now, so that the "
                             "largest allowed settings are measured)")
    parser.add_argument("--max-s", type=float, default=180.0, help="longest estimated map run (s, default 180)")
    args = parser.parse_args()
    avail, total = _memory.available_bytes(), _memory.total_bytes()
    if avail is None or total is None:
        parser.error("this machine's memory is unknown (no /proc/meminfo): the checks allow any size; "
                     "nothing to compare")
    budget = (min(_memory.usable_bytes(), 4 * GIB) if args.quick else _memory.usable_bytes()) \
        if args.max_gib is None else args.max_gib * GIB
    print(f"machine: {_memory.cpu_count()} cores, {total / GIB:.1f} GiB, {avail / GIB:.1f} GiB available now; a run "
          f"may use {_memory.USABLE_FRACTION:.0%} of it: {_memory.usable_bytes() / GIB:.1f} GiB; this bench runs "
          f"estimates up to {budget / GIB:.1f} GiB")
    with tempfile.TemporaryDirectory(prefix="filmcal-memory-") as tmp:
        folder = Path(tmp)
        if args.only in (None, "fem"):
            fem_section(args.quick, budget)
        if args.only in (None, "maps"):
            map_section(args.quick, budget, args.max_s, folder)
        if args.only in (None, "workers"):
            workers_section(args.quick, folder)
    measured = [(c, e, m) for c, e, m in ROWS if m]
    if measured:
        ratios = np.array([m / e for _, e, m in measured])
        worst = max(measured, key=lambda r: abs(r[2] / r[1] - 1))
        print(f"\nmeasured/estimated over {len(measured)} runs: {ratios.min():.2f}-{ratios.max():.2f} "
              f"(target 0.70-1.30); worst: {worst[0]}")
        return 0 if np.all(np.abs(ratios - 1) <= 0.3) else 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
