"""The mixture weights as functions of the leave-one-out terms: smooth, symmetric, and right at the limits."""
from __future__ import annotations

import numpy as np
import pytest

from filmcal.calibration.comparison import pseudo_bma_plus_weights, stacking_weights


def _terms(seed: int = 0, n_models: int = 4, n_cases: int = 10) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.5, 1.0, (n_models, n_cases))


def test_moving_one_elpd_by_0_1_moves_no_weight_by_more_than_0_05():
    for seed in range(5):
        terms = _terms(seed)
        base = pseudo_bma_plus_weights(terms)
        for k in range(terms.shape[0]):
            for sign in (-1.0, 1.0):
                moved = terms.copy()
                moved[k] += sign * 0.1 / terms.shape[1]  # the model's ELPD moves by 0.1
                assert np.max(np.abs(pseudo_bma_plus_weights(moved) - base)) <= 0.05


def test_weights_have_no_step_across_the_elpd_gap():
    """A model falling behind by 0 to 8 in ELPD loses its weight gradually (the rule this replaces cut it to
    zero at a gap of max(4, 2 se))."""
    terms = _terms(1, n_models=2)
    previous = None
    for gap in np.arange(0.0, 8.01, 0.1):
        shifted = terms.copy()
        shifted[1] = terms[0] - gap / terms.shape[1]
        w = pseudo_bma_plus_weights(shifted)[1]
        if previous is not None:
            assert 0.0 <= previous - w <= 0.05
        previous = w
    assert previous < 0.01


def test_identical_models_share_equally_and_a_dominated_one_gets_nothing():
    terms = _terms(2, n_models=1)
    same = np.vstack([terms, terms, terms])
    np.testing.assert_allclose(pseudo_bma_plus_weights(same), 1 / 3, rtol=1e-12)
    assert stacking_weights(same).sum() == pytest.approx(1.0)
    worse = np.vstack([terms, terms - 3.0])  # every case predicted e^3 times less well
    assert stacking_weights(worse)[0] == pytest.approx(1.0, abs=1e-3)
    assert pseudo_bma_plus_weights(worse)[0] > 0.999
