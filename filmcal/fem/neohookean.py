"""The large-strain film of the second FE formulation: compressible neo-Hookean in the second
Piola-Kirchhoff form, fully integrated, assembled sparse.

The material is the production film's (:mod:`filmcal.fem.largestrain`),

    W = mu/2 (tr C - 3) - mu ln J + lam/2 (ln J)^2,

written here in the other classical way, so that the two implementations check each other:

    S  = mu (I - C^-1) + lam ln J C^-1,
    dE = sym(F^T G)                          (G: the test function's displacement gradient),
    dS = lam (C^-1 : dE) C^-1 + 2 (mu - lam ln J) C^-1 dE C^-1,

internal virtual work int S : dE dV, tangent int G_a : (G_b S) + dE_a : dS_b dV, with
dV = 2 pi r dA and the axisymmetric gradient in (r, z, theta) (hoop term u_r / r). Every
term is integrated at the basis' full rule (no selective integration).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import Basis

from filmcal.elastic import lame_parameters

__all__ = ["neo_hookean_force_and_tangent", "minimum_jacobian"]


def _gradient(field, r: np.ndarray) -> np.ndarray:
    """Axisymmetric 3 x 3 displacement gradient of a vector field, [i, j, element, point]."""
    g = np.asarray(field.grad)
    z = np.zeros_like(r)
    return np.array([[g[0, 0], g[0, 1], z], [g[1, 0], g[1, 1], z], [z, z, np.asarray(field)[0] / r]])


def _deformation_gradient(basis: Basis, u: np.ndarray, r: np.ndarray) -> np.ndarray:
    """F at the basis' points, [element, point, i, j]."""
    F = _gradient(basis.interpolate(u), r) + np.eye(3)[:, :, None, None]
    return np.moveaxis(F, (0, 1), (-2, -1))


def minimum_jacobian(basis: Basis, u: np.ndarray) -> float:
    """The smallest J = det F at the basis' points (<= 0: an element is inverted)."""
    return float(np.linalg.det(_deformation_gradient(basis, u, np.asarray(basis.global_coordinates()[0]))).min())


def neo_hookean_force_and_tangent(basis: Basis, modulus_mpa: float, poisson: float, u: np.ndarray
                                  ) -> tuple[np.ndarray, sp.csr_matrix]:
    """Internal nodal forces (N) and tangent stiffness (N/mm, sparse) of a neo-Hookean body at `u`.

    Parameters
    ----------
    basis : skfem.Basis
        A vector basis of the body (axisymmetric: x[0] is the radius, in mm).
    modulus_mpa, poisson : float
        Young's modulus and Poisson's ratio at small strain.
    u : ndarray
        Displacements (mm) at the basis' DOFs.

    Raises `numpy.linalg.LinAlgError` when an element is inverted (J <= 0 at a point).
    """
    lam, mu = lame_parameters(modulus_mpa, poisson)
    r = np.asarray(basis.global_coordinates()[0])
    weight = np.asarray(basis.dx) * 2.0 * np.pi * r  # [element, point]
    Fm = _deformation_gradient(basis, u, r)  # [element, point, i, j]
    C = np.swapaxes(Fm, -1, -2) @ Fm
    J = np.linalg.det(Fm)
    if np.any(J <= 0.0):
        raise np.linalg.LinAlgError("film element inverted (J <= 0)")
    Ci = np.linalg.inv(C)
    log_j = np.log(J)[..., None, None]
    S = mu * (np.eye(3) - Ci) + lam * log_j * Ci  # [element, point, i, j]
    c2 = (mu - lam * np.log(J))[None]  # [1, element, point]

    G = np.array([np.moveaxis(_gradient(phi[0], r), (0, 1), (-2, -1)) for phi in basis.basis])  # [a, e, q, i, j]
    FtG = np.swapaxes(Fm, -1, -2)[None] @ G
    dE = 0.5 * (FtG + np.swapaxes(FtG, -1, -2))  # [a, e, q, i, j]
    force_local = np.einsum("aeqij,eqij,eq->ea", dE, S, weight)
    # geometric part: G_a : (G_b S) = sum_ij G_a[i, j] (G_b S)[i, j]
    GS = G @ S[None]
    # material part: lam (C^-1 : dE_a)(C^-1 : dE_b) + 2 c2 tr(dE_a C^-1 dE_b C^-1)
    trace_a = np.einsum("aeqij,eqij->aeq", dE, Ci)
    CdEC = Ci[None] @ dE @ Ci[None]  # C^-1 dE_b C^-1
    local = (np.einsum("aeqij,beqij,eq->eab", G, GS, weight)
             + lam * np.einsum("aeq,beq,eq->eab", trace_a, trace_a, weight)
             + 2.0 * np.einsum("aeqij,beqji,eq->eab", dE, CdEC, c2[0] * weight))
    dofs = basis.element_dofs.T  # [element, a]
    f = np.bincount(dofs.ravel(), weights=force_local.ravel(), minlength=basis.N)
    rows = np.broadcast_to(dofs[:, :, None], local.shape).ravel()
    cols = np.broadcast_to(dofs[:, None, :], local.shape).ravel()
    K = sp.coo_matrix((local.ravel(), (rows, cols)), shape=(basis.N, basis.N)).tocsr()
    return f, K
