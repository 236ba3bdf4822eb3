"""Posterior sampling of the film calibration on synthetic data with a known truth.

The model is a *test function*, not physics (made-up constants):

    r = a_H(R, F) + c * (p_H(R, F) / M)^k,    M = E (1 - nu) / ((1 + nu)(1 - 2 nu)),

c = 2.2 mm, k = 0.5, with the steel-on-steel Hertz radius a_H and peak pressure
p_H. Synthetic radii are drawn from it at the Table 1 cases with E = 2800 MPa,
nu = 0.33 and Gaussian noise of known sigma, so the posterior must recover E and
sigma.
"""
from __future__ import annotations

import math

import h5py
import numpy as np
import pytest
from scipy.stats import kstest

from filmcal.calibration.pipeline import calibrate
from filmcal.calibration.data import RadiusErrorData
from filmcal.calibration.datasets import load_table1
from filmcal.hertz import hertz_radius_mm
from filmcal.elastic import oedometric_ratio
from toymodels import ToyRadiusModel
from filmcal.calibration.sampling import SamplerSettings, read_chain
from filmcal.calibration.diagnostics import QUANTILE_LEVELS, compute_diagnostics, quadrature_quantiles
from filmcal.calibration.likelihood import CalibrationProblem
from filmcal.calibration.posterior import CalibrationResult

E_TRUE, NU_TRUE, SIGMA_TRUE = 2800.0, 0.33, 0.1




def synthetic(repeats: int, sigma: float = SIGMA_TRUE, seed: int = 0) -> RadiusErrorData:
    """The 10 Table 1 cases, `repeats` times each, with radii drawn from the test function."""
    cases = load_table1("HS")
    R = np.tile(cases.sphere_radius_mm, repeats)
    F = np.tile(cases.force_n, repeats)
    mean, _ = ToyRadiusModel().predict(E_TRUE, NU_TRUE, R, F)
    y = mean + sigma * np.random.default_rng(seed).standard_normal(R.size)
    a = hertz_radius_mm(R, F)
    return RadiusErrorData(film=np.full(R.size, "SYN"), sphere_radius_mm=R, force_n=F, radius_error_mm=y - a,
                           hertz_radius_mm=a, measured_radius_mm=y)


def summary(result) -> dict:
    d = result.to_dict()
    d.pop("elapsed_s")
    return d


@pytest.fixture(scope="module")
def small():
    """10 radii, default settings, seed 0."""
    return calibrate(synthetic(1), ToyRadiusModel(), seed=0)


@pytest.fixture(scope="module")
def large():
    """60 radii."""
    return calibrate(synthetic(6, seed=1), ToyRadiusModel(), seed=0)


def relative_width(s: dict) -> float:
    return (s["ci90"][1] - s["ci90"][0]) / s["median"]


def test_recovers_modulus_and_sigma(small, large):
    for result in (small, large):
        assert result.diagnostics_ok, result.diagnostics.messages
        assert result.modulus_mpa["ci90"][0] < E_TRUE < result.modulus_mpa["ci90"][1]
        assert result.sigma_mm["ci90"][0] < SIGMA_TRUE < result.sigma_mm["ci90"][1]
        assert result.sigma_mm["median"] > 0.0
        assert result.rhat_max <= 1.01 and result.ess_bulk["modulus_mpa"] >= 2000
        # burn-in and thinning follow tau; the chain is >= 50 tau long
        tau = max(result.tau.values())
        assert result.n_steps >= 50 * tau
        assert result.burn_in == math.ceil(5 * tau) and result.thin == int(0.5 * min(result.tau.values()))
    # six times the data: the interval narrows by about sqrt(6) = 2.4
    assert relative_width(large.modulus_mpa) < 0.6 * relative_width(small.modulus_mpa)
    # nu fixed: M = E * M/E(0.33) sample by sample
    np.testing.assert_allclose(small.samples["oedometric_modulus_mpa"],
                               small.samples["modulus_mpa"] * oedometric_ratio(0.33), rtol=1e-12)
    assert small.poisson == {"fixed": 0.33}


def test_contract_keys(small):
    d = small.to_dict()
    assert set(d["modulus_mpa"]) >= {"median", "ci90"} and len(d["modulus_mpa"]["ci90"]) == 2
    assert set(d["oedometric_modulus_mpa"]) >= {"median", "ci90"} and "median" in d["sigma_mm"]
    assert d["rhat"] == max(d["diagnostics"]["rhat"].values())
    assert d["ess"] == min(d["diagnostics"]["ess_bulk"].values())
    assert d["n_data"] == 10


