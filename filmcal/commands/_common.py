"""Helpers shared by the subcommands: JSON output and common options."""
from __future__ import annotations

import json
import math
import sys
from typing import Any

import numpy as np


def _plain(obj: Any) -> Any:
    """Convert numpy scalars/arrays and non-finite floats to JSON-safe values."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return _plain(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def print_json(payload: dict) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(json.dumps(_plain(payload), indent=2) + "\n")
