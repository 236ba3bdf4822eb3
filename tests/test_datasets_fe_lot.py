"""A film lot unknown to filmcal, calibrated from a CSV of imprints made by FE solves at a known E.

The lot is a user film type from a TOML file (thickness 0.1 mm, not the
built-in 0.09). Its "experiments" are sphere-on-flat solves of `filmcal.fem`
(small strain, default options) at E = 2600 MPa on cases off Table 1's grid
(R 350 and 500 mm, F 40, 60 and 90 kN), two imprints per case with Gaussian
scatter, written as a dataset CSV with a stated measurement uncertainty.

The radius model of the calibration is a different set of FE solves: per
case, FE radii at five moduli that exclude the true one (1200-6000 MPa),
interpolated by a cubic spline in ln E (`TabulatedRadiusModel`), its error
checked against further FE solves at four other moduli. The known E must lie inside the 90 % interval
and the median within 2 %.
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from filmcal.calibration.datasets import load_dataset
from filmcal.calibration.likelihood import Priors
from filmcal.calibration.pipeline import calibrate
from filmcal.calibration.tabulated import TabulatedRadiusModel
from filmcal.films import load_films_file

pytestmark = pytest.mark.slow  # about 40 FE solves and one MCMC run

E_TRUE_MPA = 2600.0
SCATTER_MM = 0.03
STATED_STD_MM = 0.01
NODES_MPA = np.array([1200.0, 1800.0, 2700.0, 4000.0, 6000.0])
CHECK_MPA = np.array([1500.0, 2200.0, 3300.0, 4900.0])
CASES = [(R, F) for R in (350.0, 500.0) for F in (40e3, 60e3, 90e3)]


@pytest.fixture(scope="module")
def lot(tmp_path_factory):
    from filmcal.fem import Film, solve_sphere_on_flat

    folder = tmp_path_factory.mktemp("lot")
    films_file = folder / "films.toml"
    films_file.write_text('[LOT7]\nactivation_pressure_mpa = 45\nthickness_mm = 0.1\npoisson = 0.33\n')
    film = load_films_file(films_file)["LOT7"]

    def fe_radius(E, nu, R, F):
        result = solve_sphere_on_flat(R, F, Film(E, nu), film_thickness_mm=film.thickness_mm)
        assert result.converged
        return result.contact_radius_mm

    t0 = time.perf_counter()
    rng = np.random.default_rng(11)
    lines = ["# FE imprints of a film lot at E = 2600 MPa, two repeats per case",
             "film,sphere_radius_mm,force_kn,measured_radius_mm,repeat,measurement_std_mm"]
    for R, F in CASES:
        truth = fe_radius(E_TRUE_MPA, film.poisson, R, F)
        for repeat in (1, 2):
            noise = np.hypot(SCATTER_MM, STATED_STD_MM) * rng.standard_normal()
            lines.append(f"LOT7,{R:g},{F / 1e3:g},{truth + noise:.4f},{repeat},{STATED_STD_MM}")
    csv = folder / "lot7.csv"
    csv.write_text("\n".join(lines) + "\n")
    model = TabulatedRadiusModel.from_function(fe_radius, CASES, NODES_MPA, film.poisson)
    spline_error_mm = model.max_error_mm(fe_radius, CHECK_MPA)
    model.std_mm = max(spline_error_mm, 0.002)
    fe_s = time.perf_counter() - t0
    return film, csv, model, spline_error_mm, fe_s


def test_fe_lot_calibrated_from_its_csv_recovers_the_known_modulus(lot):
    film, csv, model, spline_error_mm, fe_s = lot
    assert spline_error_mm < 0.01  # the interpolated FE model against FE solves it did not see
    dataset = load_dataset(csv)
    data = dataset.select(film)
    assert len(data) == 12 and data.n_cases == 6 and data.has_repeats
    t0 = time.perf_counter()
    result = calibrate(data, model, film=film.name,
                       priors=Priors.for_film(film, modulus_range_mpa=(NODES_MPA[0], NODES_MPA[-1])), seed=0)
    lo, hi = result.modulus_mpa["ci90"]
    median = result.modulus_mpa["median"]
    print(f"\nLOT7 (FE at E = {E_TRUE_MPA:g} MPa, 6 cases x 2 repeats, scatter {SCATTER_MM} mm): "
          f"E median {median:.0f} MPa ({100 * (median / E_TRUE_MPA - 1):+.2f} %), 90 % [{lo:.0f}, {hi:.0f}], "
          f"sigma {result.sigma_mm['median']:.4f} mm, case sigma {result.case_sigma_mm['median']:.4f} mm, "
          f"R-hat {result.rhat_max:.4f}, ESS {result.ess_min:.0f}; spline error {spline_error_mm:.4f} mm; "
          f"FE {fe_s:.1f} s, calibration {time.perf_counter() - t0:.1f} s; sha256 {dataset.sha256[:12]}")
    assert result.diagnostics_ok, result.diagnostics.messages
    assert lo < E_TRUE_MPA < hi
    assert median == pytest.approx(E_TRUE_MPA, rel=0.02)
    assert result.n_data == 12 and result.film == "LOT7"
    assert result.case_sigma_mm is not None  # repeats: the case-level scatter is inferred