def test_posterior_predictive_coverage(large):
    pc = large.predictive
    assert 0.8 <= pc.coverage <= 0.98  # nominal 0.9 on 60 points
    assert kstest(pc.pit, "uniform").pvalue > 0.01
    assert np.all(pc.lower_mm < pc.mean_mm) and np.all(pc.mean_mm < pc.upper_mm)
    # predictive std includes sigma: at least the posterior median sigma
    assert np.all(pc.std_mm >= 0.95 * large.sigma_mm["median"])


def test_same_seed_same_summary_digit_for_digit(small):
    again = calibrate(synthetic(1), ToyRadiusModel(), seed=0)
    assert summary(again) == summary(small)
    other = calibrate(synthetic(1), ToyRadiusModel(), seed=1, settings=SamplerSettings(max_steps=500))
    assert other.modulus_mpa["median"] != small.modulus_mpa["median"]


def test_backend_resume_continues_the_chain(small, tmp_path):
    path = tmp_path / "chain.h5"
    first = calibrate(synthetic(1), ToyRadiusModel(), seed=0, backend_path=path,
                      settings=SamplerSettings(max_steps=1000))
    assert first.n_steps == 1000 and first.n_steps_new == 1000 and not first.diagnostics_ok
    head = read_chain(path).chain.copy()
    second = calibrate(synthetic(1), ToyRadiusModel(), seed=0, backend_path=path)
    assert second.n_steps == small.n_steps == 1000 + second.n_steps_new
    stored = read_chain(path)
    assert stored.chain.shape == (second.n_steps, 32, 2)
    np.testing.assert_array_equal(stored.chain[:1000], head)
    # continuing restores emcee's random state: the same as one uninterrupted run
    assert summary(second) | {"n_steps_new": 0, "backend_path": None} == summary(small) | {"n_steps_new": 0}
    # the file holds numbers and strings only: nothing to unpickle
    kinds = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: kinds.append(obj.dtype.kind) if isinstance(obj, h5py.Dataset) else None)
        for obj in (f, f["mcmc"]):
            kinds += [np.asarray(v).dtype.kind for v in obj.attrs.values()]
    assert set(kinds) <= set("fiubSUO") and all(k != "V" for k in kinds)
    assert stored.metadata["seed"] == 0 and stored.metadata["problem"]["poisson"] == "fixed"
    # another configuration is refused, reset starts afresh
    with pytest.raises(ValueError, match="another configuration"):
        calibrate(synthetic(1), ToyRadiusModel(), seed=5, backend_path=path)
    fresh = calibrate(synthetic(1), ToyRadiusModel(), seed=5, backend_path=path, reset=True,
                      settings=SamplerSettings(max_steps=300))
    assert fresh.n_steps == fresh.n_steps_new == 300


def test_short_run_is_flagged_with_its_diagnostics():
    result = calibrate(synthetic(1), ToyRadiusModel(), seed=0, settings=SamplerSettings(max_steps=150))
    assert result.n_steps == 150 and not result.diagnostics_ok
    assert any("shorter than 50 tau" in m for m in result.diagnostics.messages)
    assert math.isfinite(result.rhat_max) and math.isfinite(result.ess_min)
    assert result.to_dict()["diagnostics_ok"] is False


def test_run_is_extended_until_the_ess_target_or_the_cap():
    # the autocorrelation criterion made trivial: only R-hat / ESS can extend the run
    loose = dict(check_every=100, min_tau_multiple=1.0, tau_rtol=10.0)
    done = calibrate(synthetic(1), ToyRadiusModel(), seed=0, settings=SamplerSettings(**loose))
    assert done.diagnostics_ok and done.ess_bulk["modulus_mpa"] >= 2000 and done.n_steps > 200
    capped = calibrate(synthetic(1), ToyRadiusModel(), seed=0, settings=SamplerSettings(**loose, max_steps=200))
    assert not capped.diagnostics_ok and any("bulk ESS of modulus_mpa" in m for m in capped.diagnostics.messages)


