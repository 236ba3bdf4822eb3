"""Calibration on Table 1 with the FE model in the loop: model comparison and cross-validation, timed.

The radius model is the FE model itself (`filmcal.fem`, default options: frictionless sphere, film tied to
the flat), tabulated at Table 1's ten (R, F) cases on a ladder of moduli and interpolated in ln E
(`filmcal.calibration.TabulatedRadiusModel`, interpolation error checked at the midpoints and used as the
model's std). Every imprint model (edge, activation, capsule) of every film type is read from the same
solves; small- and large-strain film kinematics are two sets of solves. Nothing depends on a study folder.

Four steps (each prints its own timings; the machine's load average is printed with them):

    python bench/calibration_speed.py tables [--kinematics small large] [--nodes 9] [--cache FILE]
        FE tables (10 cases x nodes x kinematics), cached as JSON.
    python bench/calibration_speed.py compare --film HS [--cache FILE]
        Per imprint model x kinematics: E median and 90 %, rms residual, ppc_inside_90, ELPD-LOO +/- SE,
        max Pareto k, stacking weight and combination weight; seconds per calibration.
    python bench/calibration_speed.py crossval --film HS [--model activation-small|combined] [--exact]
        Leave-one-case-out of the sphere correction: PSIS from one posterior (refits where k > 0.7)
        against ten exact refits (one model); time ratio, refits, hits, band width as % of the area,
        largest difference of the corrected areas. ``combined``: every model, weighted as `compare`.
    python bench/calibration_speed.py lot [--seeds 5]
        A user film lot (0.1 mm) from FE imprints at E = 2600 MPa off Table 1's grid (R 350/500 mm,
        F 40/60/90 kN, two repeats, scatter 0.03 mm, stated 0.01 mm), calibrated back from its CSV per
        noise seed: how often the known E is inside the 90 % interval, the median's error.
"""
from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from filmcal.calibration import (CalibrationProblem, Priors, TabulatedRadiusModel, calibrate, compare_models,
                                 load_table1, posterior_inference_data)
from filmcal.films import FILM_TYPES, get_film

IMPRINTS = ("edge", "activation", "capsule")
DEFAULT_CACHE = Path("/tmp/filmcal-bench-fe-tables.json")


def load() -> str:
    return "load average " + " ".join(f"{x:.2f}" for x in os.getloadavg())


def cases() -> list[tuple[float, float]]:
    data = load_table1("HS")  # the same ten (R, F) cases for every film
    return list(zip(data.sphere_radius_mm.tolist(), data.force_n.tolist()))


def build_tables(kinematics: list[str], nodes: int, path: Path) -> dict:
    from filmcal.fem import ContactOptions, Film, solve_sphere_on_flat

    films = {name: get_film(name) for name in FILM_TYPES}
    nu = films["HS"].poisson
    moduli = np.geomspace(400.0, 20000.0, nodes)
    checks = np.sqrt(moduli[:-1] * moduli[1:])[::2]  # midpoints in ln E, every other interval
    out = json.loads(path.read_text()) if path.exists() else {}
    for kin in kinematics:
        t0 = time.perf_counter()
        options = ContactOptions(kinematics=kin)
        table = {f"{imp}-{film}": {"node": [], "check": []} for imp in IMPRINTS for film in films}
        solves = 0
        for R, F in cases():
            for key, ladder in (("node", moduli), ("check", checks)):
                rows = {k: [] for k in table}
                for E in ladder:
                    res = solve_sphere_on_flat(R, F, Film(float(E), nu), options=options)
                    solves += 1
                    for imp in IMPRINTS:
                        for name, film in films.items():
                            rows[f"{imp}-{name}"].append(res.read_imprint(imp, film) if res.converged else None)
                for k in table:
                    table[k][key].append(rows[k])
        out[kin] = {"moduli_mpa": moduli.tolist(), "check_mpa": checks.tolist(), "poisson": nu, "cases": cases(),
                    "sphere_radius_mm": table, "solves": solves, "elapsed_s": time.perf_counter() - t0}
        print(f"{kin}-strain tables: {solves} FE solves in {time.perf_counter() - t0:.1f} s ({load()})")
    path.write_text(json.dumps(out))
    return out


