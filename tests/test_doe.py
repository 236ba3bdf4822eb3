"""Tests of filmcal.doe: design spaces, optimal Latin hypercubes, metrics, CLI."""
from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import qmc

from filmcal.cli import main
from filmcal.doe import (DesignSpace, OptimalLatinHypercube, Parameter, augment_design,
                         centered_l2, design_quality, is_latin, latin_design,
                         max_abs_correlation, min_distance, parse_parameter, phi_p,
                         read_design_csv, write_design_csv)


def cells_are_permutations(sample: np.ndarray) -> bool:
    """Latin property checked directly: each column has one point per cell."""
    n = len(sample)
    return all(sorted(np.floor(col * n).astype(int)) == list(range(n)) for col in sample.T)


# --- metrics against values computed by hand or by a second formula -------------

TRIANGLE = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.5]])   # distances 1, 0.5, sqrt(1.25)


def test_min_distance_and_phi_p_of_a_hand_computed_design():
    assert min_distance(TRIANGLE) == pytest.approx(0.5)
    assert phi_p(TRIANGLE, p=2) == pytest.approx(math.sqrt(1.0 + 4.0 + 1.0 / 1.25))
    expected_50 = math.fsum([1.0, 0.5 ** -50, 1.25 ** -25]) ** (1 / 50)
    assert phi_p(TRIANGLE) == pytest.approx(expected_50, rel=1e-12)


def test_phi_p_of_repeated_point_is_infinite():
    assert phi_p(np.array([[0.2, 0.3], [0.2, 0.3], [0.9, 0.1]])) == math.inf


def hickernell_cd2(x: np.ndarray) -> float:
    """Squared centred L2 discrepancy, Hickernell (1998) closed form, by loops."""
    n, d = x.shape
    z = np.abs(x - 0.5)
    second = sum(np.prod(1 + z[i] / 2 - z[i] ** 2 / 2) for i in range(n))
    third = sum(np.prod(1 + z[i] / 2 + z[j] / 2 - np.abs(x[i] - x[j]) / 2)
                for i in range(n) for j in range(n))
    return (13 / 12) ** d - 2 / n * second + third / n ** 2


def test_centered_l2_matches_the_closed_form():
    assert centered_l2(np.array([[0.5]])) == pytest.approx(1 / 12)   # 13/12 - 2 + 1
    x = np.random.default_rng(3).random((7, 3))
    assert centered_l2(x) == pytest.approx(hickernell_cd2(x), rel=1e-12)


def test_max_abs_correlation():
    square = np.array([[0.1, 0.1], [0.1, 0.9], [0.9, 0.1], [0.9, 0.9]])
    assert max_abs_correlation(square) == pytest.approx(0.0, abs=1e-15)
    x = np.linspace(0.05, 0.95, 10)
    assert max_abs_correlation(np.column_stack([x, x[::-1], np.roll(x, 3)])) == pytest.approx(1.0)


def test_is_latin():
    assert is_latin(np.array([[0.1, 0.6], [0.7, 0.2]]))
    assert not is_latin(np.array([[0.1, 0.6], [0.2, 0.2]]))     # two points in cell 0
    assert not is_latin(np.array([[0.1, 0.6], [1.0, 0.2]]))     # 1.0 lies outside [0, 1)


def test_metrics_reject_bad_samples():
    with pytest.raises(ValueError, match="at least 2 points"):
        min_distance(np.array([[0.5, 0.5]]))
    with pytest.raises(ValueError, match="shape"):
        phi_p(np.arange(4.0))
    with pytest.raises(ValueError, match="unit cube"):
        centered_l2(np.array([[0.5, 1.5], [0.1, 0.2]]))


# --- the optimal Latin hypercube engine ------------------------------------------

