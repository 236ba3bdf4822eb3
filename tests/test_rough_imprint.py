"""What a film records on rough bodies: the coverage reading, its inputs' prior and their conditioning."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.stats import norm

from filmcal.calibration.roughness import (DETECTION_SCATTER, PAPER_ROUGH_FLAT, RoughFlatObservation,
                                           condition_weights, observation_likelihood, resample)
from filmcal.contact.film import FilmModel
from filmcal.contact.rough_imprint import (DEFAULT_ROUGHNESS_INPUTS, ROUGHNESS_PRIOR, RoughnessInputs,
                                           _shipped, coverage, coverage_level_mpa, load_roughness_inputs,
                                           representative_roughness_inputs, rough_recorded_area_mm2,
                                           sample_roughness_prior)
from filmcal.correction.roughness import RoughGrowth, weighted_quantiles
from filmcal.wheelrail.rough_growth import sphere_growth
from filmcal.films import get_film
from filmcal.wheelrail.halfspace import sphere_on_flat_contact

#: Each film at the modulus and under the model the shipped conditioning used (its calibrated median and
#: preferred model, recorded in filmcal/data/roughness_inputs.json), so that the tests follow a recalibration.
SHIPPED_FILMS = {f["film"]: f for f in _shipped()["films"]}
HS, HHS, MS = (FilmModel(get_film(name), SHIPPED_FILMS[name]["imprint"], SHIPPED_FILMS[name]["kinematics"])
               for name in ("HS", "HHS", "MS"))
MODULUS = {name: float(f["modulus_mpa"]) for name, f in SHIPPED_FILMS.items()}


def test_prior_draws_cover_the_stated_ranges_and_are_reproducible():
    draws = sample_roughness_prior(32, random_state=5)
    assert draws == sample_roughness_prior(32, random_state=5)
    for p in ROUGHNESS_PRIOR:
        values = np.array([getattr(d, p.name) for d in draws])
        assert p.low <= values.min() and values.max() <= p.high and p.source
        # a Latin hypercube: one draw in each of the 32 strata of the (log) range
        u = (np.log(values / p.low) / math.log(p.high / p.low)) if p.log else (values - p.low) / (p.high - p.low)
        assert sorted(np.floor(32 * u).astype(int)) == list(range(32))
    with pytest.raises(ValueError, match="reading_level"):
        replace(DEFAULT_ROUGHNESS_INPUTS, reading_level=1.5)
    with pytest.raises(ValueError, match="n must be"):
        sample_roughness_prior(0)


def test_smooth_bodies_give_no_law_and_the_ratio_one_exactly():
    d = DEFAULT_ROUGHNESS_INPUTS
    assert d.bodies(0.0, None).smooth and d.bodies(None, 0.0).smooth
    assert sphere_growth(HS, 2500.0, d, 0.0) == 1.0


def test_an_asperity_cannot_stain_a_film_whose_activation_lies_above_the_coating_hardness():
    """Local pressures are capped by the hardness H: while the real contact is partial (below the law's
    saturation) no spot of a film activating above H is coloured; only once the nominal pressure itself
    carries the film past its activation does the coverage rise."""
    inputs = replace(representative_roughness_inputs(), film_hardness_mpa=90.0)
    _, _, law = HHS.interface(MODULUS["HHS"], inputs.bodies(1.5))
    p = np.linspace(1.0, law.saturation_pressure_mpa, 50)
    assert np.all(coverage(HHS, law, p) == 0.0)
    level = coverage_level_mpa(HHS, law, 0.1, 1000.0)
    assert law.saturation_pressure_mpa < level < 130.0 + 20.0  # near the activation pressure (130 MPa)
    # a soft film is coloured by the same asperities far below its activation's nominal contour
    _, _, soft = HS.interface(MODULUS["HS"], inputs.bodies(1.5))
    assert coverage_level_mpa(HS, soft, 0.1, 1000.0) < 0.5 * 50.0


def test_a_higher_reading_level_reads_a_smaller_rough_imprint():
    d = representative_roughness_inputs()
    film, law, rough = HS.interface(MODULUS["HS"], d.bodies(1.5))
    result = sphere_on_flat_contact(450.0, 50e3, film=film, law=law)
    areas = [rough_recorded_area_mm2(HS, result, rough, level) for level in (0.02, 0.1, 0.3, 0.6)]
    assert all(a > b for a, b in zip(areas, areas[1:]))
    # the reading level 0 limit: the nominal field's zero outline
    assert areas[0] < float(result.area_mm2) * 1.0001


def test_observation_likelihoods_follow_their_closed_forms():
    s = DETECTION_SCATTER
    seen, unseen = PAPER_ROUGH_FLAT[1], PAPER_ROUGH_FLAT[2]
    assert seen.detected and not unseen.detected
    assert observation_likelihood(seen, np.array(s)) == pytest.approx(0.5)
    assert observation_likelihood(unseen, np.array(0.0)) == pytest.approx(norm.cdf(1) - norm.cdf(-1))
    measured = RoughFlatObservation("HS", 1.5, growth=0.05)
    assert observation_likelihood(measured, np.array(0.05)) == pytest.approx(1.0 / (s * math.sqrt(2 * math.pi)))
    with pytest.raises(ValueError):
        RoughFlatObservation("HS", 1.5)


def test_conditioning_weights_and_systematic_resampling():
    growth = np.array([0.0, 0.02, 0.06, 0.10])
    w, n_eff = condition_weights({0: growth}, [PAPER_ROUGH_FLAT[0]])
    assert np.all(np.diff(w) > 0) and w.sum() == pytest.approx(1.0) and 1.0 < n_eff < 4.0
    idx = resample(np.array([0.5, 0.25, 0.25, 0.0]), 8)
    assert sorted(np.bincount(idx, minlength=4)) == [0, 2, 2, 4]


def test_growth_summary_weights_and_monte_carlo_error():
    g = RoughGrowth(np.array([1.02, 1.04, 1.06, 1.08]), np.ones(4), np.full(4, 0.25))
    s = g.summary()
    assert s["film_growth"]["mean_pct"] == pytest.approx(5.0)
    sd = np.std([2.0, 4.0, 6.0, 8.0])
    assert s["film_growth"]["sd_pct"] == pytest.approx(sd) and s["film_growth"]["mc_error_pct"] == pytest.approx(sd / 2)
    assert s["correction_factor_change"]["mean_pct"] < 0
    assert weighted_quantiles(np.array([1.0, 2.0, 3.0]), np.ones(3), [0.5])[0] == pytest.approx(2.0)


def test_shipped_draws_are_conditioned_on_the_paper_and_load_without_code():
    prior, cond = load_roughness_inputs("prior"), load_roughness_inputs()
    assert len(cond) >= 8 and set(cond) <= set(prior)
    assert representative_roughness_inputs() in cond
    with pytest.raises(ValueError):
        load_roughness_inputs("posterior")
    with pytest.raises(ValueError, match="unknown keys"):
        RoughnessInputs.from_dict({**DEFAULT_ROUGHNESS_INPUTS.to_dict(), "code": "import os"})


@pytest.mark.slow
def test_the_representative_draw_reproduces_the_paper_roughened_flat():
    """The paper (section 2): on a flat roughened to Ra ~ 1.5 um, MS and HS imprints grew, HHS's did not."""
    d = representative_roughness_inputs()
    growth = {name: sphere_growth(model, MODULUS[name], d, 1.5) - 1.0
              for name, model in (("MS", MS), ("HS", HS), ("HHS", HHS))}
    assert growth["MS"] >= 0.02 and growth["HS"] >= 0.02, growth
    assert abs(growth["HHS"]) <= 0.01, growth


