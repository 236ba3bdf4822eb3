"""Wheel-rail correction: the posterior's film effect from direct wheel-rail solves, and the command."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from filmcal.correction import WheelRailCorrector
from filmcal.fem import ContactOptions
from filmcal.study import posterior_tag
from filmcal.wheelrail import FilmLayer, solve_wheel_rail


def point_posterior(e_mpa=2800.0, sigma=0.0, n=500):
    return {"modulus_mpa": np.full(n, e_mpa), "sigma_mm": np.full(n, sigma)}


def test_single_modulus_without_scatter_scales_by_the_solved_area_ratio():
    a0 = solve_wheel_rail(-3.0, 100e3).area_mm2
    af = solve_wheel_rail(-3.0, 100e3, film=FilmLayer(2800.0, 0.33, 0.09)).area_mm2
    out = WheelRailCorrector(point_posterior(), model_radius_std_mm=0.0).correct(150.0, -3.0, 100e3)
    assert out.area_mm2 == pytest.approx(150.0 * a0 / af, rel=1e-9)
    assert out.area_std_mm2 == pytest.approx(0.0, abs=1e-9)
    assert af > a0  # the film enlarges the patch


def test_ratio_interpolates_the_film_effect_across_the_posterior():
    rng = np.random.default_rng(0)
    post = {"modulus_mpa": np.exp(rng.normal(np.log(2800.0), 0.05, 800)), "sigma_mm": np.full(800, 0.05)}
    corr = WheelRailCorrector(post)
    ratio, support = corr.area_ratio(-5.0, 50e3)
    e_check = float(np.quantile(corr.modulus_mpa_, 0.9))
    direct = support["area_no_film_mm2"] / solve_wheel_rail(-5.0, 50e3, film=FilmLayer(e_check, 0.33, 0.09)).area_mm2
    k = np.argmin(np.abs(corr.modulus_mpa_ - e_check))
    assert ratio[k] == pytest.approx(direct, rel=2e-3)
    out = corr.correct(120.0, -5.0, 50e3, measurement_std_mm2=2.0)
    lo, hi = out.area_ci90_mm2
    assert lo < out.area_mm2 < hi and out.area_std_mm2 > 0


def test_bad_input():
    corr = WheelRailCorrector(point_posterior())
    with pytest.raises(ValueError, match="measured_area_mm2"):
        corr.correct(-1.0, -3.0, 100e3)


def test_command_uses_the_study_posterior(tmp_path):
    tag = posterior_tag("HS", None, ContactOptions())
    samples = {"modulus_mpa": [2800.0] * 200, "sigma_mm": [0.05] * 200}
    (tmp_path / f"posterior-{tag}.json").write_text(json.dumps({"samples": samples}))
    cmd = [sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--measured-area-mm2", "150",
           "--offset-mm=-3", "--force-kn", "100", "--study-dir", str(tmp_path), "--json"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert {"area_mm2", "area_std_mm2", "area_ci90_mm2"} <= set(out)
    assert out["area_ci90_mm2"][0] < out["area_mm2"] < out["area_ci90_mm2"][1] < 150.0
    bad = subprocess.run(cmd[:5] + ["-1"] + cmd[6:], capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
