"""A radius surrogate's fit: filmcal's likelihood against scikit-learn's, from the same starts, timed.

`filmcal.surrogate.GPSurrogate` maximises the log marginal likelihood of
``C * Matern(2.5, anisotropic) + White`` with its own evaluation of the
likelihood and gradient (`filmcal.surrogate.gp._log_marginal_likelihood`).
Here each optimiser start is run twice, L-BFGS-B on that function and
scikit-learn's `GaussianProcessRegressor` (its generic kernel algebra, its
optimiser) from the same start on the same data, one BLAS thread: the seconds
of each, their ratio, and the optimum each reaches (the fit keeps the best
start). The data are a study's surrogate training runs (``--study-dir``), or
a smooth stand-in of a radius excess on a Latin hypercube of the same size.

    python bench/gp_fit.py [--points 320] [--starts 4]
    python bench/gp_fit.py --study-dir filmcal-study [--surrogates 2]
"""
from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from pathlib import Path

import numpy as np


def stand_in(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """GP coordinates on a Latin hypercube and a smooth radius-excess-like output, standardised."""
    from scipy.stats import qmc

    T = qmc.LatinHypercube(4, rng=seed).random(n)
    y = 0.3 / (1 + 2 * T[:, 0]) * (1 + 0.4 * T[:, 1]) * (1 + 0.2 * T[:, 2] ** 2) * (0.8 + 0.3 * T[:, 3])
    y = y + 1e-4 * np.random.default_rng(seed).standard_normal(n)
    return T, (y - y.mean()) / y.std()


def study_sets(study_dir: str, count: int):
    """(name, T, z) of the first `count` surrogates of a study, in their fitted coordinates."""
    from filmcal.surrogate import load_surrogate

    stems = sorted(p.with_suffix("") for p in (Path(study_dir) / "surrogates").glob("*.json")
                   if not p.name.endswith("-validation.json"))[:count]
    for stem in stems:
        s = load_surrogate(stem)
        yield stem.name, s.X_gp_, s.output_transform_.transform(s.y_train_)


def main(argv=None) -> int:
    from sklearn.gaussian_process import GaussianProcessRegressor
    from threadpoolctl import threadpool_limits

    from filmcal.surrogate import GPSurrogate
    from filmcal.surrogate.gp import _optimise_from

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=320, help="stand-in design size (default 320, a full study's)")
    ap.add_argument("--starts", type=int, default=4, help="optimiser starts per data set (default 4)")
    ap.add_argument("--study-dir", help="time a study's own surrogate data instead of the stand-in")
    ap.add_argument("--surrogates", type=int, default=2, help="with --study-dir: how many (default 2)")
    args = ap.parse_args(argv)
    sets = (list(study_sets(args.study_dir, args.surrogates)) if args.study_dir
            else [(f"stand-in, {args.points} points", *stand_in(args.points))])
    print(f"load average {os.getloadavg()[0]:.2f}; one BLAS thread; {args.starts} starts per data set")
    ratios = []
    for name, T, z in sets:
        template = GPSurrogate(n_restarts=args.starts - 1, random_state=0)
        kernel = template._template_kernel(T.shape[1])
        starts = template._starts(kernel, np.random.default_rng(0))
        own_s = ref_s = 0.0
        own_best = ref_best = -np.inf
        for theta0 in starts:
            t = time.perf_counter()
            _, value, _ = _optimise_from(kernel, theta0, T, z)
            own_s += time.perf_counter() - t
            own_best = max(own_best, value)
            t = time.perf_counter()
            with threadpool_limits(limits=1), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                gpr = GaussianProcessRegressor(kernel=kernel.clone_with_theta(theta0), alpha=0.0,
                                               n_restarts_optimizer=0).fit(T, z)
            ref_s += time.perf_counter() - t
            ref_best = max(ref_best, gpr.log_marginal_likelihood_value_)
        ratios.append(ref_s / own_s)
        print(json.dumps({"data": name, "points": int(T.shape[0]), "filmcal_s": round(own_s, 2),
                          "scikit_learn_s": round(ref_s, 2), "speed_up": round(ref_s / own_s, 2),
                          "best_lml": {"filmcal": round(float(own_best), 4),
                                       "scikit_learn": round(float(ref_best), 4)}}), flush=True)
    print(f"speed-up: {min(ratios):.2f}..{max(ratios):.2f}x; load average {os.getloadavg()[0]:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
