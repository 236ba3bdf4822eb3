"""What the FE runs at the data's cases buy: each film's preferred surrogate with and without them.

For each film of a study (its preferred model, `summary.json`), the surrogate
the posterior was calibrated with is read, and a second one is fitted on the
same training runs less those at the data's cases (the Latin hypercube alone,
the same GP settings and seed). Both are asked at every case of the data at the
film's posterior median E, and both are checked on the study's held-out runs.
Nothing in the study is written.

    python bench/case_runs.py --study-dir filmcal-study

Prints per film: the std at each case (the std the likelihood adds to sigma^2)
of the hypercube alone with the output transform chosen by sign (log while
every excess over Hertz is positive: the rule before the evidence chose it,
`bench/output_transform.py`), of the hypercube alone with the transform
of the surrogate with the cases, and of the surrogate with the cases; and the
three surrogates' held-out radius rms and max.
"""
from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def _split(surrogate, case_points: list, moduli_per_case: int, domain_moduli) -> np.ndarray:
    """Rows of the surrogate's training set that are runs at the data's cases (`case_design_points`)."""
    X = surrogate.X_train_
    names = list(surrogate.input_names_)
    e, nu, r, f = (X[:, names.index(n)] for n in ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn"))
    grid = np.geomspace(*domain_moduli, moduli_per_case)
    at_case = np.zeros(len(X), bool)
    for cr, cf, cnu in case_points:
        at_case |= (np.isclose(r, cr) & np.isclose(f, cf) & np.isclose(nu, cnu)
                    & np.isclose(e[:, None], grid[None, :], rtol=1e-9).any(axis=1))
    return at_case


def main(argv=None) -> int:
    from filmcal.hertz import hertz_radius_mm
    from filmcal.study import Study
    from filmcal.surrogate import GPSurrogate, load_surrogate

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study-dir", default="filmcal-study")
    ap.add_argument("--model", action="append", metavar="LABEL",
                    help="a model such as activation/large, at its own posterior median (repeatable; default each "
                         "film's preferred model)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    study = Study(args.study_dir)
    summary = json.loads((Path(args.study_dir) / "summary.json").read_text())
    from filmcal.calibration import load_result

    jobs = [(film, label) for film, s in summary["films"].items()
            for label in (args.model or [(s.get("preferred_model") or {}).get("model") or s["model"]])]
    for film, label in jobs:
        found = [(p, sp) for p, sp in study.posteriors(film) if sp["model"] == label]
        if not found:
            print(f"{film} {label}: no posterior")
            continue
        (path, spec), = found
        median = float(load_result(path).modulus_mpa["median"])
        fe = spec["fe"]
        if not fe.get("case_points"):
            print(f"{film} {label}: its surrogate has no runs at the data's cases")
            continue
        key = study.manifest.entry(study.layout.relative(path))["surrogate"]
        stem = study.layout.surrogate(key)
        with_cases = load_surrogate(stem)
        at_case = _split(with_cases, fe["case_points"], fe["moduli_per_case"], fe["domain"]["modulus_mpa"])
        names = list(with_cases.input_names_)
        X = {n: with_cases.X_train_[~at_case, i] for i, n in enumerate(names)}
        y = with_cases.y_train_[~at_case]
        # the hypercube alone as it was fitted before the evidence chose the transform (log while every excess
        # over Hertz is positive) and with the transform of the surrogate with the cases
        before = GPSurrogate(**{**with_cases.get_params(), "output_transform": "log" if np.all(y > 0)
                                else "standardize"}).fit(X, y)
        transform = with_cases.output_transform_.kind
        alone = GPSurrogate(**{**with_cases.get_params(), "output_transform": transform}).fit(X, y)
        cases = np.array([c[:2] for c in fe["case_points"]])
        nu = fe["case_points"][0][2]
        Q = {"modulus_mpa": np.full(len(cases), median), "poisson": np.full(len(cases), nu),
             "sphere_radius_mm": cases[:, 0], "force_kn": cases[:, 1]}
        _, s_with = with_cases.predict(Q, return_std=True, noise=True)
        _, s_alone = alone.predict(Q, return_std=True, noise=True)
        _, s_before = before.predict(Q, return_std=True, noise=True)
        print(f"{film} {label} at E = {median:.0f} MPa, nu {nu:g}: {int(at_case.sum())} case runs of "
              f"{len(at_case)} training runs; output transform {before.get_params()['output_transform']} for the "
              f"hypercube alone, {transform} with the cases")
        print(f"  {'R mm':>6} {'F kN':>6} {'std: hypercube, by sign':>30} {'hypercube, ' + transform:>22} "
              f"{'with the cases':>15}")
        for (r, f), b, a, w in zip(cases, s_before, s_alone, s_with):
            print(f"  {r:6.0f} {f:6.0f} {b:30.4f} {a:22.4f} {w:15.4f}")
        v = json.loads(study.layout.surrogate_validation(key).read_text())["points"]
        H = {n: np.asarray(v[n], float) for n in names}
        truth = np.asarray(v["radius_fe_mm"], float)
        hertz = hertz_radius_mm(H["sphere_radius_mm"], H["force_kn"] * 1e3)
        for name, gp in (("hypercube, by sign", before), (f"hypercube, {transform}", alone),
                         ("with the cases", with_cases)):
            err = gp.predict(H) + hertz - truth
            print(f"  held out ({len(truth)} runs), {name}: radius rms {np.sqrt(np.mean(err ** 2)):.4f} mm, "
                  f"max {np.abs(err).max():.4f} mm")
    print(f"({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