def models_of(tables: dict, film: str) -> dict[str, TabulatedRadiusModel]:
    out = {}
    for kin, t in tables.items():
        for imp in IMPRINTS:
            rows = t["sphere_radius_mm"][f"{imp}-{film}"]
            node, check = np.array(rows["node"], dtype=float), np.array(rows["check"], dtype=float)
            moduli = np.array(t["moduli_mpa"])
            usable = np.all(np.isfinite(node), axis=0)  # drop moduli where some case failed (film collapse)
            model = TabulatedRadiusModel(t["cases"], moduli[usable], node[:, usable], t["poisson"])
            lo, hi = model.modulus_range_mpa
            inside = (np.array(t["check_mpa"]) > lo) & (np.array(t["check_mpa"]) < hi)
            errors = [abs(model.predict(e, t["poisson"], r, f)[0] - check[i, j])
                      for i, (r, f) in enumerate(t["cases"]) for j, e in enumerate(t["check_mpa"]) if inside[j]]
            model.std_mm = max(float(np.nanmax(errors)), 0.002)
            out[f"{imp}-{kin}"] = model
    return out


def calibrate_all(film: str, models: dict, seed: int) -> dict:
    data = load_table1(film)
    out = {}
    for name, model in models.items():
        priors = Priors.for_film(get_film(film), modulus_range_mpa=model.modulus_range_mpa)
        t0 = time.perf_counter()
        result = calibrate(data, model, film=film, priors=priors, seed=seed)
        problem = CalibrationProblem(data, model, priors)
        out[name] = (problem, posterior_inference_data(problem, result.samples, name, max_draws=250), result,
                     time.perf_counter() - t0)
    return out


def cmd_compare(args, tables) -> None:
    t0 = time.perf_counter()
    fits = calibrate_all(args.film, models_of(tables, args.film), args.seed)
    comparison = compare_models({k: v[:2] for k, v in fits.items()})
    print(f"{args.film}: {len(fits)} calibrations in {time.perf_counter() - t0:.1f} s ({load()})")
    print(f"{'model':20s} {'E_med':>6s} {'E_ci90':>13s} {'std_mm':>6s} {'rms_mm':>6s} {'ppc90':>5s} "
          f"{'elpd_loo':>13s} {'k_max':>5s} {'stack':>5s} {'weight':>6s} {'ok':>5s} {'time_s':>6s}")
    for name, (problem, _, result, secs) in fits.items():
        a = comparison.assessments[name]
        ci = result.modulus_mpa["ci90"]
        print(f"{name:20s} {result.modulus_mpa['median']:6.0f} {f'{ci[0]:.0f}-{ci[1]:.0f}':>13s} "
              f"{problem.model.std_mm:6.4f} {a.rms_residual_mm:6.3f} {a.ppc_inside_90:2d}/{a.n_data:<2d} "
              f"{f'{a.elpd_loo:.1f}+/-{a.elpd_loo_se:.1f}':>13s} {a.pareto_k_max:5.2f} "
              f"{comparison.stacking_weights[name]:5.2f} {comparison.weights[name]:6.2f} "
              f"{str(result.diagnostics_ok):>5s} {secs:6.1f}")
    r600 = [(name, float(v[2].predictive.standardized_residual[(v[0].data.sphere_radius_mm == 600)
                                                              & (v[0].data.force_n == 25e3)][0]))
            for name, v in fits.items()]
    print("R600/25 kN standardised residual: " + ", ".join(f"{n} {z:+.2f}" for n, z in r600))
    print(f"preferred: {comparison.preferred}; pseudo-BMA+ weights: "
          + ", ".join(f"{k} {w:.2f}" for k, w in comparison.weights.items()))


