"""FE designs through a campaign into a radius surrogate, seen by the calibration."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.fem import Film, get_model
from filmcal.study import FERadiusModel, SurrogateDomain, SurrogateRadiusModel, build_radius_surrogate

DOMAIN = SurrogateDomain(modulus_mpa=(1500.0, 6000.0), poisson=(0.32, 0.34), radius_levels_mm=(450.0, 600.0),
                         force_kn=(50.0, 100.0))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    study = tmp_path_factory.mktemp("study")
    surrogate, validation = build_radius_surrogate(study, domain=DOMAIN, n_train=30, n_test=12, seed=3,
                                                   workers=2, progress=False)
    return study, surrogate, validation


def test_surrogate_reproduces_held_out_fe_runs(built):
    _, _, validation = built
    assert validation.n == 12
    assert validation.area_rms_relative_error < 0.005
    assert validation.radius_max_error_mm < 0.03


def test_radius_model_agrees_with_the_fe_model(built):
    _, surrogate, _ = built
    model = SurrogateRadiusModel(surrogate, DOMAIN)
    mean, std = model.predict(np.array([2500.0, 4000.0]), 0.33, 450.0, 75e3)
    fe, fe_std = FERadiusModel().predict(np.array([2500.0, 4000.0]), 0.33, 450.0, 75e3)
    direct = [get_model(450.0).solve(Film(e, 0.33), 75e3).contact_radius_mm for e in (2500.0, 4000.0)]
    assert np.allclose(fe, direct) and np.all(fe_std == 0)
    assert np.all(np.abs(mean - fe) < 0.02)
    assert np.all(std > 0)


def test_outside_the_domain_is_nan(built):
    _, surrogate, _ = built
    mean, _ = SurrogateRadiusModel(surrogate, DOMAIN).predict(500.0, 0.33, 450.0, 75e3)
    assert np.isnan(mean)


def test_second_build_reuses_runs_and_surrogate(built):
    study, surrogate, validation = built
    again, validation2 = build_radius_surrogate(study, domain=DOMAIN, n_train=30, n_test=12, seed=3, workers=1,
                                                progress=False)
    X = {"modulus_mpa": np.array([3000.0]), "poisson": np.array([0.33]), "radius_mm": np.array([450.0]),
         "force_kn": np.array([75.0])}
    assert again.predict(X)[0] == surrogate.predict(X)[0]
    assert validation2.area_rms_relative_error == validation.area_rms_relative_error


def test_refinement_runs_fe_where_the_surrogate_is_least_certain(built):
    from filmcal.study import refine_radius_surrogate
    study, surrogate, _ = built
    result = refine_radius_surrogate(study, surrogate, domain=DOMAIN, target=1e-9, max_evaluations=8,
                                     batch_size=4, workers=1, experiments_radii_mm=(450.0, 600.0),
                                     experiments_force_kn=(50.0, 100.0))
    refined = result.surrogate
    assert len(refined.y_train_) == len(surrogate.y_train_) + 8
    # the new runs came from the FE model: they are stored in the study's campaign
    from filmcal.campaign import RunStore
    assert RunStore(study / "runs.sqlite").counts().ok >= 30 + 12 + 8
