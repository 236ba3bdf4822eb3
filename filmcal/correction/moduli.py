"""The one grid over E at which the wheel-rail film is solved, for the corrector and the curves alike.

Light on purpose (numpy alone): a correction whose solves are cached imports nothing of the solvers.
"""
from __future__ import annotations

import numpy as np

__all__ = ["SUPPORT_RANGE", "N_NODES", "modulus_grid", "thinned_posterior"]

#: Posterior quantiles whose range the moduli of the solves span (log-spaced between them).
SUPPORT_RANGE = (0.001, 0.999)
#: Solves over that range; a quadratic in log E through them, checked at one more modulus.
N_NODES = 3


def modulus_grid(samples) -> tuple[np.ndarray, np.ndarray]:
    """The one grid over E of the curves and the corrector: its nodes and the check modulus.

    `N_NODES` moduli log-spaced over the `SUPPORT_RANGE` quantiles of every sample array together (one when
    they all coincide); the check lies between the first two nodes, where the quadratic in log E is weakest.
    """
    lo = min(float(np.quantile(e, SUPPORT_RANGE[0])) for e in samples)
    hi = max(float(np.quantile(e, SUPPORT_RANGE[1])) for e in samples)
    nodes = np.geomspace(lo, hi, N_NODES) if hi > lo * (1 + 1e-9) else np.array([lo])
    return nodes, np.sqrt(nodes[:1] * nodes[1:2])


def thinned_posterior(posterior: dict, max_samples: int) -> dict[str, np.ndarray]:
    """A corrector's posterior, checked and thinned: at most `max_samples` evenly spaced samples.

    Parameters
    ----------
    posterior : dict of array_like
        ``modulus_mpa`` (finite, > 0) and ``sigma_mm`` (finite, >= 0) of equal size, any layout; ``poisson``
        (in (-1, 0.5)) of that size or one value, optional.
    max_samples : int
        At least 2 (a spread needs two samples).

    Returns
    -------
    dict
        ``modulus_mpa``, ``sigma_mm`` and, when given, ``poisson``, each 1-D of the same length.
    """
    if int(max_samples) != max_samples or max_samples < 2:
        raise ValueError(f"max_samples must be an integer >= 2, got {max_samples!r}")
    missing = [k for k in ("modulus_mpa", "sigma_mm") if k not in posterior]
    if missing:
        raise ValueError(f"posterior needs samples of {' and '.join(missing)}")
    out = {k: np.asarray(posterior[k], dtype=float).ravel() for k in ("modulus_mpa", "sigma_mm", "poisson")
           if k in posterior}
    n = out["modulus_mpa"].size
    if "poisson" in out and out["poisson"].size == 1:
        out["poisson"] = np.full(n, out["poisson"][0])
    sizes = {k: v.size for k, v in out.items()}
    if len(set(sizes.values())) != 1 or n < 2:
        raise ValueError(f"posterior samples must be of one size, at least 2, got {sizes}")
    checks = {"modulus_mpa": (lambda v: v > 0.0, "> 0"), "sigma_mm": (lambda v: v >= 0.0, ">= 0"),
              "poisson": (lambda v: (v > -1.0) & (v < 0.5), "in (-1, 0.5)")}
    for k, v in out.items():
        ok, text = checks[k]
        if not (np.all(np.isfinite(v)) and np.all(ok(v))):
            raise ValueError(f"posterior {k} samples must be finite and {text}")
    take = np.unique(np.linspace(0, n - 1, min(n, int(max_samples))).round().astype(int))
    return {k: v[take] for k, v in out.items()}
