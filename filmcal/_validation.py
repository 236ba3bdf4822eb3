"""Validation of parameters where they enter the package.

Every public entry point checks its physical parameters here, so that a bad
value raises one `ValueError` that names the parameter and its allowed range.
The CLI turns that error into one line on stderr and exit status 2.
"""
from __future__ import annotations

import math
from numbers import Real

__all__ = ["as_finite", "check_positive", "check_range", "check_poisson", "check_choice"]


def as_finite(name: str, value: object) -> float:
    """Return `value` as a finite float or raise a `ValueError` naming `name`."""
    if isinstance(value, bool) or not isinstance(value, (Real, str)):
        try:
            value = float(value)  # numpy scalars, 0-d arrays
        except (TypeError, ValueError):
            raise ValueError(f"{name} must be a finite number, got {value!r}") from None
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return x


def check_positive(name: str, value: object) -> float:
    """Return `value` as a float after checking that it is finite and > 0."""
    x = as_finite(name, value)
    if x <= 0.0:
        raise ValueError(f"{name} must be > 0, got {x:g}")
    return x


def check_range(name: str, value: object, low: float, high: float,
                low_open: bool = True, high_open: bool = True) -> float:
    """Return `value` as a float after checking it lies in the given interval."""
    x = as_finite(name, value)
    below = x <= low if low_open else x < low
    above = x >= high if high_open else x > high
    if below or above:
        lb = "(" if low_open else "["
        hb = ")" if high_open else "]"
        raise ValueError(f"{name} must lie in {lb}{low:g}, {high:g}{hb}, got {x:g}")
    return x


def check_poisson(name: str, value: object) -> float:
    """Poisson's ratio of an isotropic elastic solid: -1 < nu < 0.5."""
    return check_range(name, value, -1.0, 0.5)


def check_choice(name: str, value: str, choices: tuple[str, ...] | list[str]) -> str:
    """Return `value` if it is one of `choices`, else raise a `ValueError`."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(choices)}; got {value!r}")
    return value