def cmd_crossval(args, tables) -> None:
    from filmcal.correction.crossval import psis_leave_one_case_out

    all_models = models_of(tables, args.film)
    data = load_table1(args.film)
    names = list(all_models) if args.model == "combined" else [args.model]
    priors = {n: Priors.for_film(get_film(args.film), modulus_range_mpa=all_models[n].modulus_range_mpa)
              for n in names}
    refits = []

    def refit(name, fold_data):
        refits.append(name)
        return calibrate(fold_data, all_models[name], film=args.film, priors=priors[name], seed=args.seed).samples

    t0 = time.perf_counter()
    fits = {n: (CalibrationProblem(data, all_models[n], priors[n]),
                calibrate(data, all_models[n], film=args.film, priors=priors[n], seed=args.seed)) for n in names}
    weights = None
    if len(names) > 1:
        comparison = compare_models({n: (p, posterior_inference_data(p, r.samples, n, max_draws=250))
                                     for n, (p, r) in fits.items()})
        weights = comparison.weights
        print("weights: " + ", ".join(f"{n} {w:.2f}" for n, w in weights.items()))
    t_full = time.perf_counter() - t0
    psis = psis_leave_one_case_out({n: (p, r.samples) for n, (p, r) in fits.items()}, weights, refit=refit,
                                   film=args.film, random_state=args.seed)
    t_psis = time.perf_counter() - t0
    model = all_models[names[0]]
    priors = priors[names[0]]
    print(f"{args.film} {args.model}: PSIS leave-one-case-out {t_psis:.1f} s ({len(names)} full calibrations "
          f"{t_full:.1f} s, {len(refits)} refits for Pareto k > 0.7 over {len(data)} folds x {len(names)} models), "
          f"hits {psis.hits}/{len(data)}, band (90 %) median {np.median(psis.band_percent):.1f} % of the area, "
          f"range {np.min(psis.band_percent):.1f}-{np.max(psis.band_percent):.1f} % ({load()})")
    print("Pareto k: " + " ".join(f"{k:.2f}" for k in psis.pareto_k))
    if not args.exact or len(names) > 1:
        return
    from filmcal.correction.sphere import SphereCorrector

    t0 = time.perf_counter()
    exact_rows = []
    for case in range(len(data)):
        keep = np.arange(len(data)) != case
        result = calibrate(data.select(keep), model, film=args.film, priors=priors, seed=args.seed)
        samples = {"modulus_mpa": result.samples["modulus_mpa"], "sigma_mm": result.samples["sigma_mm"],
                   "poisson": np.full(result.samples["sigma_mm"].shape, priors.poisson)}
        corrected = SphereCorrector(model, samples, random_state=args.seed).correct(
            data.measured_radius_mm[case], data.sphere_radius_mm[case], data.force_n[case])
        exact_rows.append((float(corrected.area_mm2), float(corrected.area_std_mm2),
                           [float(x) for x in corrected.area_ci90_mm2]))
    t_exact = time.perf_counter() - t0
    mean = np.array([r[0] for r in exact_rows])
    std = np.array([r[1] for r in exact_rows])
    ci = np.array([r[2] for r in exact_rows])
    hertz = np.pi * data.hertz_radius_mm**2
    hits = int(np.sum((ci[:, 0] <= hertz) & (hertz <= ci[:, 1])))
    print(f"exact refits: {len(data)} calibrations in {t_exact:.1f} s; hits {hits}/{len(data)}; "
          f"PSIS / exact time {t_psis / t_exact:.2f}; largest |PSIS - exact| corrected mean "
          f"{np.max(np.abs(psis.area_mm2 - mean) / std):.2f} std, std ratio "
          f"{np.min(psis.area_std_mm2 / std):.2f}-{np.max(psis.area_std_mm2 / std):.2f}")


