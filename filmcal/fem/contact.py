"""Dual contact problem on node-to-node pairs, solved by a primal-dual active set.

The unknowns are the pair forces Lambda (on the upper body of each pair) and
the rigid displacement w of the loaded sphere. Relative displacements of the
pairs (upper minus lower; with the initial gap for normal components) are
affine in them:

    d = H Lambda + d0 + w a,         sum of the normal forces = F,

H symmetric positive definite (the bodies' combined compliance). Conditions:

* normal component (unilateral): d >= 0, lambda >= 0, d lambda = 0;
* tangential component, frictionless: tau = 0;
* tangential component with Coulomb friction mu (mu = inf: no slip): with the
  slip increment v = d - d_prev since the last load step and the normal force
  n, |tau| <= mu n, stick (v = 0) while |tau| < mu n, else tau = -mu n sign(v).

The active set update uses the complementarity functions lambda - c d (normal)
and sigma = tau - c v (tangential) with c = 1 / mean(diag H), as in the
semi-smooth Newton view of Hueber & Wohlmuth; each iteration solves one dense
linear system of the pair unknowns, which is exact for the frictionless case
(an LCP) and for given stick/slip states.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["PairSystem", "ContactState", "solve_pairs"]

OPEN, CLOSED = 0, 1
FREE, STICK, SLIP = 0, 1, 2


@dataclass
class PairSystem:
    """The pair unknowns' structure (fixed for a model and its options).

    Attributes
    ----------
    normal : ndarray of int
        Indices (into Lambda) of unilateral normal components.
    tangential : ndarray of int
        Indices of frictional (or no-slip) tangential components.
    friction : ndarray of float
        Friction coefficient per tangential component (inf: no slip).
    gate : ndarray of int
        For each tangential component, the position in `normal` of the normal
        component that must be closed for it to carry force, or -1 when it is
        always engaged (a bilateral interface).
    normal_force_map : ndarray, shape (n_tangential, n_lambda)
        Rows giving the normal force of each tangential component's pair as
        ``normal_force_map @ Lambda + normal_force_offset``.
    normal_force_offset : ndarray
    """

    normal: np.ndarray
    tangential: np.ndarray
    friction: np.ndarray
    gate: np.ndarray
    normal_force_map: np.ndarray
    normal_force_offset: np.ndarray

    @property
    def size(self) -> int:
        return len(self.normal) + len(self.tangential)


@dataclass
class ContactState:
    """Pair forces and statuses after a solve (also the start of the next)."""

    forces: np.ndarray
    rigid_w: float
    normal_status: np.ndarray
    tangential_status: np.ndarray
    relative: np.ndarray = field(default_factory=lambda: np.zeros(0))
    iterations: int = 0
    converged: bool = False
    reason: str = ""


def solve_pairs(H: np.ndarray, d0: np.ndarray, a: np.ndarray, force: float, pairs: PairSystem,
                start: ContactState, d_prev: np.ndarray, max_iterations: int = 60) -> ContactState:
    """Solve one load step of the pair problem.

    Parameters
    ----------
    H : ndarray (n, n)
        Compliance of the pair unknowns (symmetric positive definite).
    d0 : ndarray (n,)
        Relative displacement at zero pair forces and w = 0 (gaps included).
    a : ndarray (n,)
        Effect of the rigid displacement w on the relative displacements.
    force : float
        Total normal force (sum over the normal components).
    pairs : PairSystem
    start : ContactState
        Initial statuses (and forces) for the active-set iteration.
    d_prev : ndarray (n,)
        Relative displacements at the end of the previous load step (for slip
        increments); ignored for normal components.
    """
    n = H.shape[0]
    nn, nt = len(pairs.normal), len(pairs.tangential)
    c = 1.0 / float(np.mean(np.diag(H)))
    ns = start.normal_status.copy()
    ts = start.tangential_status.copy()
    sign = np.sign(start.forces[pairs.tangential]) if nt else np.zeros(0)
    lam = start.forces.copy()
    w = start.rigid_w
    seen: set[bytes] = set()
    for it in range(1, max_iterations + 1):
        A = np.zeros((n + 1, n + 1))
        b = np.zeros(n + 1)
        # default rows: force component = 0
        A[np.arange(n), np.arange(n)] = 1.0
        closed = pairs.normal[ns == CLOSED]
        A[closed, :n] = H[closed]
        A[closed, n] = a[closed]
        b[closed] = -d0[closed]
        if nt:
            stick = pairs.tangential[ts == STICK]
            A[stick, :n] = H[stick]
            A[stick, n] = a[stick]
            b[stick] = d_prev[stick] - d0[stick]
            slip_k = np.flatnonzero(ts == SLIP)
            slip = pairs.tangential[slip_k]
            A[slip, :n] = 0.0
            A[slip, slip] = 1.0
            A[slip, :n] += (pairs.friction[slip_k] * sign[slip_k])[:, None] * pairs.normal_force_map[slip_k]
            b[slip] = -pairs.friction[slip_k] * sign[slip_k] * pairs.normal_force_offset[slip_k]
        A[n, pairs.normal] = 1.0
        b[n] = force
        try:
            sol = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            return ContactState(lam, w, ns, ts, np.zeros(n), it, False, "singular pair system (no contact?)")
        lam, w = sol[:n], sol[n]
        d = H @ lam + d0 + w * a
        new_ns = np.where(lam[pairs.normal] - c * d[pairs.normal] > 0.0, CLOSED, OPEN)
        if not np.any(new_ns == CLOSED):  # keep the pair nearest to contact closed
            new_ns[np.argmin(d[pairs.normal])] = CLOSED
        new_ts = ts
        if nt:
            v = d[pairs.tangential] - d_prev[pairs.tangential]
            tau = lam[pairs.tangential]
            sigma = tau - c * v
            bound = pairs.friction * np.maximum(pairs.normal_force_map @ lam + pairs.normal_force_offset, 0.0)
            engaged = np.where(pairs.gate >= 0, new_ns[np.maximum(pairs.gate, 0)] == CLOSED, True)
            new_ts = np.where(~engaged, FREE, np.where(np.abs(sigma) <= bound, STICK, SLIP))
            new_sign = np.where(new_ts == SLIP, np.sign(sigma), sign)
        if np.array_equal(new_ns, ns) and np.array_equal(new_ts, ts) and (not nt or np.array_equal(new_sign, sign)):
            return ContactState(lam, w, ns, ts, d, it, True, "")
        key = new_ns.tobytes() + (new_ts.tobytes() + new_sign.tobytes() if nt else b"")
        if key in seen:
            return ContactState(lam, w, ns, ts, d, it, False, "active set cycles")
        seen.add(key)
        ns, ts = new_ns, new_ts
        if nt:
            sign = new_sign
    return ContactState(lam, w, ns, ts, d, max_iterations, False,
                        f"active set not settled after {max_iterations} iterations")
