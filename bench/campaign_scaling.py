"""Campaign throughput with 1 and 2 local worker processes; external-command acceptance figures.

Runs the same design (points at one sphere radius, varied E, nu, F) through
`filmcal.campaign.Campaign` on a `LocalPoolExecutor` with 1 worker, then with
2, each after a warm-up that gives every worker its per-radius setup, and
prints points per second and the ratio (target >= 1.7 on 2 idle cores).

    python bench/campaign_scaling.py            # the FE model, filmcal.fem.evaluate_point
    python bench/campaign_scaling.py --toy      # a CPU-bound numpy model with a per-radius cache
    python bench/campaign_scaling.py --acceptance   # external commands: kill, rerun, Ctrl-C, two writers, Dask

``--acceptance`` runs a 20-point design through ``filmcal campaign run
--command`` with 2 workers and a stand-in solver whose behaviour a design
column selects (ok, outputs.json, exit 3, hang past the deadline, garbage,
NaN), and prints: the undisturbed run; SIGKILL of the campaign midway (how
long until no process of it is alive) and the rerun (points run, each point
finished exactly once, none recomputed); Ctrl-C (exit status and time);
two campaigns on one store started together; the same kill and rerun on a
Dask LocalCluster; and how fast bad Dask addresses are refused.

The timed runs include everything a campaign does: pickling, dispatch and one
SQLite transaction per point. Two more figures help read the result on a
shared machine: "busy", the share of the run's wall time during which the
workers were evaluating points (low: the campaign does not keep its workers
fed), and "on-CPU", the share of that evaluation time the workers actually
got a CPU (low: other processes compete for the cores, and no speed-up target
can be met).
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from filmcal._parallel import descendant_pids, pid_alive
from filmcal.campaign import Campaign, LocalPoolExecutor

_TOY_SETUP: dict[float, np.ndarray] = {}
TOY_SIZE = 240
TOY_SOLVES = 120


def toy_model(params: dict) -> dict:
    """CPU-bound stand-in for the FE model: a per-radius matrix, then repeated solves.

    The matrix for a radius is built once per process (like the FE model's
    per-radius mesh); each point then runs `TOY_SOLVES` dense solves.
    """
    radius_mm = params["sphere_radius_mm"]
    if radius_mm not in _TOY_SETUP:
        rng = np.random.default_rng(int(radius_mm))
        a = rng.standard_normal((TOY_SIZE, TOY_SIZE))
        _TOY_SETUP[radius_mm] = a @ a.T + TOY_SIZE * np.eye(TOY_SIZE)
    stiffness = _TOY_SETUP[radius_mm]
    x = np.full(TOY_SIZE, params["force_kn"] / params["modulus_mpa"])
    for _ in range(TOY_SOLVES):
        x = np.linalg.solve(stiffness, x + 1.0)
    return {"toy_response": float(x.mean()), "converged": True}


class CpuTimedModel:
    """A model wrapper that adds the CPU time of each evaluation to its outputs (``bench_cpu_s``)."""

    def __init__(self, model) -> None:
        self.model = model

    def __call__(self, params: dict) -> dict:
        start = time.process_time()
        outputs = dict(self.model(params))
        outputs["bench_cpu_s"] = time.process_time() - start
        return outputs


def worker_pid_after(model, params: dict) -> int:
    """Evaluate the model (to fill the worker's caches); return the worker's process id."""
    model(params)
    return os.getpid()


def design(n_points: int, radius_mm: float, seed: int) -> list[dict]:
    """Points at one radius with E, nu and F drawn uniformly (E 500-5000 MPa, nu 0.2-0.45, F 25-100 kN)."""
    rng = np.random.default_rng(seed)
    return [{"modulus_mpa": float(e), "poisson": float(nu), "sphere_radius_mm": radius_mm, "force_kn": float(f)}
            for e, nu, f in zip(rng.uniform(500, 5000, n_points), rng.uniform(0.2, 0.45, n_points),
                                rng.uniform(25, 100, n_points))]


def warm_up(pool: LocalPoolExecutor, model, params: dict, max_rounds: int = 10) -> None:
    """Evaluate one point on every worker of the pool."""
    seen: set[int] = set()
    for _ in range(max_rounds):
        futures = [pool.submit(worker_pid_after, model, params) for _ in range(pool.max_workers)]
        seen.update(future.result() for future in futures)
        if len(seen) >= pool.max_workers:
            return
    raise RuntimeError(f"warm-up reached {len(seen)} of {pool.max_workers} workers")


def measure(model, model_name: str, points: list[dict], n_workers: int, store: Path,
            timeout_s: float | None) -> dict[str, float]:
    """Throughput of a campaign on `n_workers` warm workers: points/s, ok count, busy and on-CPU shares."""
    with LocalPoolExecutor(n_workers) as pool:
        warm_up(pool, model, {**points[0], "force_kn": points[0]["force_kn"] * 0.5})
        campaign = Campaign(CpuTimedModel(model), store, executor=pool, model_name=model_name)
        summary = campaign.run(points, timeout_s=timeout_s, progress=False)
    runs = campaign.results(status=None)
    evaluating_s = float(np.nansum(runs.elapsed_s))
    cpu_s = float(np.nansum(runs.outputs.get("bench_cpu_s", np.array([np.nan]))))
    return {"points_per_s": summary.n_run / summary.elapsed_s, "ok": summary.counts.ok,
            "busy": evaluating_s / (n_workers * summary.elapsed_s), "on_cpu": cpu_s / evaluating_s}


def load_model(toy: bool):
    """The model to measure and its name; exit with a message if the FE model is missing."""
    if toy:
        return toy_model, "bench:toy_model"
    try:
        from filmcal.fem import evaluate_point
    except ImportError as exc:
        sys.exit(f"filmcal.fem.evaluate_point is not available ({exc}).\n"
                 "Run with --toy to measure the campaign machinery with a CPU-bound numpy model.")
    return evaluate_point, "filmcal.fem:evaluate_point"


STANDIN = r"""
import json, os, sys, time
mode, key, log = sys.argv[1], sys.argv[2], sys.argv[3]
e, r, f = map(float, sys.argv[4:7])
with open(log, "a") as stream:
    stream.write(f"{key} {os.getpid()}\n")
time.sleep(0.3)
radius = (3 * f * 1e3 * r / (4 * e / (2 * (1 - 0.3**2)))) ** (1 / 3)
if mode == "ok":
    print(json.dumps({"contact_radius_mm": radius}))
elif mode == "file":
    json.dump({"contact_radius_mm": radius, "deck_chars": len(open("deck.inp").read())}, open("outputs.json", "w"))
elif mode == "fail":
    sys.stderr.write("ERROR: element distorted\n"); sys.exit(3)
elif mode == "hang":
    time.sleep(600)
elif mode == "garbage":
    print("<html>not json</html>")
else:
    print('{"contact_radius_mm": NaN}')
"""
MODES_20 = ["ok", "ok", "hang", "ok", "fail", "ok", "garbage", "ok", "file", "nanout",
            "ok", "hang", "ok", "fail", "ok", "garbage", "ok", "file", "ok", "ok"]






class _Case:
    """A stand-in solver, a 20-point design and the command line of one scenario, in its own folder."""

    def __init__(self, folder: Path, modes: list[str]) -> None:
        import csv

        folder.mkdir(parents=True)
        self.folder, self.log, self.store = folder, folder / "starts.log", folder / "runs.sqlite"
        (folder / "standin.py").write_text(STANDIN)
        (folder / "deck.inp.tmpl").write_text("E={modulus_mpa} R={radius_mm}\n")
        with (folder / "design.csv").open("w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(["key", "mode", "modulus_mpa", "sphere_radius_mm", "force_kn"])
            for i, mode in enumerate(modes):
                writer.writerow([f"p{i:02d}", mode, 2000 + 100 * i, 300 + 10 * i, 25 + i])
        self.template = (f"{sys.executable} {folder / 'standin.py'} {{mode}} {{key}} {self.log} "
                         "{modulus_mpa} {radius_mm} {force_kn}")

    def command(self, *extra: str) -> list[str]:
        return [sys.executable, "-m", "filmcal.cli", "campaign", "run", "--design", str(self.folder / "design.csv"),
                "--store", str(self.store), "--command", self.template, "--template-file",
                str(self.folder / "deck.inp.tmpl"), "--timeout-s", "3", "--json", *extra]

    def starts(self) -> list[str]:
        return [line.split()[0] for line in self.log.read_text().splitlines()] if self.log.exists() else []

    def start_pids(self) -> set[int]:
        return {int(line.split()[1]) for line in self.log.read_text().splitlines()} if self.log.exists() else set()

    def rows(self) -> dict[str, tuple[str, str | None]]:
        import json
        import sqlite3

        try:
            conn = sqlite3.connect(f"file:{self.store}?mode=ro", uri=True)
            rows = conn.execute("SELECT inputs_json, status, reason FROM runs").fetchall()
            conn.close()
        except sqlite3.Error:
            return {}
        return {json.loads(i)["key"]: (status, reason) for i, status, reason in rows}

    def finished(self) -> int:
        return sum(status != "pending" for status, _ in self.rows().values())


def _kill_and_rerun(case: _Case, extra: list[str], label: str) -> None:
    import collections
    import json
    import subprocess
    import threading

    seen: set[int] = set()
    stop = threading.Event()
    first = subprocess.Popen(case.command(*extra), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    def watch() -> None:
        while not stop.is_set():
            seen.update(descendant_pids(first.pid))
            time.sleep(0.02)

    watcher = threading.Thread(target=watch, daemon=True)
    watcher.start()
    while not (case.finished() >= 8 and "p11" in case.starts()):
        if first.poll() is not None:
            raise RuntimeError(f"{label}: the campaign ended before the kill")
        time.sleep(0.02)
    first.kill()
    killed = time.monotonic()
    first.wait()
    stop.set()
    watcher.join()
    pids = seen | case.start_pids()
    while any(pid_alive(pid) for pid in pids) and time.monotonic() - killed < 30:
        time.sleep(0.01)
    gone_s = time.monotonic() - killed
    left = [pid for pid in pids if pid_alive(pid)]
    done_before = {key for key, (status, _) in case.rows().items() if status != "pending"}
    start = time.perf_counter()
    second = subprocess.run(case.command(*extra), capture_output=True, text=True)
    rerun_s = time.perf_counter() - start
    summary = json.loads(second.stdout) if second.returncode == 0 else {}
    starts = collections.Counter(case.starts())
    rows = case.rows()
    recomputed = sum(starts[key] > 1 for key in done_before)
    print(f"{label}: SIGKILL after {len(done_before)}/20 points finished; {len(pids)} processes of the first run "
          f"(workers, resource tracker, commands) all gone {gone_s:.2f} s after the kill ({len(left)} left); "
          f"rerun exit {second.returncode} in {rerun_s:.1f} s ran {summary.get('n_run')} points -> "
          f"{summary.get('ok')} ok / {summary.get('failed')} failed / {summary.get('pending')} pending; "
          f"{len(rows)} rows for 20 points; finished points recomputed: {recomputed}")


def acceptance(folder: Path) -> None:
    """Print the acceptance figures of external-command campaigns (see the module docstring)."""
    import collections
    import json
    import signal
    import subprocess

    print(f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    case = _Case(folder / "plain", MODES_20)
    start = time.perf_counter()
    run = subprocess.run(case.command("--workers", "2"), capture_output=True, text=True)
    summary = json.loads(run.stdout)
    reasons = collections.Counter((reason or "").split(" (")[0].split(";")[0] for status, reason in
                                  case.rows().values() if status == "failed")
    print(f"undisturbed, 2 workers: {time.perf_counter() - start:.1f} s, {summary['ok']} ok, {summary['failed']} "
          f"failed ({dict(reasons)})")

    _kill_and_rerun(_Case(folder / "kill", MODES_20), ["--workers", "2"], "local pool, 2 workers")

    case = _Case(folder / "ctrl-c", MODES_20)
    process = subprocess.Popen(case.command("--workers", "2"), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                               text=True)
    while "p02" not in case.starts() or case.finished() < 2:
        time.sleep(0.02)
    pids = descendant_pids(process.pid)
    process.send_signal(signal.SIGINT)
    sent = time.monotonic()
    _, err = process.communicate()
    exit_s = time.monotonic() - sent
    pids |= case.start_pids()
    print(f"Ctrl-C: exit {process.returncode} after {exit_s:.2f} s, stderr {err.strip()!r}, "
          f"{case.finished()} finished points kept, {sum(pid_alive(pid) for pid in pids)} processes left")

    case = _Case(folder / "two", ["ok"] * 20)
    both = [subprocess.Popen(case.command("--workers", "2"), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True) for _ in range(2)]
    begun = time.monotonic()
    ends: dict[int, float] = {}
    while len(ends) < 2:
        for i, proc in enumerate(both):
            if i not in ends and proc.poll() is not None:
                ends[i] = time.monotonic() - begun
        time.sleep(0.01)
    outs = [proc.communicate() for proc in both]
    codes = [proc.returncode for proc in both]
    refused = [i for i, code in enumerate(codes) if code == 2]
    starts = collections.Counter(case.starts())
    print(f"two campaigns on one store: exit statuses {codes}; the refused one exited after "
          f"{ends[refused[0]] if refused else float('nan'):.2f} s with {outs[refused[0]][1].strip()!r}; "
          f"{len(case.rows())} rows, {sum(s == 'ok' for s, _ in case.rows().values())} ok, "
          f"points computed twice: {sum(n > 1 for n in starts.values())}")

    import distributed

    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, protocol="tcp",
                                  dashboard_address=None, scheduler_port=0) as cluster:
        _kill_and_rerun(_Case(folder / "dask", MODES_20), ["--dask", cluster.scheduler_address],
                        "Dask LocalCluster (1 worker, 2 threads)")
    for address in ("garbage", "tcp://127.0.0.1:9"):
        case = _Case(folder / f"dask-{address.replace(':', '_').replace('/', '_')}", ["ok"])
        start = time.perf_counter()
        run = subprocess.run(case.command("--dask", address), capture_output=True, text=True)
        print(f"--dask {address}: exit {run.returncode} after {time.perf_counter() - start:.2f} s, "
              f"{run.stderr.count(chr(10))} stderr line(s): {run.stderr.strip()!r}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--acceptance", action="store_true",
                        help="external-command acceptance figures (kill, rerun, Ctrl-C, two writers, Dask)")
    parser.add_argument("--toy", action="store_true", help="use the CPU-bound numpy toy model")
    parser.add_argument("--points", type=int, default=24, help="design points per timed run (default 24)")
    parser.add_argument("--sphere-radius-mm", type=float, default=450.0, help="sphere radius of all points (default 450)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the design")
    parser.add_argument("--timeout-s", type=float, default=None, help="deadline per point")
    args = parser.parse_args()
    if args.acceptance:
        with tempfile.TemporaryDirectory() as tmp:
            acceptance(Path(tmp))
        return

    model, model_name = load_model(args.toy)
    points = design(args.points, args.sphere_radius_mm, args.seed)
    print(f"model {model_name}: {len(points)} points at R = {args.sphere_radius_mm:g} mm, "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.2f}")
    rates = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n_workers in (1, 2):
            start = time.perf_counter()
            figures = measure(model, model_name, points, n_workers, Path(tmp) / f"runs-{n_workers}.sqlite",
                              args.timeout_s)
            rates[n_workers] = figures["points_per_s"]
            print(f"{n_workers} worker(s): {rates[n_workers]:.3f} points/s, {figures['ok']}/{len(points)} ok, "
                  f"busy {figures['busy']:.0%}, on-CPU {figures['on_cpu']:.0%} "
                  f"({time.perf_counter() - start:.1f} s with start-up and warm-up)")
    print(f"speed-up 2 vs 1 workers: {rates[2] / rates[1]:.2f} (target >= 1.7 on 2 idle cores)")


if __name__ == "__main__":
    main()
