"""Helpers shared by the subcommands: JSON output and common options."""
from __future__ import annotations

import json
import sys

from filmcal._json import json_safe


def print_json(payload: dict) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(json.dumps(json_safe(payload), indent=2) + "\n")
