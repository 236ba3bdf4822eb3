"""Quality and speed of optimal Latin hypercubes: filmcal against pyDOE and scipy.

For n = 100 points in d = 4 dimensions and seeds 0-4, in one run:

- filmcal: ``OptimalLatinHypercube(d=4, seed=s).random(100)`` (cell centres,
  ESE on phi_50);
- pyDOE: ``lhs(4, 100, criterion='maximin', iterations=1000, seed=s)`` (best
  of 1000 random jittered Latin hypercubes);
- scipy: ``qmc.LatinHypercube(d=4, optimization='random-cd', seed=s)``.

Prints, per method, the mean minimum pairwise distance, mean phi_50 and mean
centred L2 discrepancy (all in the unit cube), the largest |correlation|
between columns, whether every design is Latin, and the mean and largest
time per design; then the ratios of filmcal to the two others and a check of
the targets (mean min distance >= 0.32, mean phi_50 <= 3.3, <= 2 s wall time
per design, Latin). Times are wall clock ("t") and CPU time of this process
("cpu"); on a shared machine the two differ by the load.

Run: ``python bench/doe_quality.py``
"""
from __future__ import annotations

import time

import numpy as np
from pydoe import lhs
from scipy.stats import qmc

from filmcal.doe import OptimalLatinHypercube, design_quality

N, D, SEEDS = 100, 4, range(5)

METHODS = {
    "filmcal ESE": lambda s: OptimalLatinHypercube(d=D, seed=s).random(N),
    "pyDOE maximin": lambda s: lhs(D, N, criterion="maximin", iterations=1000, seed=s),
    "scipy random-cd": lambda s: qmc.LatinHypercube(d=D, optimization="random-cd",
                                                    seed=s).random(N),
}


def measure(make) -> dict[str, float]:
    """Metrics of one method averaged over the seeds, with timings."""
    rows, times, cpu_times = [], [], []
    for seed in SEEDS:
        start, cpu_start = time.perf_counter(), time.process_time()
        sample = make(seed)
        times.append(time.perf_counter() - start)
        cpu_times.append(time.process_time() - cpu_start)
        rows.append(design_quality(sample))
    return {
        "min_distance": float(np.mean([q.min_distance for q in rows])),
        "phi_50": float(np.mean([q.phi_p for q in rows])),
        "centered_l2": float(np.mean([q.centered_l2 for q in rows])),
        "max_abs_corr": float(max(q.max_abs_correlation for q in rows)),
        "latin": all(q.latin for q in rows),
        "time_mean_s": float(np.mean(times)),
        "time_max_s": float(np.max(times)),
        "cpu_mean_s": float(np.mean(cpu_times)),
    }


def main() -> None:
    results = {name: measure(make) for name, make in METHODS.items()}
    print(f"n = {N}, d = {D}, seeds {SEEDS.start}-{SEEDS.stop - 1}; metrics in the unit cube")
    header = (f"{'method':<16} {'min dist':>9} {'phi_50':>8} {'CL2':>10} {'max|corr|':>10} "
              f"{'Latin':>6} {'t mean s':>9} {'t max s':>8} {'cpu mean s':>11}")
    print(header)
    print("-" * len(header))
    for name, r in results.items():
        print(f"{name:<16} {r['min_distance']:9.4f} {r['phi_50']:8.3f} {r['centered_l2']:10.3e} "
              f"{r['max_abs_corr']:10.4f} {'yes' if r['latin'] else 'no':>6} "
              f"{r['time_mean_s']:9.3f} {r['time_max_s']:8.3f} {r['cpu_mean_s']:11.3f}")
    ours = results["filmcal ESE"]
    print()
    for name, other in results.items():
        if other is ours:
            continue
        print(f"filmcal / {name}: min distance x{ours['min_distance'] / other['min_distance']:.2f}, "
              f"phi_50 x{ours['phi_50'] / other['phi_50']:.2f}, "
              f"centred L2 x{ours['centered_l2'] / other['centered_l2']:.2f}, "
              f"mean time x{ours['time_mean_s'] / other['time_mean_s']:.2f}")
    checks = {
        "mean min distance >= 0.32": ours["min_distance"] >= 0.32,
        "mean phi_50 <= 3.3": ours["phi_50"] <= 3.3,
        "every design <= 2 s": ours["time_max_s"] <= 2.0,
        "Latin property kept": ours["latin"],
    }
    print()
    for label, ok in checks.items():
        print(f"target {label}: {'met' if ok else 'NOT MET'}")


if __name__ == "__main__":
    main()