@pytest.mark.slow
def test_a_dataset_with_flat_ra_calibrates_stiffer_as_the_rough_law_says():
    """Rows measured on a roughened flat (flat_ra_um): the model radius there is the smooth one times
    sqrt(g_f), g_f > 1 for HS (its imprint grows on a rough flat), so the same measured radii are fitted
    by a stiffer film (a smaller film enlargement) than when the column is ignored; without the growth the
    problem refuses the rows instead of calibrating them as smooth."""
    from dataclasses import replace as dc_replace

    from filmcal.calibration import CalibrationProblem
    from filmcal.calibration.datasets import load_table1
    from filmcal.calibration.roughness import RoughFlatGrowth
    from filmcal.hertz import hertz_radius_mm

    class FilmEnlargement:  # a smooth model of the imprint radius: Hertz plus a film term falling with E
        def predict(self, e, nu, r, f):
            return hertz_radius_mm(r, f) + 2800.0 / np.asarray(e) * 1.1, np.zeros_like(np.asarray(e, float))

    data = load_table1("HS", "50-100")
    rough = dc_replace(data, flat_ra_um=np.where(data.force_n == 50e3, 1.5, np.nan))
    growth = RoughFlatGrowth(FilmModel(get_film("HS"), "edge", "small"), (1000.0, 8000.0), n_moduli=3)
    with pytest.raises(ValueError, match="roughened flat"):
        CalibrationProblem(rough, FilmEnlargement())
    plain = CalibrationProblem(data, FilmEnlargement())
    with_ra = CalibrationProblem(rough, FilmEnlargement(), rough_flat=growth)
    e = np.geomspace(1000.0, 8000.0, 400)
    nu = np.full(e.size, 0.33)

    def best(problem) -> float:
        mean, _ = problem.model_radius(e, nu)
        return float(e[np.argmin(((mean - data.measured_radius_mm) ** 2).sum(axis=1))])

    factor = with_ra.model_radius(np.array([2800.0]), np.array([0.33]))[0] / \
        plain.model_radius(np.array([2800.0]), np.array([0.33]))[0]
    rows = data.force_n == 50e3
    assert np.all(factor[0, ~rows] == 1.0) and np.all(factor[0, rows] > 1.005)
    assert best(with_ra) > 1.02 * best(plain)


def test_a_synthetic_surface_beyond_the_micro_law_says_so():
    d = representative_roughness_inputs()
    with pytest.warns(UserWarning, match="rms slopes above 1"):
        d.surface(30.0)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        d.surface(1.5)
