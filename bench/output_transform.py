"""Which output transform each radius surrogate of a study should have: log or standardised excess.

Every surrogate of the study is fitted again on its own training runs (or, with
``--design-alone``, on the Latin hypercube alone, without the runs at the data's
cases: the design of a study made with ``--moduli-per-case 0``, such as
``--quick``) once with each output transform, with the same GP settings and seed.
For each it prints the evidence of the excesses (the log marginal likelihood of
the physical outputs, Jacobian included: what ``output_transform="auto"``
compares) and the held-out radius rms, max and 90 % coverage on the study's
validation runs: whether the transform the evidence picks is the one that
predicts better. Nothing in the study is written.

    python bench/output_transform.py --study-dir filmcal-study [--design-alone]
"""
from __future__ import annotations

import argparse
import json
import time

import numpy as np

from case_runs import _split


def main(argv=None) -> int:
    from filmcal.hertz import hertz_radius_mm
    from filmcal.study import Study
    from filmcal.surrogate import GPSurrogate, load_surrogate

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study-dir", default="filmcal-study")
    ap.add_argument("--design-alone", action="store_true",
                    help="refit without the runs at the data's cases (the design of --moduli-per-case 0)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    study = Study(args.study_dir)
    agree = total = 0
    stems = sorted(p.with_suffix("") for p in (study.layout.root / "surrogates").glob("*.json")
                   if not p.name.endswith("-validation.json"))
    for stem in stems:
        key = stem.name
        spec = study.manifest.entry(study.layout.relative(stem.with_suffix(".json")))["spec"]
        fe = spec["fe"]
        with_cases = load_surrogate(study.layout.surrogate(key))
        names = list(with_cases.input_names_)
        keep = np.ones(len(with_cases.y_train_), bool)
        if args.design_alone and fe.get("case_points"):
            keep = ~_split(with_cases, fe["case_points"], fe["moduli_per_case"], fe["domain"]["modulus_mpa"])
        X = {n: with_cases.X_train_[keep, i] for i, n in enumerate(names)}
        y = with_cases.y_train_[keep]
        v = json.loads(study.layout.surrogate_validation(key).read_text())["points"]
        H = {n: np.asarray(v[n], float) for n in names}
        truth = np.asarray(v["radius_fe_mm"], float)
        hertz = hertz_radius_mm(H["sphere_radius_mm"], H["force_kn"] * 1e3)
        auto = GPSurrogate(**{**with_cases.get_params(), "output_transform": "auto"}).fit(X, y)
        print(f"{key} {spec['column']}, {fe['kinematics']} strain: {len(y)} runs, "
              f"excess {y.min():.4f}..{y.max():.4f} mm; the evidence picks {auto.output_transform_.kind}")
        rms = {}
        for kind in auto.log_evidence_:
            gp = auto if kind == auto.output_transform_.kind else \
                GPSurrogate(**{**with_cases.get_params(), "output_transform": kind}).fit(X, y)
            mean, std = gp.predict(H, return_std=True, noise=True)
            err = mean + hertz - truth
            rms[kind] = float(np.sqrt(np.mean(err ** 2)))
            print(f"  {kind:12s} evidence {auto.log_evidence_[kind]:8.1f}   held out ({len(truth)} runs): radius rms "
                  f"{rms[kind]:.5f} mm, max {np.abs(err).max():.5f} mm, 90 % coverage "
                  f"{np.mean(np.abs(err) <= 1.6448536 * std):.2f}")
        if len(rms) == 2:
            total += 1
            agree += min(rms, key=rms.get) == auto.output_transform_.kind
    print(f"the evidence picked the transform with the lower held-out rms for {agree} of {total} surrogates "
          f"that could take either ({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