def cmd_lot(args) -> None:
    """A user film lot (thickness 0.1 mm) from FE imprints at E = 2600 MPa, calibrated back from its CSV."""
    import tempfile

    from filmcal.calibration import load_dataset
    from filmcal.fem import Film, solve_sphere_on_flat
    from filmcal.films import FilmType

    film = FilmType("LOT7", activation_pressure_mpa=45.0, thickness_mm=0.1)
    e_true, scatter, stated = 2600.0, 0.03, 0.01
    lot_cases = [(R, F) for R in (350.0, 500.0) for F in (40e3, 60e3, 90e3)]

    def fe_radius(E, nu, R, F):
        return solve_sphere_on_flat(R, F, Film(E, nu), film_thickness_mm=film.thickness_mm).contact_radius_mm

    t0 = time.perf_counter()
    truth = {case: fe_radius(e_true, film.poisson, *case) for case in lot_cases}
    model = TabulatedRadiusModel.from_function(fe_radius, lot_cases, [1200.0, 1800.0, 2700.0, 4000.0, 6000.0],
                                               film.poisson)
    model.std_mm = max(model.max_error_mm(fe_radius, [1500.0, 2200.0, 3300.0, 4900.0]), 0.002)
    print(f"LOT7 FE tables in {time.perf_counter() - t0:.1f} s; interpolation error {model.std_mm:.4f} mm ({load()})")
    inside, errors = 0, []
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(args.seeds):
            rng = np.random.default_rng(seed)
            lines = ["film,sphere_radius_mm,force_kn,measured_radius_mm,repeat,measurement_std_mm"]
            for (R, F), r in truth.items():
                for repeat in (1, 2):
                    noisy = r + np.hypot(scatter, stated) * rng.standard_normal()
                    lines.append(f"LOT7,{R:g},{F / 1e3:g},{noisy:.4f},{repeat},{stated}")
            path = Path(folder) / f"lot7-{seed}.csv"
            path.write_text("\n".join(lines) + "\n")
            data = load_dataset(path).select(film)
            t1 = time.perf_counter()
            result = calibrate(data, model, film=film.name, seed=seed,
                               priors=Priors.for_film(film, modulus_range_mpa=model.modulus_range_mpa))
            lo, hi = result.modulus_mpa["ci90"]
            med = result.modulus_mpa["median"]
            inside += int(lo < e_true < hi)
            errors.append(100 * (med / e_true - 1))
            print(f"noise seed {seed}: E median {med:.0f} MPa ({errors[-1]:+.2f} %), 90 % [{lo:.0f}, {hi:.0f}], "
                  f"sigma {result.sigma_mm['median']:.4f} mm, case sigma {result.case_sigma_mm['median']:.4f} mm, "
                  f"{time.perf_counter() - t1:.1f} s")
    print(f"known E inside the 90 % interval in {inside}/{args.seeds}; |median error| max "
          f"{max(abs(e) for e in errors):.2f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("step", choices=("tables", "compare", "crossval", "lot"))
    parser.add_argument("--seeds", type=int, default=5, help="lot: noise seeds")
    parser.add_argument("--cache", type=Path, default=DEFAULT_CACHE)
    parser.add_argument("--kinematics", nargs="+", choices=("small", "large"), default=["small"])
    parser.add_argument("--nodes", type=int, default=9)
    parser.add_argument("--film", choices=FILM_TYPES, default="HS")
    parser.add_argument("--model", default="activation-small",
                        help="crossval: imprint-kinematics (e.g. edge-small), or 'combined' for the weighted mixture")
    parser.add_argument("--exact", action="store_true", help="crossval: also the ten exact refits")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.step == "tables":
        build_tables(args.kinematics, args.nodes, args.cache)
        return
    if args.step == "lot":
        cmd_lot(args)
        return
    if not args.cache.exists():
        parser.error(f"no FE tables at {args.cache}; run the 'tables' step first")
    tables = json.loads(args.cache.read_text())
    (cmd_compare if args.step == "compare" else cmd_crossval)(args, tables)


if __name__ == "__main__":
    main()
