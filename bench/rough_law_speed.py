"""Time of the rough wheel's pressure-closure laws (boundary elements), and what the solver's path changes.

The laws the pipeline's curves make: each of the first ``--draws`` shipped conditioned draws of the roughness
inputs, at Ra 1.5 um on the wheel, against each film at its shipped median modulus and steel on steel. Each law
is solved twice in this one run:

* ``retry``: the conjugate gradients tried first at every load, the projected gradient finishing the loads
  where they stall (the solver before 29 Nov 2026);
* ``now``: once the conjugate gradients have stalled at a load, the later loads start with the projected
  gradient (`filmcal.contact.roughness.solve_periodic_contact`).

Prints each law's two times and their ratio, the largest relative difference of the closures over the law's
loads and of the contact fractions, and the totals.

Usage::

    OMP_NUM_THREADS=1 python3 bench/rough_law_speed.py [--draws 2]
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from filmcal.contact import roughness
from filmcal.contact.rough_imprint import load_roughness_inputs
from filmcal.contact.waviness import WAVINESS_CUTOFF_CELLS
from filmcal.films import get_film
from filmcal.wheelrail.settings import GRID_MM

SHIPPED_MEDIANS_MPA = {"MS": 519.4, "HS": 2602.1, "HHS": 3358.0}  # the full study's medians (README, 28 Nov)


def _solve(make, retry: bool):
    """A law made with the conjugate gradients retried at every load (``retry``) or not, and its time (s)."""
    real = roughness._solve_step

    def always_conjugate(*args, **kwargs):
        return real(*args[:7], True)

    roughness._CACHE.clear()
    if retry:
        roughness._solve_step = always_conjugate
    try:
        start = time.perf_counter()
        law = make()
        return law, time.perf_counter() - start
    finally:
        roughness._solve_step = real


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--draws", type=int, default=2, help="shipped conditioned draws (default 2)")
    args = ap.parse_args()
    totals = {"retry": 0.0, "now": 0.0}
    print(f"{'draw':>4} {'against':>8} {'retry s':>8} {'now s':>7} {'ratio':>6} {'closure rel':>12} "
          f"{'fraction':>9}")
    for k, draw in enumerate(load_roughness_inputs()[:args.draws]):
        bodies = draw.bodies(1.5, None).split(1e3 * WAVINESS_CUTOFF_CELLS * GRID_MM)
        makers = {name: (lambda f=get_film(name), e=e: bodies.film_law(e, f.poisson, f.thickness_mm))
                  for name, e in SHIPPED_MEDIANS_MPA.items()}
        makers["steel"] = bodies.steel_law
        for name, make in makers.items():
            old, t_old = _solve(make, retry=True)
            new, t_new = _solve(make, retry=False)
            totals["retry"] += t_old
            totals["now"] += t_new
            a = np.array([s.closure_mm for s in old.steps])
            b = np.array([s.closure_mm for s in new.steps])
            n = min(a.size, b.size)
            fa = np.array([s.contact_fraction for s in old.steps])[:n]
            fb = np.array([s.contact_fraction for s in new.steps])[:n]
            print(f"{k:>4} {name:>8} {t_old:8.2f} {t_new:7.2f} {t_old / t_new:6.2f} "
                  f"{np.max(np.abs(a[:n] - b[:n]) / a[:n]):12.1e} {np.max(np.abs(fa - fb)):9.1e}", flush=True)
    print(f"total: retry {totals['retry']:.1f} s, now {totals['now']:.1f} s, "
          f"ratio {totals['retry'] / totals['now']:.2f}")


if __name__ == "__main__":
    main()
