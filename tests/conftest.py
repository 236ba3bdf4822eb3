"""Shared fixtures: FE models are expensive to build, so each radius is built once per run."""
from __future__ import annotations

import pytest

from filmcal.fem import get_model


@pytest.fixture(scope="session")
def model450():
    """The paper-resolution model of the R450 sphere."""
    return get_model(450.0)
