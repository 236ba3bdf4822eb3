"""Wheel-rail correction: the posterior's film effect from direct wheel-rail solves, and the command."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from filmcal.contact.film import FilmModel
from filmcal.correction import WheelRailCorrector
from filmcal.films import get_film
from filmcal.wheelrail import FilmLayer, solve_wheel_rail

HS_EDGE = FilmModel(get_film("HS"), "edge", "small")


def point_posterior(e_mpa=2800.0, sigma=0.0, n=500):
    return {"modulus_mpa": np.full(n, e_mpa), "sigma_mm": np.full(n, sigma)}


def test_single_modulus_without_scatter_scales_by_the_solved_area_ratio_and_carries_the_transfer():
    """One modulus, no imprint scatter: the answer is the measured area times A_0 / A_f, A_f the film's own
    solve plus the transfer term's shift (the calibrated continuum film lies inside the springs' edge); its
    spread is the transfer term's standard deviation alone."""
    a0 = solve_wheel_rail(-3.0, 100e3).area_mm2
    result = solve_wheel_rail(-3.0, 100e3, film=FilmLayer(2800.0, 0.33, 0.09))
    term = HS_EDGE.transfer_term(2800.0, result)
    af = result.area_mm2 + term.shift_mm2
    assert term.shift_mm2 < 0 < term.std_mm2  # the continuum film's edge lies inside the springs'
    out = WheelRailCorrector(point_posterior(n=4000), HS_EDGE).correct(150.0, -3.0, 100e3)
    assert np.median(out.samples_mm2) == pytest.approx(150.0 * a0 / af, rel=1e-3)
    assert out.area_std_mm2 == pytest.approx(150.0 * a0 / af * term.std_mm2 / af, rel=0.1)
    assert af > a0  # the film enlarges the patch


def test_ratio_interpolates_the_film_effect_across_the_posterior():
    rng = np.random.default_rng(0)
    post = {"modulus_mpa": np.exp(rng.normal(np.log(2800.0), 0.05, 800)), "sigma_mm": np.full(800, 0.05)}
    corr = WheelRailCorrector(post, HS_EDGE)
    ratio, _, support = corr.area_ratio(-5.0, 50e3)
    e_check = float(np.quantile(corr.modulus_mpa_, 0.9))
    direct = support["area_no_film_mm2"] / corr.film_area_mm2(e_check, -5.0, 50e3)
    k = np.argmin(np.abs(corr.modulus_mpa_ - e_check))
    assert ratio[k] == pytest.approx(direct, rel=2e-3)
    out = corr.correct(120.0, -5.0, 50e3, measured_area_std_mm2=2.0)
    lo, hi = out.area_ci90_mm2
    assert lo < out.area_mm2 < hi and out.area_std_mm2 > 0


def test_bad_input():
    corr = WheelRailCorrector(point_posterior(), HS_EDGE)
    with pytest.raises(ValueError, match="measured_area_mm2"):
        corr.correct(-1.0, -3.0, 100e3)


def test_free_poisson_posterior_is_carried_over_at_equal_oedometric_modulus():
    """A sample (E, nu) with nu free acts on the film springs through M only: at the nominal nu the
    corrector uses the E of the same M, so its ratio equals that of a film solved with (E, nu) itself."""
    from filmcal.elastic import oedometric_modulus_mpa

    post = {"modulus_mpa": np.full(50, 2500.0), "poisson": np.full(50, 0.36), "sigma_mm": np.zeros(50)}
    corr = WheelRailCorrector(post, HS_EDGE)
    assert oedometric_modulus_mpa(corr.modulus_mpa_[0], 0.33) == pytest.approx(oedometric_modulus_mpa(2500.0, 0.36))
    ratio, _, support = corr.area_ratio(-3.0, 50e3)
    result = solve_wheel_rail(-3.0, 50e3, film=FilmLayer(2500.0, 0.36, 0.09))
    direct = support["area_no_film_mm2"] / (result.area_mm2 + HS_EDGE.transfer_term(corr.modulus_mpa_[0], result).shift_mm2)
    assert ratio[0] == pytest.approx(direct, rel=1e-4)