def test_designs_are_latin_at_cell_centres():
    n = 23
    sample = OptimalLatinHypercube(3, seed=1, n_outer=20).random(n)
    assert sample.shape == (n, 3)
    assert cells_are_permutations(sample) and is_latin(sample)
    for column in sample.T:
        np.testing.assert_allclose(np.sort(column), (np.arange(n) + 0.5) / n, rtol=0, atol=1e-15)


def test_same_seed_same_design_different_seeds_differ():
    a = OptimalLatinHypercube(4, seed=7, n_outer=10).random(30)
    b = OptimalLatinHypercube(4, seed=7, n_outer=10).random(30)
    c = OptimalLatinHypercube(4, seed=8, n_outer=10).random(30)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    engine = OptimalLatinHypercube(4, seed=np.random.default_rng(7), n_outer=10)
    first = engine.random(30)
    assert not np.array_equal(first, engine.random(30))      # the stream moves on
    assert np.array_equal(first, engine.reset().random(30))  # reset starts over


def test_optimisation_improves_on_the_random_start():
    # n_outer=0 returns the pyDOE start that the optimiser would begin from.
    for seed in range(3):
        start = OptimalLatinHypercube(4, seed=seed, n_outer=0).random(40)
        best = OptimalLatinHypercube(4, seed=seed, n_outer=60).random(40)
        assert phi_p(best) < 0.8 * phi_p(start)
        assert min_distance(best) > 1.5 * min_distance(start)


def test_reaches_the_exhaustive_maximin_optimum_in_two_dimensions():
    # Second method: enumerate every 2-D Latin hypercube of 7 points.
    n = 7
    best_d2 = max(min((i - j) ** 2 + (p[i] - p[j]) ** 2
                      for i, j in itertools.combinations(range(n), 2))
                  for p in itertools.permutations(range(n)))
    sample = OptimalLatinHypercube(2, seed=0, n_outer=30).random(n)
    assert (min_distance(sample) * n) ** 2 == pytest.approx(best_d2)


def test_discrete_columns_are_optimised_as_realised():
    space = DesignSpace((Parameter("x", 0.0, 1.0), Parameter("y", 0.0, 1.0),
                         Parameter("sphere_radius_mm", levels=(300, 450, 600))))
    aware = latin_design(space, 45, seed=2, n_outer=40)
    plain = OptimalLatinHypercube(3, seed=2, n_outer=40).random(45)
    plain_realised = space.to_unit(space.to_physical(plain))
    assert aware.quality.min_distance > 1.5 * min_distance(plain_realised)
    assert aware.quality.phi_p < 0.7 * phi_p(plain_realised)
    counts = np.unique(aware.points[:, 2], return_counts=True)[1]
    assert list(counts) == [15, 15, 15]                       # balanced levels
    assert cells_are_permutations(aware.unit[:, :2])          # continuous columns Latin


def test_engine_rejects_bad_settings():
    with pytest.raises(ValueError, match="d must be"):
        OptimalLatinHypercube(0)
    with pytest.raises(ValueError, match="n must be"):
        OptimalLatinHypercube(2).random(1)
    with pytest.raises(ValueError, match="n_levels"):
        OptimalLatinHypercube(2, n_levels=[3])
    with pytest.raises(ValueError, match="p must be"):
        OptimalLatinHypercube(2, p=0.0)


# --- augmentation -----------------------------------------------------------------

def test_augment_keeps_old_points_stays_latin_and_beats_random_points():
    old = OptimalLatinHypercube(3, seed=4, n_outer=30).random(30)
    augmented = OptimalLatinHypercube(3, seed=5, n_outer=30).augment(old, 10)
    assert augmented.shape == (40, 3)
    assert np.array_equal(augmented[:30], old)
    assert cells_are_permutations(augmented)
    rng = np.random.default_rng(0)
    random_min = [min_distance(np.vstack([old, rng.random((10, 3))])) for _ in range(20)]
    assert min_distance(augmented) > max(random_min)
    unoptimised = OptimalLatinHypercube(3, seed=5, n_outer=0).augment(old, 10)
    assert phi_p(augmented) < phi_p(unoptimised)


