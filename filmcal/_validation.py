"""Validation of parameters where they enter the package.

Every public entry point checks its physical parameters here, so that a bad
value raises one `ValueError` that names the parameter and its allowed range.
The CLI turns that error into one line on stderr and exit status 2.
"""
from __future__ import annotations

import argparse
import math
import re
from numbers import Real
from typing import Any, Callable

__all__ = ["as_finite", "plain_float", "plain_int", "check_positive", "check_range", "check_poisson", "check_choice",
           "check_count", "arg_finite", "arg_int_in", "arg_float_in", "parse_grid", "arg_grid", "FORCE_KN_BOUNDS",
           "SPHERE_RADIUS_MM_BOUNDS", "OFFSET_MM_BOUNDS"]


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


#: A force (load) range in kN: ``LOW-HIGH`` or ``VALUE``, non-negative numbers.
FORCE_RANGE = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*(?:-\s*(\d+(?:\.\d*)?)\s*)?$")


def as_bool(name: str, value: object) -> bool:
    """A boolean from True/False or the text 1/0, true/false, yes/no, y/n (empty: False)."""
    if isinstance(value, str):
        v = value.strip().lower()
        if v in ("1", "true", "yes", "y"):
            return True
        if v in ("0", "false", "no", "n", ""):
            return False
        raise ValueError(f"{name} must be a boolean (true/false), got {value!r}")
    return bool(value)


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


def check_count(name: str, value: object, low: int, high: int) -> int:
    """Return `value` as an int after checking low <= value <= high (a size, count or seed)."""
    if isinstance(value, bool):
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    try:
        n = int(value)  # type: ignore[call-overload]
        exact = n == value or (isinstance(value, str) and str(n) == value.strip())
    except (TypeError, ValueError, OverflowError):
        exact = False
    if not exact:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {value!r}")
    if not low <= n <= high:
        raise ValueError(f"{name} must be an integer in [{low}, {high}], got {n}")
    return n


# --- argparse types: the check happens while the options are parsed, before any work ---

def _argparse_type(convert: Callable[[str], Any], check: Callable[[Any], None], name: str,
                   bounds: tuple[float, float] | None = None) -> Callable[[str], Any]:
    def parse(text: str) -> Any:
        try:
            value = convert(text)
            check(value)
        except argparse.ArgumentTypeError:
            raise
        except (TypeError, ValueError, OverflowError) as exc:
            raise argparse.ArgumentTypeError(f"{exc}, got {text!r}") from None
        return value
    parse.__name__ = name
    parse.filmcal_checked = True  # type: ignore[attr-defined]
    parse.bounds = bounds  # type: ignore[attr-defined]
    return parse


def _require(ok: bool, what: str) -> None:
    if not ok:
        raise ValueError(what)


def plain_float(text: str) -> float:
    """A number as written on a command line or in a CSV cell: ASCII digits, sign, point, exponent. Python's
    `float` also reads ``1_0`` (10) and other scripts' digits, which no user means as a number."""
    if not text.isascii() or "_" in text:
        raise ValueError("must be a plain number (ASCII digits, a decimal point, no underscores)")
    try:
        return float(text)
    except ValueError:  # Python's wording ("could not convert string to float") is not the user's
        raise ValueError("must be a number") from None


def plain_int(text: str) -> int:
    """An integer as written on a command line or in a CSV cell: ASCII digits and a sign (`int` also reads
    ``1_0`` as 10, and other scripts' digits)."""
    if not text.isascii() or "_" in text:
        raise ValueError("must be a plain integer (ASCII digits, no underscores)")
    try:
        return int(text)
    except ValueError:  # Python's wording ("invalid literal for int()") is not the user's
        raise ValueError("must be an integer") from None


def arg_finite() -> Callable[[str], float]:
    """An argparse ``type`` for a finite float (nan and inf refused)."""
    return _argparse_type(plain_float, lambda x: _require(math.isfinite(x), "must be a finite number"), "float")


def arg_int() -> Callable[[str], int]:
    """An argparse ``type`` for an integer written plainly (``int`` alone reads ``1_0`` as 10)."""
    return _argparse_type(plain_int, lambda n: None, "int")


def arg_int_in(low: int, high: int) -> Callable[[str], int]:
    """An argparse ``type`` for an integer in [low, high]."""
    what = f"must be an integer in [{low}, {high}]"

    def convert(text: str) -> int:
        try:
            return plain_int(text)
        except ValueError:
            raise ValueError(what) from None
    return _argparse_type(convert, lambda n: _require(low <= n <= high, what), "int", (low, high))


def _arg_float(accept: Callable[[float], bool], what: str, bounds: tuple[float, float]) -> Callable[[str], float]:
    """An argparse ``type`` for a finite number that `accept` takes (`what` says which)."""
    def convert(text: str) -> float:
        try:
            return plain_float(text)
        except ValueError:
            raise ValueError(what) from None
    return _argparse_type(convert, lambda x: _require(math.isfinite(x) and accept(x), what), "float", bounds)


def arg_float_in(low: float, high: float) -> Callable[[str], float]:
    """An argparse ``type`` for a finite number in [low, high]."""
    return _arg_float(lambda x: low <= x <= high, f"must be a number in [{low:g}, {high:g}]", (low, high))


