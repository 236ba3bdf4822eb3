"""Shared fixtures: FE models are expensive to build, so each radius is built once per run."""
from __future__ import annotations

import pytest

from filmcal.fem import get_model


@pytest.fixture(scope="session")
def model450():
    """The paper-resolution model of the R450 sphere."""
    return get_model(450.0)


@pytest.fixture(scope="session")
def quick_study(tmp_path_factory):
    """One quick pipeline run (HS film) through the CLI: its folder and its JSON summary."""
    import json
    import subprocess
    import sys

    study = tmp_path_factory.mktemp("quick-study")
    cmd = [sys.executable, "-m", "filmcal.cli", "pipeline", "--quick", "--films", "HS", "--workers", "2",
           "--study-dir", str(study), "--json"]
    run = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-3000:]
    return study, json.loads(run.stdout), cmd