def test_augment_a_jittered_design_uses_free_cells():
    old = qmc.LatinHypercube(d=2, seed=1).random(12)
    augmented = OptimalLatinHypercube(2, seed=0, n_outer=10).augment(old, 8)
    cells = np.floor(augmented * 20).astype(int)
    for k in range(2):
        new = cells[12:, k]
        assert len(set(new)) == 8 and not set(new) & set(cells[:12, k])
    one_more = OptimalLatinHypercube(2, seed=0).augment(old, 1)
    assert one_more.shape == (13, 2) and np.array_equal(one_more[:12], old)


def test_augment_rejects_bad_input():
    engine = OptimalLatinHypercube(2, seed=0)
    with pytest.raises(ValueError, match="m must be"):
        engine.augment(np.full((3, 2), 0.5), 0)
    with pytest.raises(ValueError, match="columns"):
        engine.augment(np.full((3, 3), 0.5), 2)
    with pytest.raises(ValueError, match="unit cube"):
        engine.augment(np.full((3, 2), 1.5), 2)


# --- design spaces ----------------------------------------------------------------

def test_linear_log_discrete_and_fixed_mapping():
    lin = Parameter("poisson", 0.0, 0.49)
    log = Parameter("modulus_mpa", 50.0, 5000.0, unit="MPa", scale="log")
    levels = Parameter("sphere_radius_mm", levels=(600, 300, 450))
    fixed = Parameter("force_kn", fixed=75.0)
    u = np.array([0.0, 0.25, 0.5, 0.9])
    np.testing.assert_allclose(lin.to_physical(u), 0.49 * u)
    np.testing.assert_allclose(log.to_physical(u), [50.0, 50 * 10 ** 0.5, 500.0, 50 * 100 ** 0.9])
    assert levels.levels == (300.0, 450.0, 600.0)
    np.testing.assert_array_equal(levels.to_physical(np.array([0.1, 0.34, 0.5, 0.99])),
                                  [300, 450, 450, 600])
    np.testing.assert_allclose(levels.to_unit(np.array([300.0, 600.0])), [1 / 6, 5 / 6])
    np.testing.assert_allclose(log.to_unit(log.to_physical(u)), u, atol=1e-15)
    assert fixed.is_fixed and (fixed.low, fixed.high) == (75.0, 75.0)

    space = DesignSpace((log, lin, levels, fixed))
    assert space.d == 3 and space.names == ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn")
    physical = space.to_physical(np.array([[0.5, 0.5, 0.5]]))
    np.testing.assert_allclose(physical, [[500.0, 0.245, 450.0, 75.0]])
    np.testing.assert_allclose(space.to_unit(physical), [[0.5, 0.5, 0.5]])
    with pytest.raises(ValueError, match="force_kn is fixed"):
        space.to_unit(np.array([[500.0, 0.245, 450.0, 80.0]]))
    with pytest.raises(ValueError, match="poisson must lie in"):
        space.to_unit(np.array([[500.0, 0.6, 450.0, 75.0]]))
    with pytest.raises(ValueError, match="radius_mm must be one of the levels"):
        space.to_unit(np.array([[500.0, 0.2, 400.0, 75.0]]))


