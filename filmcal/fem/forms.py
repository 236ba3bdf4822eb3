"""Weak forms of axisymmetric elasticity (forms as plain functions).

Displacement u = (u_r, u_z); strains eps_rr = du_r/dr, eps_zz = du_z/dz,
eps_tt = u_r / r, gamma_rz = du_r/dz + du_z/dr. Integrals carry the full
2 pi r weight, so that assembled nodal forces are forces in newton.

The film's volumetric term (the one multiplied by lambda) is integrated at one
point per element, the rest at the full rule (selective reduced integration,
`film_bases`): fully integrated bilinear quads lock as the film nears
incompressibility (nu >= 0.4 read its edge 0.004-0.013 mm inside a second
formulation's at h = 0.1 mm); the shear and deviatoric terms at the full rule
keep the element free of hourglass modes.
"""
from __future__ import annotations

import numpy as np
from skfem import Basis, BilinearForm, LinearForm

from filmcal.elastic import lame_parameters, oedometric_modulus_mpa

__all__ = ["lame_parameters", "oedometric_modulus_mpa", "linear_elasticity", "axial_traction", "film_bases",
           "film_stiffness_parts"]


def _strains(u, r):
    """(eps_rr, eps_zz, eps_tt, gamma_rz) as plain arrays (plain ndarrays are much
    faster here than skfem's field objects)."""
    g = np.asarray(u.grad)
    return (g[0, 0], g[1, 1], np.asarray(u)[0] / r, g[0, 1] + g[1, 0])


@BilinearForm
def linear_elasticity(u, v, w):
    """Axisymmetric isotropic elasticity with Lame parameters ``w.lam``, ``w.mu``."""
    r = np.asarray(w.x[0])
    eu, ev = _strains(u, r), _strains(v, r)
    tr_u = eu[0] + eu[1] + eu[2]
    tr_v = ev[0] + ev[1] + ev[2]
    normal = eu[0] * ev[0] + eu[1] * ev[1] + eu[2] * ev[2]
    return (w.lam * tr_u * tr_v + 2.0 * w.mu * normal + w.mu * eu[3] * ev[3]) * 2.0 * np.pi * r


@LinearForm
def axial_traction(v, w):
    """Uniform traction ``w.traction`` (MPa, positive along +z) on a boundary."""
    return w.traction * v[1] * 2.0 * np.pi * w.x[0]


#: One Gauss point at the centre of the reference square [0, 1]^2, weight 1.
_CENTRE_RULE = (np.array([[0.5], [0.5]]), np.array([1.0]))


def film_bases(mesh, element) -> tuple[Basis, Basis]:
    """The film's bases: (full rule, one point per element) on the same DOFs."""
    return Basis(mesh, element), Basis(mesh, element, quadrature=_CENTRE_RULE)


def film_stiffness_parts(full: Basis, centre: Basis) -> tuple[np.ndarray, np.ndarray]:
    """(K_lam, K_mu), dense: the film's stiffness is ``lam * K_lam + mu * K_mu``.

    K_lam (the volumetric term) is integrated at the element centres, K_mu at
    the full rule.
    """
    K_lam = linear_elasticity.assemble(centre, lam=1.0, mu=0.0).toarray()
    K_mu = linear_elasticity.assemble(full, lam=0.0, mu=1.0).toarray()
    return K_lam, K_mu
