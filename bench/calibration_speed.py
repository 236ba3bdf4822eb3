"""Wall time and diagnostics of the Bayesian calibration of each film type.

In one run: the FE radius surrogate of `filmcal.study` (optimal Latin
hypercube of FE runs through a resumable campaign in ``--study-dir``, a GP over
(log E, nu, log R, log F), validated on held-out runs) is built or reused, then
``calibrate_film`` runs for MS, HS and HHS (32 walkers, >= 50 tau, R-hat <=
1.01 and bulk ESS >= 2000 for E, nu fixed at 0.33, prior support the
surrogate's domain). Prints per film: seconds, steps, tau, R-hat, bulk ESS of E,
E and M with 90 % intervals, sigma, predictive coverage; then the slowest film's
time against the 60 s target. Surrogate building is timed separately.

    python bench/calibration_speed.py [--study-dir /tmp/filmcal-bench-study] [--loads 50-100]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from filmcal.calibration import FILM_TYPES, Priors, calibrate_film
from filmcal.study import SurrogateDomain, SurrogateRadiusModel, build_radius_surrogate

TARGET_S = 60.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--study-dir", type=Path, default=Path("/tmp/filmcal-bench-study"))
    parser.add_argument("--loads", default=None, help="load range in kN, e.g. 50-100 (default: all)")
    parser.add_argument("--poisson", choices=("fixed", "free"), default="fixed")
    parser.add_argument("--discrepancy", choices=("load",), default=None)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    domain = SurrogateDomain()
    t0 = time.perf_counter()
    surrogate, validation = build_radius_surrogate(args.study_dir, domain=domain, seed=args.seed, progress=False)
    print(f"surrogate (built or reused) in {time.perf_counter() - t0:.1f} s; held-out area error RMS "
          f"{100 * validation.area_rms_relative_error:.3f} %, max {100 * validation.area_max_relative_error:.3f} %, "
          f"90 % coverage {validation.coverage90:.2f} (n = {validation.n})")
    model = SurrogateRadiusModel(surrogate, domain)
    print(f"{'film':5s} {'time_s':>7s} {'steps':>6s} {'tau':>6s} {'rhat':>7s} {'ess_E':>7s} {'ok':>5s} "
          f"{'E_median':>9s} {'E_ci90':>17s} {'M_median':>9s} {'sigma':>6s} {'cover':>6s}")
    times = []
    for film in FILM_TYPES:
        t0 = time.perf_counter()
        r = calibrate_film(film, model, args.loads, poisson=args.poisson, discrepancy=args.discrepancy,
                           priors=Priors(modulus_range_mpa=domain.modulus_mpa), seed=args.seed)
        elapsed = time.perf_counter() - t0
        times.append(elapsed)
        ci = r.modulus_mpa["ci90"]
        print(f"{film:5s} {elapsed:7.1f} {r.n_steps:6d} {max(r.tau.values()):6.1f} {r.rhat_max:7.4f} "
              f"{r.ess_bulk['modulus_mpa']:7.0f} {str(r.diagnostics_ok):>5s} {r.modulus_mpa['median']:9.0f} "
              f"{f'[{ci[0]:.0f}, {ci[1]:.0f}]':>17s} {r.oedometric_modulus_mpa['median']:9.0f} "
              f"{r.sigma_mm['median']:6.3f} {r.predictive.coverage:6.2f}")
        for message in r.diagnostics.messages:
            print(f"      {message}")
    worst = max(times)
    print(f"slowest film: {worst:.1f} s = {worst / TARGET_S:.2f} x the {TARGET_S:.0f} s target "
          f"({'met' if worst <= TARGET_S else 'MISSED'})")


if __name__ == "__main__":
    main()
