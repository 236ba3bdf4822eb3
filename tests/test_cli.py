"""The command line as a whole: every subcommand is discovered and explains itself."""
from __future__ import annotations

import pkgutil
import subprocess
import sys

import pytest

import filmcal.commands

SUBCOMMANDS = sorted(m.name for m in pkgutil.iter_modules(filmcal.commands.__path__) if not m.name.startswith("_"))


def test_top_level_help_lists_every_subcommand():
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", "--help"], capture_output=True, text=True, timeout=60)
    assert p.returncode == 0, p.stderr
    assert len(SUBCOMMANDS) >= 10
    for name in SUBCOMMANDS:
        assert f"\n    {name}" in p.stdout, name


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_subcommand_help(name):
    p = subprocess.run([sys.executable, "-m", "filmcal.cli", name, "--help"], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0 and "usage: filmcal " + name in p.stdout, p.stderr
