"""Speed of the axisymmetric FE model at the paper's resolution (h = 0.1 mm).

Measures, in one run on this machine:
  * t_factor: one sparse LU factorisation (SuperLU, best fill-reducing ordering
    scipy offers) of the full model's stiffness matrix: sphere body, film and
    flat assembled together, the film tied to both bodies, boundary conditions
    applied (the best of 3);
  * cold: building the model for one sphere radius (meshes, assembly,
    condensation of both steel bodies) plus its first evaluation, in a process
    that has built another radius before (so that one-time import and
    first-use costs of the libraries are not counted);
  * sweep: the mean cost of one evaluation over 100 (E, nu) points at fixed
    (R, F), on the built model.
Targets: sweep / t_factor <= 0.15, cold / t_factor <= 3.

    python bench/fem_speed.py [--radius-mm 450] [--force-kn 75]
"""
from __future__ import annotations

import argparse
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from skfem import Basis, ElementQuad1, ElementVector
from threadpoolctl import threadpool_limits

from filmcal.fem import Film, SphereOnFlat
from filmcal.fem.forms import lame_parameters, linear_elasticity


def full_stiffness(model: SphereOnFlat) -> sp.csc_matrix:
    """The whole model's stiffness (film tied to both bodies), fixed DOFs removed."""
    e = ElementVector(ElementQuad1())
    lam, mu = lame_parameters(model.steel_modulus_mpa, model.steel_poisson)
    sb, fb, mb = Basis(model.sphere.mesh, e), Basis(model.flat.mesh, e), Basis(model.film.mesh, e)
    Ks = linear_elasticity.assemble(sb, lam=lam, mu=mu)
    Kf = linear_elasticity.assemble(fb, lam=lam, mu=mu)
    fl, fm = lame_parameters(2800.0, 0.33)
    Km = linear_elasticity.assemble(mb, lam=fl, mu=fm)
    n_s, n_f = sb.N, fb.N
    # film DOFs map onto the bodies' face DOFs where they coincide (tied), else new DOFs
    index = n_s + n_f + np.arange(mb.N)
    for j, body_basis, grid, offset in ((0, fb, model.flat, n_s), (-1, sb, model.sphere, 0)):
        film_nodes = model.film.node_at[:, j]
        body_nodes = grid.node_at[: len(film_nodes), 0]
        for c in range(2):
            index[mb.nodal_dofs[c, film_nodes]] = offset + body_basis.nodal_dofs[c, body_nodes]
    used = np.unique(np.concatenate([np.arange(n_s + n_f), index]))
    remap = -np.ones(n_s + n_f + mb.N, int)
    remap[used] = np.arange(len(used))
    P = sp.csr_matrix((np.ones(mb.N), (np.arange(mb.N), remap[index])), shape=(mb.N, len(used)))
    Ps = sp.csr_matrix((np.ones(n_s), (np.arange(n_s), remap[np.arange(n_s)])), shape=(n_s, len(used)))
    Pf = sp.csr_matrix((np.ones(n_f), (np.arange(n_f), remap[n_s + np.arange(n_f)])), shape=(n_f, len(used)))
    K = Ps.T @ Ks @ Ps + Pf.T @ Kf @ Pf + P.T @ Km @ P
    fixed = np.concatenate([
        remap[sb.nodal_dofs[0, model.sphere.node_at[0, :]]],
        remap[n_s + fb.nodal_dofs[0, model.flat.node_at[0, :]]],
        remap[n_s + fb.nodal_dofs[1, model.flat.node_at[:, -1]]],
        [remap[sb.nodal_dofs[1, model.sphere.node_at[0, -1]]]],
    ])
    free = np.setdiff1d(np.arange(len(used)), fixed)
    return sp.csc_matrix(K.tocsr()[free][:, free])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--radius-mm", type=float, default=450.0)
    ap.add_argument("--force-kn", type=float, default=75.0)
    args = ap.parse_args()
    with threadpool_limits(limits=1, user_api="blas"):
        # warm the process (lazy imports, first-use set-up of numpy/scipy/skfem) on
        # another radius: "cold" below means no cached model for this radius
        SphereOnFlat(args.radius_mm * 1.5).solve(Film(2800.0, 0.33), args.force_kn * 1e3)
        t0 = time.perf_counter()
        model = SphereOnFlat(args.radius_mm)
        first = model.solve(Film(2800.0, 0.33), args.force_kn * 1e3)
        cold = time.perf_counter() - t0
        K = full_stiffness(model)
        t_factor = min(_timed(lambda: spla.splu(K, permc_spec="MMD_AT_PLUS_A")) for _ in range(3))
        rng = np.random.default_rng(0)
        moduli = np.exp(rng.uniform(np.log(500.0), np.log(10000.0), 100))
        poissons = rng.uniform(0.0, 0.45, 100)
        t0 = time.perf_counter()
        results = [model.solve(Film(e, nu), args.force_kn * 1e3) for e, nu in zip(moduli, poissons)]
        sweep = (time.perf_counter() - t0) / len(results)
    n_ok = sum(r.converged for r in results)
    print(f"model R{args.radius_mm:g}, F = {args.force_kn:g} kN, h = {model.mesh.element_size_mm} mm, "
          f"contact zone {model.r_face_mm[-1]:.1f} mm ({model.n_face} face nodes)")
    print(f"DOFs: full model {K.shape[0]} (after boundary conditions), bodies + film {model.n_dofs}")
    print(f"one sparse factorisation of the full stiffness (SuperLU, MMD(A'+A)): {t_factor * 1e3:8.1f} ms")
    print(f"  (for comparison, the cold evaluation below condensed both steel bodies in {1e3 * (model.sphere_body.factor_time_s + model.flat_body.factor_time_s):.1f} ms of factorisation)")
    print(f"cold single evaluation (build + condense + solve):     {cold * 1e3:8.1f} ms   ratio {cold / t_factor:5.2f}  (target <= 3)")
    print(f"sweep, mean per evaluation over 100 (E, nu) points:    {sweep * 1e3:8.1f} ms   ratio {sweep / t_factor:5.3f} (target <= 0.15)")
    print(f"sweep points converged: {n_ok}/100; first evaluation a = {first.contact_radius_mm:.4f} mm")


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