def test_command_uses_the_study_posterior_and_refuses_nonsense(quick_study, tmp_path):
    study, summary, _ = quick_study
    base = [sys.executable, "-m", "filmcal.cli", "correct", "--measured-area-mm2", "150", "--offset-mm=-3",
            "--force-kn", "100", "--json"]
    p = subprocess.run(base + ["--film", "HS", "--study-dir", str(study)], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    assert {"area_mm2", "area_std_mm2", "area_ci90_mm2", "models"} <= set(out)
    assert out["area_ci90_mm2"][0] < out["area_mm2"] < out["area_ci90_mm2"][1] < 150.0
    assert abs(sum(m["weight"] for m in out["models"].values()) - 1) < 1e-9
    for m in out["models"].values():  # every model's answer carries the calibrated-against-applied film term
        assert -0.05 < m["transfer"]["shift_rel"] < 0.0 < m["transfer"]["std_rel"] < 0.02
    # where the answer came from: each posterior by its file and SHA-256, the version, the options
    prov = out["provenance"]
    assert set(prov["posteriors"]) == set(out["models"])
    for entry in prov["posteriors"].values():
        assert (study / entry["file"]).is_file() and len(entry["sha256"]) == 64
    assert prov["measurement"]["offset_mm"] == -3.0 and prov["filmcal"] and prov["transfer_fit"]["made"]
    from filmcal.contact.transfer import load_transfer_fit  # the fit each model's term came from, by its digest

    assert prov["transfer_fit"]["sha256"] == {model: load_transfer_fit().digest(model) for model in out["models"]}
    assert any("roughness" in what for what in out["not_included"])  # the band does not hold it: said so
    # the measured area came without its own uncertainty: the band holds none of it, and says so
    assert any("measured area's own uncertainty" in what for what in out["not_included"])
    text = subprocess.run(base[:-1] + ["--film", "HS", "--study-dir", str(study)], capture_output=True, text=True)
    assert text.returncode == 0 and "not included: the bodies' roughness" in text.stdout
    given = subprocess.run(base + ["--film", "HS", "--study-dir", str(study), "--measured-area-std-mm2", "3"],
                           capture_output=True, text=True)
    assert not any("own uncertainty" in what for what in json.loads(given.stdout)["not_included"])
    cases = {"a negative area": ["--film", "HS", "--study-dir", str(study), "--measured-area-mm2", "-1"],
             "a stray space": ["--film", " HS", "--study-dir", str(study)],
             "an absurd area": ["--film", "HS", "--study-dir", str(study), "--measured-area-mm2", "1e9"],
             "a mistyped study folder": ["--film", "HS", "--study-dir", str(tmp_path / "typo")],
             "a film without posterior": ["--film", "MS", "--study-dir", str(study)],
             "an absurd sphere radius": ["--film", "HS", "--study-dir", str(study), "--sphere-radius-mm", "450",
                                         "--measured-radius-mm", "1e9"]}
    for what, extra in cases.items():
        args = base + extra
        if "--sphere-radius-mm" in extra:
            args = [a for a in args if a not in ("--measured-area-mm2", "150", "--offset-mm=-3")]
        bad = subprocess.run(args, capture_output=True, text=True)
        assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1, (what, bad.stderr)
        assert "Traceback" not in bad.stderr
    assert not (tmp_path / "typo").exists()  # no study was started


def test_an_area_uncertainty_as_large_as_the_area_is_refused_before_any_solve():
    """`correct --measured-area-std-mm2 1e308` printed 'inf +/- nan' with exit 0."""
    import numpy as np

    from filmcal.contact.film import FilmModel
    from filmcal.correction.wheelrail import WheelRailCorrector
    from filmcal.films import get_film

    n = 200
    c = WheelRailCorrector({"modulus_mpa": np.full(n, 2800.0), "sigma_mm": np.full(n, 0.01)},
                           FilmModel(get_film("HS"), "edge", "small"))
    for std in (150.0, 1e308, 75.01):  # half the area is a quarter of its radius
        with pytest.raises(ValueError, match="more than 50 %"):
            c.correct(150.0, -3.0, 100e3, measured_area_std_mm2=std)
    assert c.correct(150.0, -3.0, 100e3, measured_area_std_mm2=75.0).area_ci90_mm2[0] > 0


def test_roughness_multiplies_each_sample_by_a_drawn_growth_factor():
    """On rough bodies a sample's factor A_0 / A_f is multiplied by g_0 / g_f of a draw: with every draw at
    g_0 / g_f = 0.9 the answer is the smooth one times 0.9, sample by sample; with two draws the band widens."""
    from filmcal.correction.roughness import RoughGrowth

    c = WheelRailCorrector(point_posterior(n=400, sigma=0.02), HS_EDGE, random_state=3)
    smooth = c.correct(150.0, -3.0, 100e3)
    fixed = RoughGrowth(np.full(4, 1.1), np.full(4, 0.99), np.full(4, 0.25))
    rough = c.correct(150.0, -3.0, 100e3, rough=fixed)
    np.testing.assert_allclose(rough.samples_mm2, 0.9 * smooth.samples_mm2, rtol=1e-12)
    spread = RoughGrowth(np.array([1.05, 1.15]), np.ones(2), np.full(2, 0.5))
    wide = c.correct(150.0, -3.0, 100e3, rough=spread)
    assert wide.area_std_mm2 > 2 * smooth.area_std_mm2
    with pytest.raises(ValueError, match="one offset and force"):
        c.correct([150.0, 150.0], [-3.0, 0.0], 100e3, rough=spread)


def test_command_with_a_rough_wheel_widens_the_band_and_reports_the_roughness_share(quick_study):
    study, _, _ = quick_study
    base = [sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--measured-area-mm2", "150",
            "--offset-mm=-3", "--force-kn", "100", "--study-dir", str(study), "--json", "--progress", "quiet"]
    smooth = json.loads(subprocess.run(base, capture_output=True, text=True, check=True).stdout)
    p = subprocess.run(base + ["--wheel-roughness-ra-um", "1.5", "--roughness-draws", "2"], capture_output=True,
                       text=True)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    rough = out["roughness"]
    assert rough["smooth_area_mm2"] == pytest.approx(smooth["area_mm2"], rel=1e-12)  # same seed, same draws
    assert out["area_std_mm2"] > smooth["area_std_mm2"] and 0.0 < rough["share_of_variance"] < 1.0
    change = sum(out["models"][name]["weight"] * m["correction_factor_change"]["mean_pct"]
                 for name, m in rough["models"].items())  # the models' mixture, by their weights
    assert out["area_mm2"] / smooth["area_mm2"] - 1 == pytest.approx(change / 100, abs=0.01)
    assert not any("roughness" in w for w in out["not_included"]) and any("offset" in w for w in out["not_included"])
    assert out["provenance"]["roughness"]["wheel_ra_um"] == 1.5
    kept = subprocess.run(base + ["--wheel-roughness-ra-um", "1.5", "--roughness-draws", "2"], capture_output=True,
                          text=True, check=True)  # the study kept the rough solves: read back, the same answer
    assert kept.stdout == p.stdout and list(study.glob("posteriors/*-roughness.json"))
    again = subprocess.run(base + ["--wheel-roughness-ra-um", "0"], capture_output=True, text=True, check=True)
    assert json.loads(again.stdout)["area_mm2"] == smooth["area_mm2"]  # Ra 0: the smooth answer to the digit
    sphere = subprocess.run([a for a in base if a not in ("--measured-area-mm2", "150", "--offset-mm=-3")]
                            + ["--measured-radius-mm", "8", "--sphere-radius-mm", "450",
                               "--wheel-roughness-ra-um", "1.5"], capture_output=True, text=True)
    assert sphere.returncode == 2 and "wheel-rail" in sphere.stderr


def test_an_uncertain_offset_widens_the_band_by_the_slope_of_the_correction():
    """One modulus, no other scatter: the band's relative width is |d ln(A_0 / A_f) / d eta| u, the slope
    taken from separate solves at eta -/+ u (the film's area with its transfer shift)."""
    def ratio(eta):
        a0 = solve_wheel_rail(eta, 100e3).area_mm2
        result = solve_wheel_rail(eta, 100e3, film=FilmLayer(2800.0, 0.33, 0.09))
        return a0 / (result.area_mm2 + HS_EDGE.transfer_term(2800.0, result).shift_mm2)

    u = 1.0
    slope = (math.log(ratio(-3.0 + u)) - math.log(ratio(-3.0 - u))) / (2 * u)
    c = WheelRailCorrector(point_posterior(n=4000), HS_EDGE)
    base = c.correct(150.0, -3.0, 100e3)
    wide = c.correct(150.0, -3.0, 100e3, offset_std_mm=u)
    added = math.sqrt(float(wide.area_std_mm2) ** 2 - float(base.area_std_mm2) ** 2) / float(base.area_mm2)
    assert abs(slope) * u > 0.003  # the factor does change with the offset here
    assert added == pytest.approx(abs(slope) * u, rel=0.1)
    with pytest.raises(ValueError, match="offset_std_mm"):
        c.correct(150.0, -3.0, 100e3, offset_std_mm=-1.0)


def test_a_correction_beyond_the_elastic_limit_says_so(quick_study):
    """The paper skipped R300 at 75 and 100 kN to avoid plastic strain (Hertz p0 1290 and 1420 MPa); R450 /
    50 kN (860 MPa) is elastic."""
    study, _, _ = quick_study
    base = [sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--study-dir", str(study), "--json"]
    out = {}
    for radius, force, measured in (("300", "100", "8.5"), ("450", "50", "7.0")):
        p = subprocess.run(base + ["--sphere-radius-mm", radius, "--force-kn", force, "--measured-radius-mm",
                                   measured], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr
        out[radius] = (json.loads(p.stdout), p.stderr)
    (hot, err), (cool, _) = out["300"], out["450"]
    assert hot["max_pressure_no_film_mpa"] == pytest.approx(1420, rel=0.01)
    assert any("elastic limit" in w for w in hot["warnings"]) and "elastic limit" in err
    assert "warnings" not in cool and cool["max_pressure_no_film_mpa"] < 1000


def test_a_wheel_rail_contact_outside_the_transfers_sizes_says_so(quick_study):
    """The transfer term was fitted on spheres of 150-1500 mm at 9-165 kN (Hertz radii 2.06-11.7 mm); S1002 /
    60E2 at 2 kN, eta -3 mm, has a contact without film of about 10 mm2 (1.8 mm): the answer says its transfer
    is extrapolated. At 100 kN (138 mm2, 6.6 mm) it says nothing of it."""
    from filmcal.hertz import hertz_radius_mm

    study, _, _ = quick_study
    assert hertz_radius_mm(150.0, 9e3) == pytest.approx(2.06, abs=0.01)
    base = [sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--study-dir", str(study), "--json",
            "--offset-mm=-3"]
    out = {}
    for force, measured in (("2", "16"), ("100", "190")):
        p = subprocess.run(base + ["--force-kn", force, "--measured-area-mm2", measured], capture_output=True,
                           text=True)
        assert p.returncode == 0, p.stderr
        out[force] = (json.loads(p.stdout), p.stderr)
    (small, err), (usual, usual_err) = out["2"], out["100"]
    assert any("extrapolated" in w and "smaller" in w for w in small["warnings"])
    assert "OutsideDomainWarning" in err
    assert not any("extrapolated" in w for w in usual.get("warnings", [])) and "OutsideDomain" not in usual_err


def test_the_corrected_patch_has_a_length_width_and_position_with_bands(quick_study):
    """S1002 / 60E2, 100 kN, eta 0: the patch without film's extents (its solved outline, exact to the grid)
    scaled by sqrt(corrected area / its area); the lateral position is its centroid on the rail."""
    study, _, _ = quick_study
    bare = solve_wheel_rail(0.0, 100e3)
    points = np.concatenate([np.asarray(r) for r in bare.outline_mm])
    length, width = np.ptp(points[:, 0]), np.ptp(points[:, 1])
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "correct", "--film", "HS", "--study-dir", str(study),
                        "--measured-area-mm2", "190", "--offset-mm=0", "--force-kn", "100", "--json"],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    patch = out["patch"]
    assert patch["no_film_length_mm"] == pytest.approx(length) and patch["no_film_width_mm"] == pytest.approx(width)
    scale = math.sqrt(out["area_mm2"] / bare.area_mm2)
    assert patch["length_mm"]["mean"] == pytest.approx(length * scale, rel=0.01)
    assert patch["width_mm"]["ci90"][0] < width * scale < patch["width_mm"]["ci90"][1]
    assert patch["lateral_position_mm"]["mean"] == pytest.approx(bare.centroid_rail_y_mm)


def test_a_refused_measurement_writes_nothing_and_a_load_without_imprint_is_refused(quick_study, tmp_path):
    """A measurement refused after its solve wrote the solve cache and rewrote study.json; at 1 N the
    activation reading records nothing, and `correct` answered 'nan +/- nan' with exit 0 while `curves`
    ended in an internal error (exit 70). Now: exit 2, one line, the study unchanged."""
    import hashlib
    import shutil

    study = tmp_path / "study"
    shutil.copytree(quick_study[0], study)

    def snapshot():
        return {str(p.relative_to(study)): hashlib.sha256(p.read_bytes()).hexdigest()
                for p in sorted(study.rglob("*")) if p.is_file() and not p.name.endswith(".lock")}

    before = snapshot()
    cli = [sys.executable, "-m", "filmcal.cli"]
    cases = {"an implausible area at a new offset": (
        ["correct", "--film", "HS", "--measured-area-mm2", "5000", "--offset-mm=-2.5", "--force-kn", "100"],
        "implausible"),
        "a load without imprint": (
            ["correct", "--film", "HS", "--imprint-model", "activation", "--measured-area-mm2", "0.2",
             "--offset-mm=-3", "--force-kn", "0.001"], "records nothing"),
        "a sphere outside the calibrated domain": (
            ["correct", "--film", "HS", "--measured-radius-mm", "0.1", "--sphere-radius-mm", "300", "--force-kn",
             "0.001"], "outside the calibrated domain"),
        "curves at a load without imprint": (
            ["curves", "--film", "HS", "--imprint-model", "activation", "--forces-kn", "0.001", "--offsets-mm=-3",
             "--workers", "1", "--progress", "quiet"], "records nothing")}
    for what, (args, says) in cases.items():
        p = subprocess.run(cli + args + ["--study-dir", str(study)], capture_output=True, text=True, timeout=300)
        assert p.returncode == 2 and says in p.stderr, (what, p.returncode, p.stderr[-2000:])
        assert len(p.stderr.strip().splitlines()) == 1 and p.stdout == "", (what, p.stderr)
        assert snapshot() == before, what


def test_a_rough_correction_keeps_each_law_as_it_solves_it_and_reads_the_pipelines(quick_study, tmp_path,
                                                                                     rough_law_solves):
    """The boundary-element laws are nearly all of a rough correction's time. Each is kept in the study as soon
    as it is solved: run again after an interrupt, only the missing laws are solved, and the answer is the one
    an uninterrupted run gives. A law the pipeline solved for its rough curves (the same bodies and film at the
    same modulus) is read, not solved again."""
    import shutil

    from filmcal.study import Study
    from filmcal.study.correct import BodyRoughness, WheelRailMeasurement, correct_measurement

    studies = {}
    for name in ("interrupted", "whole"):
        studies[name] = tmp_path / name
        shutil.copytree(quick_study[0], studies[name])
    solved = rough_law_solves

    def correct(study, ra_um, draws, stop_at=None):
        solved.stop_at = stop_at
        answer, _ = correct_measurement(Study(study), "HS", WheelRailMeasurement(150.0, -3.0, 100.0),
                                        roughness=BodyRoughness(ra_um, None, draws))
        return answer

    # the quick pipeline's rough curves: wheel Ra 1.5 um, 2 draws, the laws against HS and steel of each
    correct(studies["whole"], 1.5, 2)
    assert solved == [], "the pipeline's laws were solved again"
    with pytest.raises(KeyboardInterrupt):
        correct(studies["interrupted"], 2.0, 2, stop_at=2)  # the first draw's two laws, then Ctrl-C
    kept = {k: v for k, v in json.loads((studies["interrupted"] / "study.json").read_text())["caches"].items()
            if v["kind"] == "rough-law"}
    assert len(kept) == 2 and all((studies["interrupted"] / k).is_file() for k in kept)
    solved.clear()
    resumed = correct(studies["interrupted"], 2.0, 2)
    assert solved == ["film_law", "steel_law"]  # the second draw's only
    whole = correct(studies["whole"], 2.0, 2)
    for key in ("area_mm2", "area_std_mm2", "area_ci90_mm2"):
        assert resumed[key] == whole[key], key
