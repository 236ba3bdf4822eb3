"""The one grid over E at which the wheel-rail film is solved, for the corrector and the curves alike.

Light on purpose (numpy alone): a correction whose solves are cached imports nothing of the solvers.
"""
from __future__ import annotations

import numpy as np

__all__ = ["SUPPORT_RANGE", "N_NODES", "modulus_grid"]

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
