"""Static condensation of a linear elastic body onto its contact-face DOFs.

The body's DOFs are ordered by geometric nested dissection of its tensor grid
with the contact-face DOFs last; one sparse LU factorisation in that fixed
order with diagonal pivoting (the matrix is symmetric positive definite) then
holds the Schur complement S = K_ff - K_fi K_ii^-1 K_if as the product of the
trailing blocks of L and U. The condensation costs one factorisation: no
column-by-column solves.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["CondensedBody", "nested_dissection", "condense"]


def nested_dissection(node_at: np.ndarray, leaf_size: int = 64, stride: int = 1) -> np.ndarray:
    """Fill-reducing order of the nodes of a tensor grid by recursive bisection.

    Each box of grid nodes is split by its middle grid line (the separator),
    and ordered as: first half, second half, separator. With ``stride`` k a
    separator is a grid line whose index is a multiple of k: on the grid of a
    quadratic element's DOF locations (k = 2) only lines of element vertices
    separate, a line of midside points lies inside elements.
    """
    out: list[np.ndarray] = []

    def middle(lo: int, hi: int) -> int | None:
        s = (lo + hi) // 2
        s -= s % stride
        if s <= lo:
            s += stride
        return s if s < hi - 1 else None

    def split(i0: int, i1: int, j0: int, j1: int) -> None:
        ni, nj = i1 - i0, j1 - j0
        if ni <= 0 or nj <= 0:
            return
        si = middle(i0, i1) if ni >= nj else None
        sj = middle(j0, j1) if si is None else None
        if ni * nj <= leaf_size or (si is None and sj is None):
            out.append(node_at[i0:i1, j0:j1].ravel())
        elif si is not None:
            split(i0, si, j0, j1)
            split(si + 1, i1, j0, j1)
            out.append(node_at[si, j0:j1].ravel())
        else:
            split(i0, i1, j0, sj)
            split(i0, i1, sj + 1, j1)
            out.append(node_at[i0:i1, sj].ravel())

    split(0, node_at.shape[0], 0, node_at.shape[1])
    return np.concatenate(out) if out else np.zeros(0, dtype=int)


@dataclass
class CondensedBody:
    """A body condensed onto its contact-face DOFs.

    Attributes
    ----------
    stiffness : ndarray, shape (m, m)
        Condensed stiffness S on the face DOFs (symmetric positive definite).
    compliance : ndarray, shape (m, m)
        Its inverse G = S^-1.
    load_displacement : ndarray, shape (m,)
        Face displacement under the body's own load (for a unit load factor)
        with zero forces on the face.
    face_dofs : ndarray of int
        Global DOF numbers of the face DOFs, in the order of the matrices.
    factor_time_s : float
        Time spent in the sparse factorisation.
    """

    stiffness: np.ndarray
    compliance: np.ndarray
    load_displacement: np.ndarray
    face_dofs: np.ndarray
    factor_time_s: float
    n_dofs: int


def condense(K: sp.spmatrix, interior_dofs_in_order: np.ndarray, face_dofs: np.ndarray,
             load: np.ndarray | None = None) -> CondensedBody:
    """Condense the stiffness `K` onto `face_dofs`.

    Parameters
    ----------
    K : sparse matrix
        Stiffness of the body (all DOFs).
    interior_dofs_in_order : ndarray of int
        The DOFs to eliminate, in elimination order (fixed DOFs left out).
    face_dofs : ndarray of int
        The DOFs to keep.
    load : ndarray, optional
        Nodal load vector of the body (all DOFs); its condensed effect is
        returned as the face displacement with free face DOFs.
    """
    import time

    order = np.concatenate([interior_dofs_in_order, face_dofs])
    n, m = len(order), len(face_dofs)
    A = sp.csc_matrix(K.tocsr()[order][:, order])
    t0 = time.perf_counter()
    lu = spla.splu(A, permc_spec="NATURAL", diag_pivot_thresh=0.0,
                   options={"SymmetricMode": True})
    elapsed = time.perf_counter() - t0
    tail = np.arange(n - m, n)
    if not (np.array_equal(np.sort(lu.perm_c[tail]), tail) and np.array_equal(np.sort(lu.perm_r[tail]), tail)):
        raise RuntimeError("the sparse LU reordered the interface block; cannot read the Schur complement")
    L22 = lu.L.tocsc()[n - m:, n - m:].toarray()
    U22 = lu.U.tocsc()[n - m:, n - m:].toarray()
    S_perm = L22 @ U22
    rows = lu.perm_r[tail] - (n - m)
    cols = lu.perm_c[tail] - (n - m)
    S = S_perm[np.ix_(rows, cols)]
    S = 0.5 * (S + S.T)
    G = np.linalg.inv(S)
    G = 0.5 * (G + G.T)
    u0 = np.zeros(m)
    if load is not None:
        b = np.asarray(load, dtype=float)[order]
        b[n - m:] = 0.0
        u0 = lu.solve(b)[n - m:]
    return CondensedBody(S, G, u0, np.asarray(face_dofs), elapsed, n)
