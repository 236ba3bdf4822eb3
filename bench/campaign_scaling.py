"""Campaign throughput with 1 and 2 local worker processes.

Runs the same design (points at one sphere radius, varied E, nu, F) through
`filmcal.campaign.Campaign` on a `LocalPoolExecutor` with 1 worker, then with
2, each after a warm-up that gives every worker its per-radius setup, and
prints points per second and the ratio (target >= 1.7 on 2 idle cores).

    python bench/campaign_scaling.py            # the FE model, filmcal.fem.evaluate_point
    python bench/campaign_scaling.py --toy      # a CPU-bound numpy model with a per-radius cache

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

from filmcal.campaign import Campaign, LocalPoolExecutor

_TOY_SETUP: dict[float, np.ndarray] = {}
TOY_SIZE = 240
TOY_SOLVES = 120


def toy_model(params: dict) -> dict:
    """CPU-bound stand-in for the FE model: a per-radius matrix, then repeated solves.

    The matrix for a radius is built once per process (like the FE model's
    per-radius mesh); each point then runs `TOY_SOLVES` dense solves.
    """
    radius_mm = params["radius_mm"]
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
    return [{"modulus_mpa": float(e), "poisson": float(nu), "radius_mm": radius_mm, "force_kn": float(f)}
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--toy", action="store_true", help="use the CPU-bound numpy toy model")
    parser.add_argument("--points", type=int, default=24, help="design points per timed run (default 24)")
    parser.add_argument("--radius-mm", type=float, default=450.0, help="sphere radius of all points (default 450)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the design")
    parser.add_argument("--timeout-s", type=float, default=None, help="deadline per point")
    args = parser.parse_args()

    model, model_name = load_model(args.toy)
    points = design(args.points, args.radius_mm, args.seed)
    print(f"model {model_name}: {len(points)} points at R = {args.radius_mm:g} mm, "
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