@pytest.mark.parametrize("kwargs, message", [
    (dict(low=5.0, high=1.0), "x: low must be < high"),
    (dict(low=1.0, high=1.0), "x: low must be < high"),
    (dict(low=0.0, high=1.0, scale="log"), "x: log scale needs low > 0"),
    (dict(low=0.0, high=1.0, scale="cubic"), "x: unknown scale"),
    (dict(low=0.0, high=math.inf), "x high must be a finite number"),
    (dict(low=0.0), "x: a range needs both"),
    (dict(levels=()), "x: levels must be at least two distinct"),
    (dict(levels=(1.0, 1.0)), "x: levels must be at least two distinct"),
    (dict(levels=(1.0, math.nan)), "x level must be a finite number"),
    (dict(levels=(1.0, 2.0), scale="log"), "x: scale='log' applies to a continuous range"),
    (dict(low=0.0, high=1.0, fixed=0.5), "x: give exactly one of"),
    (dict(), "x: give exactly one of"),
])
def test_parameter_validation_names_the_parameter(kwargs, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        Parameter("x", **kwargs)


def test_design_space_validation():
    with pytest.raises(ValueError, match="unique; repeated: a"):
        DesignSpace((Parameter("a", 0, 1), Parameter("a", 0, 2)))
    with pytest.raises(ValueError, match="at least one parameter that varies"):
        DesignSpace((Parameter("a", fixed=1.0),))
    with pytest.raises(ValueError, match="parameter name"):
        Parameter("bad,name", 0, 1)


def test_parse_parameter_forms():
    p = parse_parameter("modulus_mpa=50:5000:log")
    assert (p.name, p.low, p.high, p.scale) == ("modulus_mpa", 50.0, 5000.0, "log")
    assert parse_parameter("poisson = 0 : 0.49").high == 0.49
    assert parse_parameter("x=-1e-3:2e-3").low == -0.001
    assert parse_parameter("sphere_radius_mm=300,450,600").levels == (300.0, 450.0, 600.0)
    assert parse_parameter("force_kn=75").fixed == 75.0
    for bad, message in [("x", "expected name=low:high"), ("x=", "expected name=low:high"),
                         ("x=1:2:3:4", "expected low:high"), ("x=a:2", "x: 'a' is not"),
                         ("x=1:2,3", "mixes a range")]:
        with pytest.raises(ValueError, match=message):
            parse_parameter(bad)


def test_csv_round_trip_is_exact(tmp_path):
    points = np.array([[0.1, 1 / 3, 1e-300], [2.5e10, -0.0, math.pi]])
    write_design_csv(tmp_path / "d.csv", ("a", "b", "c"), points)
    names, back = read_design_csv(tmp_path / "d.csv")
    assert names == ("a", "b", "c") and np.array_equal(back, points)
    (tmp_path / "bad.csv").write_text("a,b\n1,2\n3\n")
    with pytest.raises(ValueError, match="line 3"):
        read_design_csv(tmp_path / "bad.csv")


def test_augment_design_in_physical_values():
    space = DesignSpace((Parameter("modulus_mpa", 50.0, 5000.0, scale="log"),
                         Parameter("poisson", 0.0, 0.49), Parameter("force_kn", fixed=75.0)))
    first = latin_design(space, 20, seed=0, n_outer=20)
    more = augment_design(space, first.points, 5, seed=1, n_outer=20)
    assert np.array_equal(more.points[:20], first.points)
    assert more.points.shape == (25, 3) and np.all(more.points[:, 2] == 75.0)
    assert more.quality.latin
    assert np.all((more.points[:, 0] >= 50.0) & (more.points[:, 0] <= 5000.0))


# --- command line -----------------------------------------------------------------

def run_cli(capsys, *args):
    status = main(["doe", *args])
    out, err = capsys.readouterr()
    return status, out, err


def test_cli_writes_csv_and_json(tmp_path, capsys):
    out = tmp_path / "design.csv"
    status, stdout, _ = run_cli(capsys, "--samples", "20", "--seed", "0",
                                "--param", "modulus_mpa=50:5000:log", "--param", "poisson=0:0.49",
                                "--param", "sphere_radius_mm=300,450,600", "--param", "force_kn=75",
                                "--out", str(out), "--json", "--iterations", "20")
    assert status == 0
    report = json.loads(stdout)
    for key in ("min_distance", "phi_p", "centered_l2", "max_abs_correlation", "latin",
                "elapsed_s"):
        assert key in report
    names, points = read_design_csv(out)
    assert names == ("modulus_mpa", "poisson", "sphere_radius_mm", "force_kn")
    assert points.shape == (20, 4)
    assert set(points[:, 2]) == {300.0, 450.0, 600.0} and set(points[:, 3]) == {75.0}
    assert points[:, 0].min() >= 50.0 and points[:, 0].max() <= 5000.0
    space = DesignSpace(tuple(parse_parameter(s) for s in
                              ("modulus_mpa=50:5000:log", "poisson=0:0.49",
                               "sphere_radius_mm=300,450,600", "force_kn=75")))
    assert report["min_distance"] == pytest.approx(min_distance(space.to_unit(points)))
    assert report["latin"] is False                           # a discrete column


def test_cli_same_seed_same_file_and_augment(tmp_path, capsys):
    args = ["--samples", "15", "--param", "a=0:1", "--param", "b=1:10", "--iterations", "10"]
    run_cli(capsys, *args, "--out", str(tmp_path / "one.csv"))
    run_cli(capsys, *args, "--out", str(tmp_path / "two.csv"))
    assert (tmp_path / "one.csv").read_text() == (tmp_path / "two.csv").read_text()
    status, stdout, _ = run_cli(capsys, "--samples", "5", "--param", "b=1:10", "--param", "a=0:1",
                                "--augment", str(tmp_path / "one.csv"),
                                "--out", str(tmp_path / "more.csv"), "--json")
    assert status == 0 and json.loads(stdout)["latin"] is True
    names_old, old = read_design_csv(tmp_path / "one.csv")
    names_new, new = read_design_csv(tmp_path / "more.csv")
    assert names_new == ("b", "a") and new.shape == (20, 2)
    np.testing.assert_array_equal(new[:15], old[:, [1, 0]])


@pytest.mark.parametrize("args, fragment", [
    (["--samples", "10", "--param", "x=5:1"], "x: low must be < high"),
    (["--samples", "1", "--param", "x=0:1"], "samples must be"),
    (["--samples", "10", "--param", "x"], "expected name=low:high"),
    (["--samples", "10", "--param", "x=0:1:cubic"], "x: unknown scale"),
    (["--samples", "10", "--param", "x=0:1", "--param", "y=-1:1:log"], "y: log scale needs"),
    (["--samples", "10", "--param", "x=0:1", "--param", "x=0:2"], "repeated: x"),
    (["--samples", "3", "--param", "x=0:1", "--augment", "missing.csv"], "missing.csv"),
])
def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys, args, fragment):
    status, stdout, stderr = run_cli(capsys, *args, "--out", str(tmp_path / "d.csv"))
    assert status == 2 and stdout == ""
    assert len(stderr.strip().splitlines()) == 1 and fragment in stderr