def arg_zero_or_in(low: float, high: float) -> Callable[[str], float]:
    """An argparse ``type`` for 0 or a finite number in [low, high] (0 < low): e.g. an Ra, 0 for smooth."""
    return _arg_float(lambda x: x == 0.0 or low <= x <= high, f"must be 0 or a number in [{low:g}, {high:g}]",
                      (0.0, high))


def _grid(text: str, max_count: int) -> list[float]:
    """`parse_grid` without the parameter's name in its messages."""
    form = "must be a comma-separated list or start:stop:step (step > 0) of finite numbers"
    if ":" in text:
        try:
            start, stop, step = (float(x) for x in text.split(":"))
        except ValueError:
            raise ValueError(f"{form}, got {text!r}") from None
        if not all(math.isfinite(v) for v in (start, stop, step)) or step <= 0 or stop < start:
            raise ValueError(f"{form}, got {text!r}")
        count = math.floor((stop - start) / step + 0.5) + 1
        if count > max_count:
            raise ValueError(f"{text!r} gives {count} values; at most {max_count}")
        return [round(start + i * step, 9) for i in range(count)]
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise ValueError(f"{form}, got {text!r}") from None
    if not values or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{form}, got {text!r}")
    if len(values) > max_count:
        raise ValueError(f"{text!r} gives {len(values)} values; at most {max_count}")
    repeated = sorted({v for v in values if values.count(v) > 1})
    if repeated:
        raise ValueError(f"{text!r} gives {', '.join(f'{v:g}' for v in repeated)} more than once")
    return values


def parse_grid(name: str, text: str, max_count: int) -> list[float]:
    """Values from ``a,b,c`` or ``start:stop:step`` (stop included), at most `max_count` of them.

    The number of values of a range is counted before it is built, so a tiny
    step is refused instead of exhausting memory.

    Raises
    ------
    ValueError
        Naming `name`, for text that is neither form, non-finite values, a
        step <= 0, stop < start, no value, a value given twice, or more than
        `max_count` values.
    """
    try:
        return _grid(text, max_count)
    except ValueError as exc:
        raise ValueError(f"{name}: {exc}") from None


def arg_grid(max_count: int) -> Callable[[str], str]:
    """An argparse ``type`` that checks a `parse_grid` text and returns it unchanged."""
    def parse(text: str) -> str:
        try:
            _grid(text, max_count)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
        return text
    parse.__name__ = "grid"
    parse.filmcal_checked = True  # type: ignore[attr-defined]
    parse.max_count = max_count  # type: ignore[attr-defined]
    return parse


#: The loads a command, a batch row or a served request takes (kN): 1 N to 2 MN; a sphere test or a wheel load
#: above 2 MN (a 200 t axle) is a unit error (N for kN), not a contact.
FORCE_KN_BOUNDS = (1e-3, 2000.0)
#: Sphere radius (mm) and lateral offset eta (mm) a measurement may have (an option, a batch row, a request).
SPHERE_RADIUS_MM_BOUNDS = (1.0, 1e5)
OFFSET_MM_BOUNDS = (-60.0, 60.0)
#: A film's Young's modulus (MPa): a Prescale film's lies in the hundreds to thousands; 1 MPa to 1 TPa covers
#: every film and refuses a unit error (Pa, GPa). A film's thickness (mm): 1 um to 5 mm.
FILM_MODULUS_MPA_BOUNDS = (1.0, 1e6)
FILM_THICKNESS_MM_BOUNDS = (0.001, 5.0)
#: A scanned imprint's pixel size (mm): 1 um to 1 mm (25400 to 25.4 dpi); beyond it the number is a unit error.
SCAN_PIXEL_MM_BOUNDS = (0.001, 1.0)
#: A hardness capping asperity pressures (MPa): a polymer coating's is tens to hundreds of MPa, a hardened
#: steel's up to about 8000 (800 HV); beyond these bounds the number is a unit error.
HARDNESS_MPA_BOUNDS = (1.0, 1e4)
#: The smallest Ra (um) a rough body may have: 10 nm, a super-finished steel surface; below it the growth of
#: any reading is far under a grid cell (Ra 0.01 um moves the wheel-rail area by < 0.5 %), and heights of a
#: few atoms are not a roughness the boundary elements resolve. A smooth body is given as Ra 0 (no surface).
MIN_RA_UM = 0.01
#: The shortest chain (steps per walker) a calibration may be capped at: below it no autocorrelation time
#: can be estimated, so neither burn-in nor thinning nor the diagnostics exist.
MIN_MCMC_STEPS = 100
#: The largest Ra (um) a synthetic surface is made for: a freshly reprofiled wheel.
MAX_RA_UM = 30.0


def check_ra(name: str, value: float) -> float:
    """An Ra in um: 0 (smooth) or within [`MIN_RA_UM`, `MAX_RA_UM`]."""
    x = as_finite(name, value)
    if not (x == 0.0 or MIN_RA_UM <= x <= MAX_RA_UM):
        raise ValueError(f"{name} must be 0 (smooth) or in [{MIN_RA_UM:g}, {MAX_RA_UM:g}] um, got {value!r}")
    return x
