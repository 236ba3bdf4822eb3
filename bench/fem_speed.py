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

    python bench/fem_speed.py [--sphere-radius-mm 450] [--force-kn 75]

With ``--edge-table`` it prints instead the verification table of the edge and
imprint readings: at h = 0.1 mm (the paper's mesh) against h = 0.0125 mm
meshes read independently -- the edge bracketed by the last node with positive
pressure and the first node without, the activation contours (MS 10, HS 50,
HHS 130 MPa) by linear interpolation of the nodal pressures -- and, without a
film, against Hertz's closed forms. It also times the reading against the solve.

    python bench/fem_speed.py --edge-table [--sphere-radius-mm 450] [--force-kn 75] [--fine-mm 0.0125]
                              [--kinematics large] [--moduli none,500,2800]
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


def edge_table(radius_mm: float, force_kn: float, fine_mm: float,
               moduli=(None, 500.0, 1000.0, 2800.0, 6300.0, 10000.0), kinematics: str = "small") -> None:
    """Print h = 0.1 mm readings against the fine-mesh and analytic references."""
    from filmcal.contact import read_radial_profile
    from filmcal.films import get_film
    from filmcal.fem import ContactOptions, MeshSettings
    from filmcal.hertz import hertz_max_pressure_mpa, hertz_radius_mm

    films = [get_film(n) for n in ("MS", "HS", "HHS")]
    force_n = force_kn * 1e3
    coarse_model = SphereOnFlat(radius_mm)
    t0 = time.perf_counter()
    fine_model = SphereOnFlat(radius_mm, MeshSettings(element_size_mm=fine_mm, contact_zone_mm=11.0))
    options = ContactOptions(kinematics=kinematics)
    print(f"R{radius_mm:g} / {force_kn:g} kN{', large-strain film' if kinematics == 'large' else ''}: h = 0.1 mm "
          f"readings against h = {fine_mm:g} mm (model built in {time.perf_counter() - t0:.0f} s)")
    print(f"{'E MPa':>7} {'edge 0.1':>9} {'ref':>9} {'bracket':>17} {'err':>7} {'old fit':>8} | "
          + " | ".join(f"{f.name} act 0.1 / ref / err" for f in films))
    worst_edge = worst_act = 0.0
    read_s = solve_s = 0.0
    for modulus in moduli:
        film = None if modulus is None else Film(modulus, 0.33)
        coarse = coarse_model.solve(film, force_n, options)
        fine = fine_model.solve(film, force_n, options)
        t1 = time.perf_counter()
        read_radial_profile(coarse.r_mm, coarse.pressure_mpa, coarse.edge_tip_mm)
        read_s += time.perf_counter() - t1
        solve_s += coarse.elapsed_s
        k = int(np.flatnonzero(fine.pressure_mpa > 0)[-1])
        lo, hi = float(fine.r_mm[k]), float(fine.r_mm[k + 1])
        if modulus is None:
            ref = hertz_radius_mm(radius_mm, force_n)
            p0 = hertz_max_pressure_mpa(radius_mm, force_n)
            act_ref = [ref * np.sqrt(1 - (f.activation_pressure_mpa / p0) ** 2) for f in films]
        else:
            ref = 0.5 * (lo + hi)
            act_ref = [_crossing(fine, f.activation_pressure_mpa) for f in films]
        err = coarse.contact_radius_mm - ref
        worst_edge = max(worst_edge, abs(err))
        old = _old_fit(coarse)
        cells = []
        for f, r_ref in zip(films, act_ref):
            got = coarse.read_imprint("activation", f)
            worst_act = max(worst_act, abs(got - r_ref))
            cells.append(f"{got:7.4f} / {r_ref:7.4f} / {got - r_ref:+.4f}")
        label = "none" if modulus is None else f"{modulus:g}"
        print(f"{label:>7} {coarse.contact_radius_mm:9.4f} {ref:9.4f} [{lo:7.4f}, {hi:7.4f}] {err:+7.4f} "
              f"{old:8.4f} | " + " | ".join(cells))
    print(f"largest |error|: edge {worst_edge:.4f} mm, activation {worst_act:.4f} mm "
          f"(reference: Hertz without film, else the bracket's middle, +-{fine_mm / 2:g} mm)")
    print(f"reading cost: {1e3 * read_s / len(moduli):.1f} ms per evaluation against "
          f"{1e3 * solve_s / len(moduli):.1f} ms per solve (noisy on a shared machine)")


def _crossing(res, level: float) -> float:
    """Outermost crossing of the nodal pressures with `level`, linear in p."""
    k = int(np.flatnonzero(res.pressure_mpa >= level)[-1])
    p0, p1 = res.pressure_mpa[k], res.pressure_mpa[k + 1]
    return float(res.r_mm[k] + (res.r_mm[k + 1] - res.r_mm[k]) * (p0 - level) / (p0 - p1))


def _old_fit(res) -> float:
    """The reading this package used before: b (a^2 - r^2)^gamma fitted to the nodal
    pressures between a - 1.0 and a - 0.2 mm (last node excluded), for the table only."""
    from scipy.optimize import least_squares

    r, p = res.r_mm, res.pressure_mpa
    k = int(np.flatnonzero(p > 0)[-1])
    a = float(r[k])
    for _ in range(3):
        sel = np.flatnonzero((r >= a - 1.0) & (r <= a - 0.2) & (p > 0))
        sel = sel[sel < k]
        b0 = p[sel[0]] / np.sqrt(max(a * a - r[sel[0]] ** 2, 1e-12))
        fit = least_squares(lambda q: (q[1] * np.clip(q[0] ** 2 - r[sel] ** 2, 1e-300, None) ** q[2] - p[sel])
                            / p[sel].max(), [max(a, r[sel[-1]] + 1e-6), b0, 0.5],
                            bounds=([r[sel[-1]] + 1e-9, 0, 0.3], [r[k + 1] + 1.0, np.inf, 1.5]),
                            x_scale=[0.1, b0, 0.1])
        a = float(fit.x[0])
    return a


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sphere-radius-mm", type=float, default=450.0)
    ap.add_argument("--force-kn", type=float, default=75.0)
    ap.add_argument("--edge-table", action="store_true", help="print the edge/imprint verification table")
    ap.add_argument("--fine-mm", type=float, default=0.0125, help="element size of the reference mesh")
    ap.add_argument("--kinematics", choices=("small", "large"), default="small",
                    help="film kinematics of the edge table (default small)")
    ap.add_argument("--moduli", default="none,500,1000,2800,6300,10000",
                    help="film moduli of the edge table (MPa; 'none' for no film)")
    args = ap.parse_args()
    if args.edge_table:
        with threadpool_limits(limits=1, user_api="blas"):
            moduli = tuple(None if m.strip() == "none" else float(m) for m in args.moduli.split(","))
            edge_table(args.sphere_radius_mm, args.force_kn, args.fine_mm, moduli, args.kinematics)
        return
    with threadpool_limits(limits=1, user_api="blas"):
        # warm the process (lazy imports, first-use set-up of numpy/scipy/skfem) on
        # another radius: "cold" below means no cached model for this radius
        SphereOnFlat(args.sphere_radius_mm * 1.5).solve(Film(2800.0, 0.33), args.force_kn * 1e3)
        t0 = time.perf_counter()
        model = SphereOnFlat(args.sphere_radius_mm)
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
    print(f"model R{args.sphere_radius_mm:g}, F = {args.force_kn:g} kN, h = {model.mesh.element_size_mm} mm, "
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