def test_cli_usage_error_exits_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["doe", "--samples", "many", "--param", "x=0:1", "--out", str(tmp_path / "d.csv")])
    assert exc.value.code == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_cli_default_iterations_match_the_engine():
    from filmcal.commands.doe import ITERATIONS_DEFAULT
    from filmcal.doe.lhs import N_OUTER_DEFAULT
    assert ITERATIONS_DEFAULT == N_OUTER_DEFAULT


def test_cli_as_a_process(tmp_path):
    out = tmp_path / "design.csv"
    done = subprocess.run([sys.executable, "-m", "filmcal.cli", "doe", "--samples", "12",
                           "--param", "x=0:1", "--param", "y=2:3", "--out", str(out), "--json"],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    assert report["latin"] is True
    names, points = read_design_csv(out)
    assert names == ("x", "y") and points.shape == (12, 2)
    assert design_quality(DesignSpace((Parameter("x", 0, 1), Parameter("y", 2, 3)))
                          .to_unit(points)).phi_p == pytest.approx(report["phi_p"])
    bad = subprocess.run([sys.executable, "-m", "filmcal.cli", "doe", "--samples", "5",
                          "--param", "x=5:1", "--out", str(out)],
                         capture_output=True, text=True, timeout=120)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "Traceback" not in bad.stderr
