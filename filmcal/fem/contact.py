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
and sigma = tau - c v (tangential) with c = 0.1 / H_kk per component, as in the
semi-smooth Newton view of Hueber & Wohlmuth; each iteration solves one dense
linear system of the pair unknowns, which is exact for the frictionless case
(an LCP) and for given stick/slip states. Coulomb's bound mu n is handled by
a fixed point over Tresca problems (the bound frozen in the inner loop).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["PairSystem", "ContactState", "solve_pairs", "load_sensitivity"]

OPEN, CLOSED = 0, 1
# c_k = COMPLEMENTARITY_SCALE / H_kk. A value well below 1 weights the force side of the
# complementarity functions; with 1 or more, Coulomb slip directions were seen to cycle.
COMPLEMENTARITY_SCALE = 0.1
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
                start: ContactState, d_prev: np.ndarray, max_iterations: int = 60,
                max_fixed_point: int = 60, tol: float = 1e-7) -> ContactState:
    """Solve one load step of the pair problem.

    Coulomb friction is solved as a fixed point on the friction bound: with
    the bound mu n frozen (a Tresca problem, for which the active-set method
    is robust) the statuses are settled, then n is updated from the new forces
    (under-relaxed by 1/2 after four updates) until the forces no longer change
    (change below `tol` times the total force).

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
        Initial statuses and forces (the previous load step's solution).
    d_prev : ndarray (n,)
        Relative displacements at the end of the previous load step (for slip
        increments); ignored for normal components.
    """
    nt = len(pairs.tangential)
    state = start
    iterations = 0
    finite_mu = np.where(np.isinf(pairs.friction), 0.0, pairs.friction)
    bound = _friction_bound(pairs, finite_mu, start.forces)
    previous = None
    for update in range(max_fixed_point if nt else 1):
        state = _tresca_active_set(H, d0, a, force, pairs, bound, state, d_prev, max_iterations)
        iterations += state.iterations
        state.iterations = iterations
        if not state.converged or not nt:
            return state
        change = np.max(np.abs(state.forces - previous)) if previous is not None else np.inf
        if change <= tol * abs(force):
            return state
        previous = state.forces.copy()
        new_bound = _friction_bound(pairs, finite_mu, state.forces)
        # under-relaxed after the first passes: unloaded pairs (n ~ 0) may otherwise toggle
        bound = new_bound if update < 4 else np.where(np.isinf(new_bound), new_bound, 0.5 * (bound + new_bound))
    state.converged = False
    state.reason = f"friction bound fixed point not settled after {max_fixed_point} updates"
    return state


def load_sensitivity(H: np.ndarray, a: np.ndarray, d_unit: np.ndarray, pairs: PairSystem,
                     state: ContactState) -> tuple[np.ndarray, float, np.ndarray]:
    """Rates of the pair forces, the rigid displacement and the relative displacements with the force.

    With every status of `state` held (closed normals, sticking and slipping
    tangentials), the solution is affine in the force F; this returns its
    slopes (dLambda/dF, dw/dF, dd/dF). A slipping component's force follows
    its pair's normal force (mu n sign), a sticking one keeps its relative
    displacement.

    Parameters
    ----------
    H, a : ndarray
        As in :func:`solve_pairs` (for a nonlinear film, at the converged state).
    d_unit : ndarray
        Rate of the relative displacement at zero pair forces with F (the
        loaded body's displacement per newton).
    pairs : PairSystem
    state : ContactState
        A converged solution.
    """
    n = H.shape[0]
    A = np.zeros((n + 1, n + 1))
    b = np.zeros(n + 1)
    A[np.arange(n), np.arange(n)] = 1.0
    closed = pairs.normal[state.normal_status == CLOSED]
    A[closed, :n] = H[closed]
    A[closed, n] = a[closed]
    b[closed] = -d_unit[closed]
    if len(pairs.tangential):
        ts = state.tangential_status
        stick = pairs.tangential[ts == STICK]
        A[stick, :n] = H[stick]
        A[stick, n] = a[stick]
        b[stick] = -d_unit[stick]
        slip_k = np.flatnonzero(ts == SLIP)
        sign = np.sign(state.forces[pairs.tangential[slip_k]])
        A[pairs.tangential[slip_k], :n] -= (sign * pairs.friction[slip_k])[:, None] * pairs.normal_force_map[slip_k]
    A[n, pairs.normal] = 1.0
    b[n] = 1.0
    sol = np.linalg.solve(A, b)
    dlam, dw = sol[:n], float(sol[n])
    return dlam, dw, H @ dlam + d_unit + dw * a


