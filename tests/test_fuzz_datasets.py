"""Datasets that load but cannot be calibrated are refused by the command before any work: exit 2, one line on
stderr, nothing written (the folder's files hashed before and after); the likelihood never gives NaN."""
from __future__ import annotations

import hashlib
import subprocess
import sys

import numpy as np
import pytest

HEADER = "film,sphere_radius_mm,force_kn,radius_error_mm\n"


def _snapshot(folder) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("command, rows, says", [
    (["calibrate", "--film", "HS"], "HS,450,75,1.1\nHS,450,75,1.1\n", "all of one case"),
    (["calibrate", "--film", "HS"], "HS,450,75,1.1\nHS,450,75,1.1\nHS,450,50,1.0\n",
     "comparing its imprint models leaves one case out at a time and needs at least 3"),
    (["pipeline", "--films", "HS", "--smoke"], "HS,450,75,1.1\nHS,450,50,1.0\n", "needs at least 3"),
    (["calibrate", "--film", "HS", "--forces-kn", "1000-2000"], "HS,450,75,1.1\nHS,450,50,1.0\n", "0 row(s)"),
    (["calibrate", "--film", "HS", "--imprint-model", "edge"], "HS,450,75,1.1\n", "1 row(s)"),
])
def test_data_that_cannot_be_calibrated_are_refused_before_any_work(tmp_path, command, rows, says):
    (tmp_path / "lab.csv").write_text(HEADER + rows)
    before = _snapshot(tmp_path)
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", *command, "--data", "lab.csv", "--study-dir", "study"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr[-2000:]
    assert len(p.stderr.strip().splitlines()) == 1 and says in p.stderr, p.stderr
    assert _snapshot(tmp_path) == before and not (tmp_path / "study").exists()


@pytest.mark.parametrize("column, value, says", [
    ("flat_ra_um", "1e6", "0 (smooth) or in [0.01, 30] um"),  # ran the FE campaign, then exit 70
    ("flat_ra_um", "1e-308", "0 (smooth) or in [0.01, 30] um"),
    ("measurement_std_mm", "1000", "more than 0.25 of the Hertz radius"),  # was calibrated as a scatter
])
def test_implausible_columns_are_refused_when_the_dataset_loads(tmp_path, column, value, says):
    rows = "".join(f"HS,{r},{f},1.0,{value}\n" for r, f in ((300, 25), (450, 50), (600, 75)))
    (tmp_path / "lab.csv").write_text(HEADER.strip() + f",{column}\n" + rows)
    before = _snapshot(tmp_path)
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "calibrate", "--film", "HS", "--data", "lab.csv",
                        "--study-dir", "study"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2, p.stderr[-2000:]
    assert len(p.stderr.strip().splitlines()) == 1 and says in p.stderr and column in p.stderr, p.stderr
    assert _snapshot(tmp_path) == before and not (tmp_path / "study").exists()


def test_repeats_that_read_alike_never_make_the_likelihood_nan():
    """Two imprints of one case read alike: as sigma -> 0 the case's variance terms overflowed into NaN (which
    stopped the sampler); the sigma floor and the overflow-safe form give finite values or -inf."""
    from filmcal.calibration.datasets import _parse
    from filmcal.calibration.likelihood import CalibrationProblem
    from toymodels import ToyRadiusModel

    data = _parse((HEADER + "HS,450,75,1.1\nHS,450,75,1.1\nHS,450,50,1.0\n").encode(), "x", "x.csv").select("HS")
    problem = CalibrationProblem(data, ToyRadiusModel())
    rng = np.random.default_rng(0)
    n = 50_000
    theta = np.column_stack([rng.uniform(5, 10, n), rng.uniform(-300, 300, n), rng.uniform(-300, 300, n)])
    with np.errstate(all="ignore"):
        lp = problem.log_posterior(theta)
    assert not np.isnan(lp).any()
    assert np.isfinite(lp).sum() > n // 10  # the support is not empty


def _repeats_problem():
    from filmcal.calibration.datasets import _parse
    from filmcal.calibration.likelihood import CalibrationProblem
    from toymodels import ToyRadiusModel

    cases = [(450, 75)] * 4 + [(300, 50)] * 2 + [(600, 100)]
    text = HEADER + "".join(f"HS,{r},{f},{1.0 + 0.05 * np.sin(i):.4f}\n" for i, (r, f) in enumerate(cases))
    return CalibrationProblem(_parse(text.encode(), "x", "x.csv").select("HS"), ToyRadiusModel())


def test_the_closed_form_likelihood_of_repeats_equals_the_sequential_one():
    """The sampler's per-case closed form (determinant lemma, Sherman-Morrison: linear in the rows) against
    the chain of conditional densities that `pointwise_log_likelihood` sums (a second formulation)."""
    problem = _repeats_problem()
    rng = np.random.default_rng(1)
    theta = np.column_stack([rng.uniform(6, 9, 500), rng.uniform(-6, 0, 500), rng.uniform(-8, 1, 500)])
    sequential = problem.pointwise_log_likelihood(theta).sum(axis=1)
    closed = problem.log_likelihood(theta)
    assert np.allclose(closed, sequential, rtol=1e-10, atol=1e-9)


def test_repeats_that_read_alike_share_their_predictive_interval_and_case_interval():
    from filmcal.calibration.checks import case_modulus_intervals, predictive_check

    problem = _repeats_problem()
    y = problem.target_radius_mm.copy()
    problem.target_radius_mm[1] = y[0]  # two repeats of the first case read alike
    theta = np.column_stack([np.full(50, np.log(2800.0)), np.full(50, np.log(0.1)), np.full(50, np.log(0.05))])
    check = predictive_check(problem, theta)
    assert check.lower_mm[0] == check.lower_mm[1] and check.upper_mm[0] == check.upper_mm[1]
    assert check.lower_mm[0] == check.lower_mm[2]  # same case, another reading: same predictive interval
    assert check.lower_mm[4] < check.lower_mm[0]  # another case: its own interval (R 300 mm, 50 kN reads smaller)
    cases = case_modulus_intervals(problem, 0.1)
    assert cases.modulus_mpa[0] == cases.modulus_mpa[1] and cases.modulus_mpa[0] != cases.modulus_mpa[2]
