"""Geometrically nonlinear film: compressible neo-Hookean, total Lagrangian.

Strain energy (Ogden's compressible neo-Hookean form, which reduces to linear
elasticity with the same Lame constants at small strain):

    W = mu/2 (tr C - 3) - mu ln J + lam/2 (ln J)^2,
    P = mu (F - F^-T) + lam ln J F^-T,
    dP/dF = mu I(x)I + (mu - lam ln J) F^-1_Li F^-1_Jk + lam F^-T (x) F^-T.

Axisymmetric deformation gradient in (r, z, theta):
F = [[1 + du_r/dR, du_r/dZ, 0], [du_z/dR, 1 + du_z/dZ, 0], [0, 0, 1 + u_r/R]].
"""
from __future__ import annotations

import numpy as np
from skfem import Basis, BilinearForm, LinearForm

from filmcal.fem.forms import lame_parameters

__all__ = ["film_internal_force_and_tangent"]


def _grad3(u, r):
    """3 x 3 displacement gradient (r, z, theta) of a vector field at quadrature points."""
    z = np.zeros_like(u[0])
    return np.array([[u.grad[0, 0], u.grad[0, 1], z],
                     [u.grad[1, 0], u.grad[1, 1], z],
                     [z, z, u[0] / r]])


def _kinematics(w):
    r = w.x[0]
    Fd = _grad3(w["u"], r) + np.eye(3)[:, :, None, None]
    Fi = np.einsum("ij...->...ij", Fd)
    Finv = np.linalg.inv(Fi)
    J = np.linalg.det(Fi)
    return r, Fi, Finv, J


@LinearForm
def _internal_force(v, w):
    r, F, Finv, J = _kinematics(w)
    lam, mu = w.lam, w.mu
    FinvT = np.swapaxes(Finv, -1, -2)
    P = mu * (F - FinvT) + (lam * np.log(J))[..., None, None] * FinvT
    dV = np.einsum("ij...->...ij", _grad3(v, r))
    return np.einsum("...ij,...ij->...", P, dV) * 2.0 * np.pi * r


@BilinearForm
def _tangent(u, v, w):
    r, F, Finv, J = _kinematics(w)
    lam, mu = w.lam, w.mu
    dU = np.einsum("ij...->...ij", _grad3(u, r))
    dV = np.einsum("ij...->...ij", _grad3(v, r))
    FinvT = np.swapaxes(Finv, -1, -2)
    # mu dU + (mu - lam ln J) F^-T dU^T F^-T + lam (F^-T : dU) F^-T
    term1 = mu * dU
    term2 = (mu - lam * np.log(J))[..., None, None] * (FinvT @ np.swapaxes(dU, -1, -2) @ FinvT)
    term3 = (lam * np.einsum("...ij,...ij->...", FinvT, dU))[..., None, None] * FinvT
    dP = term1 + term2 + term3
    return np.einsum("...ij,...ij->...", dP, dV) * 2.0 * np.pi * r


def film_internal_force_and_tangent(basis: Basis, film, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Internal nodal forces and tangent stiffness (dense) of the film at displacement `u`.

    Raises `numpy.linalg.LinAlgError` when an element is inverted (J <= 0).
    """
    lam, mu = lame_parameters(film.modulus_mpa, film.poisson)
    uh = basis.interpolate(u)
    jac = (1 + uh.grad[0, 0]) * (1 + uh.grad[1, 1]) - uh.grad[0, 1] * uh.grad[1, 0]
    if np.any(jac <= 0.0) or np.any(1 + uh[0] / basis.global_coordinates()[0] <= 0.0):
        raise np.linalg.LinAlgError("film element inverted (J <= 0)")
    f = _internal_force.assemble(basis, u=uh, lam=lam, mu=mu)
    if not np.all(np.isfinite(f)):
        raise np.linalg.LinAlgError("film element inverted (J <= 0)")
    K = _tangent.assemble(basis, u=uh, lam=lam, mu=mu).toarray()
    return f, K