def _friction_bound(pairs: PairSystem, finite_mu: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """mu * max(n, 0) per tangential component (inf where there is no slip)."""
    if not len(pairs.tangential):
        return np.zeros(0)
    normal_force = np.maximum(pairs.normal_force_map @ forces + pairs.normal_force_offset, 0.0)
    return np.where(np.isinf(pairs.friction), np.inf, finite_mu * normal_force)


def _tresca_active_set(H, d0, a, force, pairs: PairSystem, bound: np.ndarray, start: ContactState,
                       d_prev: np.ndarray, max_iterations: int) -> ContactState:
    """Primal-dual active set for unilateral normals and a given friction bound."""
    n = H.shape[0]
    nt = len(pairs.tangential)
    c = COMPLEMENTARITY_SCALE / np.diag(H)  # per component: the scales of normal and tangential compliances differ
    ns = start.normal_status.copy()
    ts = start.tangential_status.copy()
    sign = np.sign(start.forces[pairs.tangential]) if nt else np.zeros(0)
    lam = start.forces.copy()
    w = start.rigid_w
    seen: set[bytes] = set()
    for it in range(1, max_iterations + 1):
        A = np.zeros((n + 1, n + 1))
        b = np.zeros(n + 1)
        A[np.arange(n), np.arange(n)] = 1.0  # default rows: the force component is zero
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
            b[pairs.tangential[slip_k]] = sign[slip_k] * bound[slip_k]  # tau = bound sign(sigma)
        A[n, pairs.normal] = 1.0
        b[n] = force
        try:
            sol = np.linalg.solve(A, b)
        except np.linalg.LinAlgError:
            return ContactState(lam, w, ns, ts, np.zeros(n), it, False, "singular pair system (no contact?)")
        lam, w = sol[:n], sol[n]
        d = H @ lam + d0 + w * a
        new_ns = np.where(lam[pairs.normal] - c[pairs.normal] * d[pairs.normal] > 0.0, CLOSED, OPEN)
        if not np.any(new_ns == CLOSED):  # keep the pair nearest to contact closed
            new_ns[np.argmin(d[pairs.normal])] = CLOSED
        new_ts, new_sign = ts, sign
        if nt:
            v = d[pairs.tangential] - d_prev[pairs.tangential]
            sigma = lam[pairs.tangential] - c[pairs.tangential] * v
            engaged = np.where(pairs.gate >= 0, new_ns[np.maximum(pairs.gate, 0)] == CLOSED, True)
            new_ts = np.where(~engaged, FREE, np.where(np.abs(sigma) <= bound, STICK, SLIP))
            new_sign = np.where(new_ts == SLIP, np.sign(sigma), sign)
        if np.array_equal(new_ns, ns) and np.array_equal(new_ts, ts) and np.array_equal(new_sign, sign):
            return ContactState(lam, w, ns, ts, d, it, True, "")
        key = new_ns.tobytes() + new_ts.tobytes() + np.asarray(new_sign).tobytes()
        if key in seen:
            return ContactState(lam, w, ns, ts, d, it, False, "active set cycles")
        seen.add(key)
        ns, ts, sign = new_ns, new_ts, new_sign
    return ContactState(lam, w, ns, ts, d, max_iterations, False,
                        f"active set not settled after {max_iterations} iterations")
