"""A study's design covers its dataset: extended inside the supported domain, refused in one line outside it."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from filmcal.hertz import hertz_max_pressure_mpa, hertz_radius_mm
from filmcal.surrogate.radius import (
    ELASTIC_LIMIT_MPA,
    MAX_CONTACT_RADIUS_MM,
    SUPPORTED_FORCE_KN,
    SUPPORTED_RADIUS_MM,
    SurrogateDomain,
    check_supported,
)


def test_a_dataset_inside_the_domain_keeps_it_and_one_outside_extends_it():
    default = SurrogateDomain()
    assert default.covering([300, 450, 600], [25, 50, 100]) is default  # Table 1's cases: its runs are reused
    wide = default.covering([200, 350, 900, 900], [10, 90, 150, 10])
    assert min(wide.radius_levels_mm) == 200 and max(wide.radius_levels_mm) == 900
    assert wide.force_kn[0] <= 10 / 1.1 + 1e-9 and wide.force_kn[1] >= 150 * 1.1 - 1e-9
    ratios = np.diff(np.log(wide.radius_levels_mm))
    assert ratios.max() <= np.log(1.25) + 1e-9  # the levels as dense as Table 1's (300, 375 ... 600 mm)
    assert wide.contains(2800.0, 0.33, 250.0, 20.0) and not default.contains(2800.0, 0.33, 250.0, 20.0)
    assert set(default.radius_levels_mm) <= set(wide.radius_levels_mm) and wide.includes(default)


def test_an_extended_domain_augments_the_design_and_keeps_every_run_of_the_one_it_extends():
    from filmcal.contact.options import ContactOptions
    from filmcal.surrogate.radius import augmented_samples, design_points

    base = SurrogateDomain()
    wide = base.covering([250.0, 350.0, 500.0], [20.0, 60.0, 90.0])
    # the base's share of the extended space, by hand: 5 of 7 radius levels (250 and 274 mm added) times
    # its 20-110 kN of 18.2-110 kN
    share = 5 / 7 * (110 - 20) / (110 - 20 / 1.1)
    assert abs(wide.share_of(base) - share) < 1e-12 and len(wide.radius_levels_mm) == 7
    assert augmented_samples(wide, base, 30) == round(30 * (1 / share - 1)) == 13
    points = design_points(wide, 30, 7, ContactOptions(), base)
    assert points[:30] == design_points(base, 30, 7, ContactOptions())  # the base design, unchanged
    new = points[30:]
    assert len(new) == 13 and all(wide.contains(p["modulus_mpa"], p["poisson"], p["sphere_radius_mm"],
                                                 p["force_kn"]) for p in new)
    # they go where the base design left the extended space empty: the new radius levels, the low forces
    assert all(p["sphere_radius_mm"] < 300 or p["force_kn"] < 20 for p in new)
    assert {p["sphere_radius_mm"] for p in new} >= {250.0, 273.861}  # both new levels sampled


def test_cases_outside_the_supported_domain_are_refused_with_what_to_change():
    # the paper skipped R300 at 100 kN "to avoid plastic strain" (Hertz p0 1420 MPa)
    assert hertz_max_pressure_mpa(300.0, 100e3) > ELASTIC_LIMIT_MPA > hertz_max_pressure_mpa(300.0, 50e3)
    with pytest.raises(ValueError, match="elastic limit"):
        check_supported([300.0], [100.0])
    for radius, force in ((20000.0, 100.0), (140.0, 10.0), (450.0, 9.0), (1200.0, 151.0)):
        with pytest.raises(ValueError, match="outside the supported spheres of 150-1500 mm and forces of 10-150 kN"):
            check_supported([radius], [force])
    check_supported([1200.0], [150.0])  # R 1200 mm is extended, not refused
    # the supported box keeps every contact within the modelled 50 mm bodies (Hertz radius, a closed form)
    assert hertz_radius_mm(SUPPORTED_RADIUS_MM[1], 1e3 * SUPPORTED_FORCE_KN[1]) < MAX_CONTACT_RADIUS_MM


def test_the_command_refuses_an_unsupported_dataset_before_any_fe_work(tmp_path):
    data = tmp_path / "lot.csv"
    data.write_text("film,sphere_radius_mm,force_kn,measured_radius_mm\nHS,150,150,6.0\nHS,450,50,7.0\n")
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(data), "--film", "HS",
                        "--imprint-model", "edge", "--study-dir", str(tmp_path / "st"), "--json"],
                       capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and len(p.stderr.strip().splitlines()) == 1 and "elastic limit" in p.stderr
    assert not (tmp_path / "st" / "runs").exists() and not list((tmp_path / "st").glob("**/*.sqlite"))
    # the refused dataset does not bind the study: the lab leaves the case out and calibrates in the same folder
    manifest = tmp_path / "st" / "study.json"
    assert not manifest.exists() or json.loads(manifest.read_text()).get("dataset") is None


@pytest.mark.slow
def test_a_lab_dataset_at_250_mm_is_calibrated_on_an_extended_design(tmp_path):
    """R 250 mm lay outside Table 1's radius levels: the calibration ended in an internal error. The design is
    augmented (said first, with its number of new FE runs), every run of the design it extends is reused, and
    the calibration runs."""
    import sqlite3

    def calibrate(rows: str, study: str):  # two datasets, two studies, one run store
        data = tmp_path / f"{study}.csv"
        data.write_text("film,sphere_radius_mm,force_kn,measured_radius_mm,repeat\n" + rows)
        return subprocess.run([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(data), "--film", "HS",
                               "--imprint-model", "edge", "--kinematics", "small", "--study-dir",
                               str(tmp_path / study), "--run-store", str(tmp_path / "runs"), "--train-runs", "30",
                               "--test-runs", "10", "--max-steps", "2000", "--moduli-per-case", "0", "--json"],
                              capture_output=True, text=True, timeout=600)  # the design alone: its extension

    def runs() -> int:
        (store,) = (tmp_path / "runs").glob("runs-*.sqlite")
        return sqlite3.connect(store).execute("select count(*) from runs").fetchone()[0]

    inside = "HS,350,60,6.3,1\nHS,500,90,8.3,1\nHS,450,40,6.0,1\n"
    assert calibrate(inside, "first").returncode == 0 and runs() == 40  # cases inside Table 1's domain first
    p = calibrate("HS,250,20,3.9,1\nHS,250,20,3.95,2\n" + inside, "second")
    assert p.returncode == 0, p.stderr[-2000:]
    # 5 of 7 radius levels (250 and 274 mm added) and 20-110 of 18.2-110 kN: 30 and 10 runs become 43 and 14
    assert "extended to sphere radii 250, 273.861, 300" in p.stderr and "17 new FE runs" in p.stderr
    assert runs() == 57  # the 40 runs reused, 17 new
    out = json.loads(p.stdout)
    lo, hi = out["modulus_mpa"]["ci90"]
    assert np.isfinite([lo, hi]).all() and 400 <= lo < hi <= 20000


@pytest.mark.slow
def test_a_known_modulus_is_recovered_from_data_at_200_to_900_mm_and_10_to_150_kN(tmp_path):
    """Imprints made by the FE at E = 1800 MPa (HS's nu, edge reading) on spheres of 200-900 mm at 10-150 kN,
    far outside Table 1's 300-600 mm and 25-100 kN, calibrated through the command on the study's augmented
    design: the known E lies inside the 90 % interval and the median within 2 %."""
    from filmcal.fem import Film, solve_sphere_on_flat
    from filmcal.films import FilmType

    E_true, hs = 1800.0, FilmType("HS")
    cases = [(200.0, 10.0), (200.0, 25.0), (350.0, 40.0), (500.0, 80.0), (700.0, 120.0), (900.0, 150.0),
             (900.0, 60.0)]
    rng = np.random.default_rng(5)
    lines = ["film,sphere_radius_mm,force_kn,measured_radius_mm,repeat"]
    for R, F in cases:
        result = solve_sphere_on_flat(R, F * 1e3, Film(E_true, hs.poisson), film_thickness_mm=hs.thickness_mm)
        assert result.converged
        for repeat in (1, 2):
            lines.append(f"HS,{R:g},{F:g},{result.contact_radius_mm + 0.02 * rng.standard_normal():.4f},{repeat}")
    (tmp_path / "wide.csv").write_text("\n".join(lines) + "\n")
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "calibrate", "--data", str(tmp_path / "wide.csv"),
                        "--film", "HS", "--imprint-model", "edge", "--kinematics", "small", "--study-dir",
                        str(tmp_path / "st"), "--train-runs", "40", "--test-runs", "10", "--max-steps", "4000",
                        "--json"], capture_output=True, text=True, timeout=1200)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "extended to sphere radii 200" in p.stderr and "new FE runs" in p.stderr
    out = json.loads(p.stdout)
    lo, hi = out["modulus_mpa"]["ci90"]
    assert lo <= E_true <= hi, (lo, out["modulus_mpa"]["median"], hi)
    assert abs(out["modulus_mpa"]["median"] / E_true - 1) < 0.02  # 1797.8 MPa [1773.9, 1822.1] on 27 Nov 2026
