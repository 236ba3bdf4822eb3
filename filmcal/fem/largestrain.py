"""Geometrically nonlinear film: compressible neo-Hookean, total Lagrangian.

Strain energy (Ogden's compressible neo-Hookean form, which reduces to linear
elasticity with the same Lame constants at small strain):

    W = mu/2 (tr C - 3) - mu ln J + lam/2 (ln J)^2,
    P = mu (F - F^-T) + lam ln J F^-T,
    dP = mu dF + (mu - lam ln J) F^-T dF^T F^-T + lam (F^-T : dF) F^-T.

Axisymmetric deformation gradient in (r, z, theta):
F = [[1 + du_r/dR, du_r/dZ, 0], [du_z/dR, 1 + du_z/dZ, 0], [0, 0, 1 + u_r/R]].
The kinematics are evaluated once per assembly and passed to the forms.

As in the small-strain film (`filmcal.fem.forms`), the volumetric energy
lam/2 (ln J)^2 is integrated at the element centres and the rest,
mu/2 (tr C - 3) - mu ln J, at the full rule (selective reduced integration);
at small strain the two integrate the same forms as the linear film.
"""
from __future__ import annotations

import numpy as np
from skfem import Basis, LinearForm

from filmcal.fem.forms import lame_parameters

__all__ = ["film_internal_force_and_tangent"]


def _grad3(u, r) -> np.ndarray:
    """3 x 3 displacement gradient (r, z, theta), indices first: [i, j, element, point]."""
    z = np.zeros_like(u[0])
    return np.array([[u.grad[0, 0], u.grad[0, 1], z],
                     [u.grad[1, 0], u.grad[1, 1], z],
                     [z, z, u[0] / r]])


def _contract(a, b):
    return np.einsum("ij...,ij...->...", a, b)


@LinearForm
def _internal_force(v, w):
    r = w.x[0]
    return _contract(w.P, _grad3(v, r)) * 2.0 * np.pi * r


def _tangent(basis: Basis, FinvT: np.ndarray, c2: np.ndarray, lam: float, mu: float) -> np.ndarray:
    """Dense tangent stiffness ``K[a, b] = int dV_a : dP(dU_b) 2 pi r``, every element at once.

    The gradients of all local basis functions are stacked and the
    linearised stress ``dP = mu dU + c2 F^-T dU^T F^-T + lam (F^-T : dU) F^-T``
    is evaluated for all of them in one pass, instead of once per pair of
    basis functions as a generic bilinear form would.
    """
    r = basis.global_coordinates()[0]
    dU = np.array([_grad3(phi[0], r) for phi in basis.basis])  # [b, i, j, element, point]
    FinvT_dUT = np.einsum("ik...,blk...->bil...", FinvT, dU)
    dP = (mu * dU + c2 * np.einsum("bil...,lj...->bij...", FinvT_dUT, FinvT)
          + lam * np.einsum("kl...,bkl...->b...", FinvT, dU)[:, None, None] * FinvT)
    dP *= basis.dx * 2.0 * np.pi * r
    n_local, n_elements = dU.shape[0], dU.shape[3]
    rows = np.moveaxis(dU, 3, 0).reshape(n_elements, n_local, -1)  # [element, a, (i, j, point)]
    cols = np.moveaxis(dP, 3, 0).reshape(n_elements, n_local, -1)
    local = rows @ np.swapaxes(cols, 1, 2)  # [element, a, b]
    dofs = basis.element_dofs.T  # [element, a]
    n = basis.N
    K = np.bincount((dofs[:, :, None] * n + dofs[:, None, :]).ravel(), weights=local.ravel(), minlength=n * n)
    return K.reshape(n, n)


def _kinematics(basis: Basis, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(F, F^-T, ln J) at the basis' points; raises LinAlgError where J <= 0."""
    uh = basis.interpolate(u)
    r = basis.global_coordinates()[0]
    F = _grad3(uh, r) + np.eye(3)[:, :, None, None]
    Fm = np.moveaxis(F, (0, 1), (-2, -1))
    J = np.linalg.det(Fm)
    if np.any(J <= 0.0):
        raise np.linalg.LinAlgError("film element inverted (J <= 0)")
    FinvT = np.moveaxis(np.linalg.inv(Fm), (-2, -1), (1, 0))
    return F, FinvT, np.log(J)


def film_internal_force_and_tangent(full: Basis, centre: Basis, film, u: np.ndarray
                                    ) -> tuple[np.ndarray, np.ndarray]:
    """Internal nodal forces and tangent stiffness (dense) of the film at displacement `u`.

    Parameters
    ----------
    full, centre : skfem.Basis
        The film's bases at the full rule and at one point per element
        (:func:`filmcal.fem.forms.film_bases`).
    film : Film
        Its ``modulus_mpa`` and ``poisson``.
    u : ndarray
        Film DOFs.

    Raises `numpy.linalg.LinAlgError` when an element is inverted (J <= 0).
    """
    lam, mu = lame_parameters(film.modulus_mpa, film.poisson)
    F, FinvT, _ = _kinematics(full, u)
    _, FinvT_c, log_j_c = _kinematics(centre, u)
    f = (_internal_force.assemble(full, P=mu * (F - FinvT))
         + _internal_force.assemble(centre, P=lam * log_j_c * FinvT_c))
    K = _tangent(full, FinvT, mu, 0.0, mu) + _tangent(centre, FinvT_c, -lam * log_j_c, lam, 0.0)
    return f, K
