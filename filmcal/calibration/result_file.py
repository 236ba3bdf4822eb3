"""The calibration result file: its format marker and its one reader (plain JSON, nothing executed).

Light on purpose (numpy and the JSON reader only): a correction reads the samples from here without
importing the sampler, the likelihood and the checks; `filmcal.calibration.load_result` builds the whole
result from the same payload.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from filmcal._errors import InputError
from filmcal._io import read_json

__all__ = ["FORMAT", "FORMAT_VERSION", "read_result_payload", "read_posterior_samples"]

FORMAT = "filmcal-calibration-result"
FORMAT_VERSION = 1


def read_result_payload(path: str | Path) -> dict:
    """The checked JSON payload of a result written by `filmcal.calibration.save_result`.

    Raises
    ------
    InputError
        When the file is not a filmcal calibration result of a version this release reads (a damaged file
        raises `DamagedFileError`, naming it).
    """
    payload = read_json(path)
    if not isinstance(payload, dict) or payload.get("format") != FORMAT:
        raise InputError(f"{str(path)!r} is not a filmcal calibration result")
    if payload.get("version") != FORMAT_VERSION:
        raise InputError(f"unsupported calibration result version {payload.get('version')!r} in {str(path)!r}")
    return payload


def read_posterior_samples(path: str | Path) -> dict[str, np.ndarray]:
    """The posterior samples of a result file (what a corrector needs of it)."""
    payload = read_result_payload(path)
    if not isinstance(payload.get("samples"), dict):
        raise InputError(f"{str(path)!r} holds no posterior samples")
    return {k: np.asarray(v, dtype=float) for k, v in payload["samples"].items()}
