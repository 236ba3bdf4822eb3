"""A study's own roughened-flat data condition the roughness inputs again."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from filmcal.calibration.data import RadiusErrorData
from filmcal.calibration.roughness import (RADIUS_SCATTER_MM, dataset_rough_flat_observations,
                                           observation_likelihood, reweighted_inputs)
from filmcal.contact.rough_imprint import load_roughness_inputs


def _data(rows):
    film, r, f, y, ra = (np.array(c) for c in zip(*rows))
    return RadiusErrorData(film=film, sphere_radius_mm=r, force_n=f, radius_error_mm=np.zeros(len(y)),
                           hertz_radius_mm=y, measured_radius_mm=y, flat_ra_um=ra)


def test_observations_pair_each_rough_case_with_its_smooth_twin():
    """Growth (r_rough / r_smooth)^2 - 1 from the cases' means; scatter 2 sqrt(s^2/n_r/r_r^2 + s^2/n_s/r_s^2)
    with s the pooled within-case standard deviation; a rough case without a smooth twin and another film's
    rows are no observations."""
    nan = float("nan")
    rows = [("HS", 450.0, 50e3, 6.00, nan), ("HS", 450.0, 50e3, 6.02, nan),
            ("HS", 450.0, 50e3, 6.20, 1.5), ("HS", 450.0, 50e3, 6.24, 1.5),
            ("HS", 300.0, 50e3, 5.60, 1.5), ("MS", 450.0, 50e3, 7.0, 1.5), ("MS", 450.0, 50e3, 6.8, 0.0)]
    [obs] = dataset_rough_flat_observations(_data(rows), "HS")
    assert (obs.film, obs.ra_um, obs.sphere_radius_mm, obs.force_kn) == ("HS", 1.5, 450.0, 50.0)
    assert obs.growth == pytest.approx((6.22 / 6.01) ** 2 - 1.0, rel=1e-12)
    s = math.sqrt((0.01 ** 2 * 2 + 0.02 ** 2 * 2) / 2)  # pooled over the two repeated cases (1 dof each)
    assert obs.scatter == pytest.approx(2 * math.hypot(s / math.sqrt(2) / 6.22, s / math.sqrt(2) / 6.01), rel=1e-9)
    # without repeats the scatter of one imprint is the calibration's noise level
    [ms] = dataset_rough_flat_observations(_data(rows), "MS")
    assert ms.growth == pytest.approx((7.0 / 6.8) ** 2 - 1.0)
    assert ms.scatter == pytest.approx(2 * math.hypot(RADIUS_SCATTER_MM / 7.0, RADIUS_SCATTER_MM / 6.8))


def test_reweighting_favours_the_draws_that_predict_the_observed_growth():
    """Importance weights proportional to each draw's likelihood (a Gaussian in the growth); the resampled set
    keeps the number of draws, is reproducible, and its order does not follow the weights' (a fair first N)."""
    draws = load_roughness_inputs()
    rows = [("HS", 450.0, 50e3, 6.0, float("nan")), ("HS", 450.0, 50e3, 6.0 * math.sqrt(1.05), 1.5)]
    [obs] = dataset_rough_flat_observations(_data(rows), "HS")
    predicted = np.linspace(0.0, 0.20, len(draws))
    out = reweighted_inputs(draws, {0: predicted}, [obs], random_state=3)
    like = observation_likelihood(obs, predicted)
    np.testing.assert_allclose(out["weights"], like / like.sum(), rtol=1e-12)
    assert out["effective_draws"] == pytest.approx(1.0 / np.sum((like / like.sum()) ** 2))
    assert len(out["conditioned"]) == len(draws)
    kept = [draws.index(d) for d in out["conditioned"]]
    near = int(np.argmin(np.abs(predicted - 0.05)))
    assert kept.count(near) >= kept.count(0) and kept.count(len(draws) - 1) == 0
    assert out == reweighted_inputs(draws, {0: predicted}, [obs], random_state=3)
    assert kept != sorted(kept)


def test_a_study_with_roughened_flat_data_uses_its_own_draws(tmp_path, monkeypatch):
    """The pipeline's roughness stage on a study whose dataset has Table 1's HS rows plus one imprint on a flat at
    Ra 1.5 um that grew by 4 % in area (the film at a posterior median given here, no calibration needed): it
    keeps the draws conditioned again (recorded, kind roughness-inputs), weighted towards the draws predicting
    small growths, and the study's corrections and curves then use them (`Study.roughness_inputs`)."""
    import warnings

    from filmcal.calibration.datasets import load_table1
    from filmcal.study import Study
    from filmcal.study.stages import RoughnessConditioningWarning, _roughness_stage

    d = load_table1("HS")
    lines = ["film,sphere_radius_mm,force_kn,measured_radius_mm,flat_ra_um"]
    for r, f, y in zip(d.sphere_radius_mm, d.force_n, d.measured_radius_mm):
        lines.append(f"HS,{r:g},{f / 1e3:g},{y:.4f},")
        if r == 450.0 and f == 50e3:
            lines.append(f"HS,{r:g},{f / 1e3:g},{y * math.sqrt(1.04):.4f},1.5")
    (tmp_path / "rough.csv").write_text("\n".join(lines) + "\n")

    class Stage:  # the progress display's stage, silent
        def set_total(self, n):
            pass

        def advance(self, *args, **kwargs):
            pass

        def log(self, text):
            pass

    import filmcal.contact.rough_imprint as rough_imprint

    shipped = rough_imprint.load_roughness_inputs()[:6]  # six of the shipped draws (five distinct), for time
    monkeypatch.setattr(rough_imprint, "load_roughness_inputs", lambda which="conditioned": list(shipped))
    study = Study(tmp_path / "st", create=True)
    assert "shipped with filmcal" in study.roughness_inputs()[1]
    medians = {"HS": {"modulus_mpa": 2562.0, "model": "edge/large", "kinematics": "large"}}
    with study.writing(), warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        study.dataset_rows("HS", None, str(tmp_path / "rough.csv"))
        assert _roughness_stage(study, ["HS"], medians, 0, 2, Stage()) == (None, True)
        assert _roughness_stage(study, ["HS"], medians, 0, 2, Stage()) == (None, False)  # kept
    kept = json.loads((study.root / "roughness-inputs.json").read_text())
    manifest = json.loads((study.root / "study.json").read_text())
    assert manifest["artefacts"]["roughness-inputs.json"]["kind"] == "roughness-inputs"
    growth = np.array(kept["predicted_growth"]["0"])
    w = np.array(kept["weights"])
    assert [o["growth"] for o in kept["observations"]] == pytest.approx([0.04], abs=2e-4)
    # the weight goes where the predicted growth is nearest the observed 4 % (the shipped draws predict more)
    assert float(np.sum(w * growth)) < float(np.mean(growth)) and w[np.argmin(growth)] == w.max()
    assert any(issubclass(c.category, RoughnessConditioningWarning) for c in caught) == (kept["effective_draws"] < 4)
    draws, source = Study(tmp_path / "st").roughness_inputs()
    assert "this study's roughened-flat data" in source
    assert [x.to_dict() for x in draws] == kept["conditioned"]