@pytest.mark.slow
def test_ctrl_c_during_sampling_stops_cleanly_and_keeps_whole_steps(tmp_path):
    """SIGINT while emcee runs: a plain KeyboardInterrupt within 2 s, nothing printed by emcee (no walker
    positions), and the HDF5 chain keeps whole steps only (what a rerun resumes from)."""
    import signal
    import subprocess
    import sys
    import textwrap
    import time
    from pathlib import Path

    chain = tmp_path / "chain.h5"
    script = textwrap.dedent(f"""
        import sys, time
        sys.path.insert(0, {str(Path(__file__).parent)!r})
        import numpy as np
        from toymodels import ToyRadiusModel
        from filmcal.calibration.pipeline import calibrate
        from filmcal.calibration.datasets import load_table1
        from filmcal.calibration.sampling import SamplerSettings

        class Slow(ToyRadiusModel):
            def predict(self, *args):
                time.sleep(0.002)
                return super().predict(*args)

        print("sampling", flush=True)
        try:
            calibrate(load_table1("HS"), Slow(), settings=SamplerSettings(max_steps=200000, check_every=100000),
                      backend_path={str(chain)!r})
        except KeyboardInterrupt:
            print("interrupted", flush=True)
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "sampling"
    time.sleep(3.0)
    sent = time.monotonic()
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert time.monotonic() - sent < 2.0
    assert out.strip() == "interrupted" and "walker" not in err.lower() and "Traceback" not in err, (out, err)
    with h5py.File(chain) as f:
        steps = int(f["mcmc"].attrs["iteration"])
        assert steps > 0 and np.all(np.isfinite(f["mcmc"]["log_prob"][:steps]))


def test_reading_a_calibration_result_imports_no_sampler():
    """A finished study's posteriors are read on every rerun and correction: emcee (and through it scipy.stats,
    half a second) loads only to run or read a chain."""
    import subprocess
    import sys

    code = ("import sys\n"
            "import filmcal.calibration.posterior, filmcal.calibration.sampling\n"
            "from filmcal.calibration import SamplerSettings, load_result\n"
            "print(sorted(m for m in sys.modules if m.startswith(('emcee', 'h5py'))))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_monte_carlo_error_of_quantiles_of_independent_draws_is_the_closed_form():
    """N independent draws: a sample p-quantile has the standard error sqrt(p (1 - p) / N) / f(q_p)
    (the asymptotic variance of sample quantiles; for the median of N(0, 1), sqrt(pi / 2 / N)). One
    estimate scatters by about 10 %, so the ratio is averaged over 12 sets of draws."""
    from scipy.stats import norm

    n_chains, n_draws = 8, 4000
    n = n_chains * n_draws
    ratios, stuck_ratios = {key: [] for key in QUANTILE_LEVELS}, []
    for seed in range(12):
        draws = np.random.default_rng(seed).standard_normal((n_chains, n_draws))
        mcse = compute_diagnostics({"x": draws}).mcse["x"]
        assert set(mcse) == set(QUANTILE_LEVELS)
        for key, p in QUANTILE_LEVELS.items():
            ratios[key].append(mcse[key] / (math.sqrt(p * (1.0 - p) / n) / norm.pdf(norm.ppf(p))))
        # each value repeated 10 times carries a tenth of the information: the variance grows 10-fold
        stuck = np.repeat(draws[:, : n_draws // 10], 10, axis=1)
        stuck_ratios.append(compute_diagnostics({"x": stuck}).mcse["x"]["median"] / mcse["median"])
    for key, r in ratios.items():
        assert np.mean(r) == pytest.approx(1.0, abs=0.1), key
    assert 6.0 < np.mean(np.square(stuck_ratios)) < 14.0


def test_sampled_quantiles_agree_with_quadrature_within_their_monte_carlo_errors(small):
    """The posterior of (ln E, ln sigma) integrated on a grid (`quadrature_quantiles`) is an independent
    reference of the sampler's median and 90 % interval of E: each lies within 4 of its own Monte Carlo
    standard errors of the exact one."""
    problem = CalibrationProblem(synthetic(1), ToyRadiusModel())
    exact = quadrature_quantiles(problem, small.modulus_mpa["median"])
    # the grid's fineness does not matter at that scale
    finer = quadrature_quantiles(problem, small.modulus_mpa["median"], n_fine=1001, n_sigma=300)
    sampled = {"median": small.modulus_mpa["median"], "q05": small.modulus_mpa["ci90"][0],
               "q95": small.modulus_mpa["ci90"][1]}
    mcse = small.mcse["modulus_mpa"]
    for key in QUANTILE_LEVELS:
        assert 0.0 < mcse[key] < 0.03 * (exact["q95"] - exact["q05"]), key  # an ESS of some thousands
        assert abs(finer[key] - exact[key]) < 0.05 * mcse[key], key
        assert abs(sampled[key] - exact[key]) <= 4.0 * mcse[key], (key, sampled[key], exact[key], mcse[key])
    # stored and read back
    again = CalibrationResult.from_dict(small.to_dict(include_samples=True))
    assert again.mcse == small.mcse
    with pytest.raises(ValueError, match="log_modulus, log_sigma"):
        quadrature_quantiles(CalibrationProblem(synthetic(2), ToyRadiusModel()), 2800.0)  # repeats: tau too
