"""Named design spaces: parameters, their ranges, and the map to the unit cube.

A design is built in the unit cube ``[0, 1)^d``, one dimension per free
parameter, and mapped to physical values parameter by parameter:

- continuous, linear scale: ``x = low + u (high - low)``;
- continuous, log scale: ``x = low (high / low)^u`` (``low > 0``), for
  quantities spanning decades such as ``modulus_mpa``;
- discrete levels ``v_0 < ... < v_{L-1}``: the unit interval is cut into ``L``
  equal bins and ``u`` maps to the level of its bin, ``floor(u L)``; level
  ``i`` sits at the bin centre ``(i + 0.5) / L``, the nearest level position to
  ``u``. A Latin column of ``n`` points then holds each level ``n / L`` times
  (to within one), but the column is no longer Latin in physical space;
- fixed value: the parameter takes no dimension of the unit cube and the same
  value at every point.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from filmcal._validation import as_finite

__all__ = ["Parameter", "DesignSpace", "parse_parameter"]

SCALES = ("linear", "log")
_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.\-]*$")


@dataclass(frozen=True)
class Parameter:
    """One named parameter of a design space.

    Give exactly one of: a range (``low``, ``high``), discrete ``levels``, or a
    ``fixed`` value. For levels and fixed values ``low`` and ``high`` are filled
    in from them (smallest and largest value).

    Parameters
    ----------
    name : str
        Column name, e.g. ``"modulus_mpa"`` (letters, digits, ``_ . -``).
    low, high : float, optional
        Bounds of a continuous range, ``low < high``.
    unit : str, optional
        Unit, for reports (the name should already carry it).
    scale : {'linear', 'log'}
        How the unit interval maps onto ``[low, high]``; ``'log'`` needs
        ``low > 0`` and applies to continuous ranges only.
    fixed : float, optional
        A constant value.
    levels : sequence of float, optional
        At least two distinct finite values, stored in increasing order.

    Raises
    ------
    ValueError
        For a bad name, bound, scale or level; the message names the parameter.
    """

    name: str
    low: float | None = None
    high: float | None = None
    unit: str = ""
    scale: str = "linear"
    fixed: float | None = None
    levels: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not _NAME.match(self.name):
            raise ValueError(f"parameter name must start with a letter or '_' and hold only "
                             f"letters, digits, '_', '.', '-'; got {self.name!r}")
        if self.scale not in SCALES:
            raise ValueError(f"{self.name}: unknown scale {self.scale!r}; use linear or log")
        kinds = sum([self.low is not None or self.high is not None,
                     self.fixed is not None, self.levels is not None])
        if kinds != 1:
            raise ValueError(f"{self.name}: give exactly one of a range (low, high), levels, "
                             f"or a fixed value")
        if self.levels is not None:
            self._init_levels()
        elif self.fixed is not None:
            value = as_finite(self.name, self.fixed)
            self._set(fixed=value, low=value, high=value)
        else:
            self._init_range()

    def _set(self, **values: object) -> None:
        for key, value in values.items():
            object.__setattr__(self, key, value)

    def _init_range(self) -> None:
        if self.low is None or self.high is None:
            raise ValueError(f"{self.name}: a range needs both low and high")
        low = as_finite(f"{self.name} low", self.low)
        high = as_finite(f"{self.name} high", self.high)
        if not low < high:
            raise ValueError(f"{self.name}: low must be < high, got low={low:g}, high={high:g}")
        if not math.isfinite(high - low):
            raise ValueError(f"{self.name}: the range {low:g}:{high:g} is wider than a float holds")
        if self.scale == "log" and low <= 0.0:
            raise ValueError(f"{self.name}: log scale needs low > 0, got low={low:g}")
        self._set(low=low, high=high)

    def _init_levels(self) -> None:
        if self.scale != "linear":
            raise ValueError(f"{self.name}: scale='log' applies to a continuous range only, "
                             f"not to levels")
        values = sorted(as_finite(f"{self.name} level", v) for v in self.levels)
        if len(set(values)) < 2 or len(set(values)) != len(values):
            raise ValueError(f"{self.name}: levels must be at least two distinct values, "
                             f"got {self.levels!r}")
        self._set(levels=tuple(values), low=values[0], high=values[-1])

    @property
    def is_fixed(self) -> bool:
        """True if the parameter is a constant (takes no unit-cube dimension)."""
        return self.fixed is not None

    @property
    def is_discrete(self) -> bool:
        """True if the parameter takes one of a finite set of levels."""
        return self.levels is not None

    def to_physical(self, u: np.ndarray) -> np.ndarray:
        """Map unit-interval values ``u`` to physical values of this parameter.

        Parameters
        ----------
        u : array_like
            Values in ``[0, 1]`` (ignored except for its shape if fixed).

        Returns
        -------
        ndarray
            Physical values, within ``[low, high]``.
        """
        u = np.asarray(u, dtype=float)
        if self.is_fixed:
            return np.full(u.shape, self.fixed)
        if self.is_discrete:
            n_levels = len(self.levels)
            index = np.clip(np.floor(u * n_levels).astype(int), 0, n_levels - 1)
            return np.asarray(self.levels)[index]
        if self.scale == "log":
            x = np.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        else:
            x = self.low + u * (self.high - self.low)
        return np.clip(x, self.low, self.high)

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """Map physical values ``x`` of a free parameter to the unit interval.

        A discrete value maps to the centre of its level's bin.

        Raises
        ------
        ValueError
            If the parameter is fixed, a value lies outside ``[low, high]`` or a
            discrete value is not one of the levels.
        """
        if self.is_fixed:
            raise ValueError(f"{self.name} is fixed and has no unit-cube coordinate")
        x = np.asarray(x, dtype=float)
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{self.name}: values must be finite")
        if np.any(x < self.low) or np.any(x > self.high):
            bad = x[(x < self.low) | (x > self.high)].flat[0]
            raise ValueError(f"{self.name} must lie in [{self.low:g}, {self.high:g}], got {bad:g}")
        if self.is_discrete:
            levels = np.asarray(self.levels)
            index = np.abs(x[..., None] - levels).argmin(axis=-1)
            off = ~np.isclose(levels[index], x, rtol=1e-9, atol=0.0)
            if np.any(off):
                raise ValueError(f"{self.name} must be one of the levels "
                                 f"{', '.join(f'{v:g}' for v in levels)}; got {x[off].flat[0]:g}")
            return (index + 0.5) / len(levels)
        if self.scale == "log":
            return (np.log(x) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (x - self.low) / (self.high - self.low)


@dataclass(frozen=True)
class DesignSpace:
    """An ordered set of named parameters, with the unit-cube map.

    The unit cube has one dimension per free (not fixed) parameter, in the
    order of `parameters`; physical arrays have one column per parameter,
    fixed ones included.

    Parameters
    ----------
    parameters : sequence of Parameter
        At least one free parameter; names must be unique.
    """

    parameters: tuple[Parameter, ...]

    def __post_init__(self) -> None:
        params = tuple(self.parameters)
        if not params or not all(isinstance(p, Parameter) for p in params):
            raise ValueError("a design space needs at least one Parameter")
        names = [p.name for p in params]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            raise ValueError(f"parameter names must be unique; repeated: {', '.join(repeated)}")
        if all(p.is_fixed for p in params):
            raise ValueError("a design space needs at least one parameter that varies "
                             "(a range or levels), not only fixed values")
        object.__setattr__(self, "parameters", params)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of all parameters (the columns of a physical design)."""
        return tuple(p.name for p in self.parameters)

    @property
    def free(self) -> tuple[Parameter, ...]:
        """The parameters that vary, one per unit-cube dimension."""
        return tuple(p for p in self.parameters if not p.is_fixed)

    @property
    def d(self) -> int:
        """Dimension of the unit cube (number of free parameters)."""
        return len(self.free)

    def _check_columns(self, array: np.ndarray, width: int, what: str) -> np.ndarray:
        array = np.asarray(array, dtype=float)
        if array.ndim != 2 or array.shape[1] != width:
            raise ValueError(f"{what} must be an array of shape (n, {width}), got {array.shape}")
        return array

    def to_physical(self, unit: np.ndarray) -> np.ndarray:
        """Map unit-cube points, shape ``(n, d)``, to physical points ``(n, len(names))``."""
        unit = self._check_columns(unit, self.d, "unit-cube points")
        columns = iter(unit.T)
        out = [p.to_physical(np.zeros(len(unit)) if p.is_fixed else next(columns))
               for p in self.parameters]
        return np.column_stack(out)

    def to_unit(self, physical: np.ndarray) -> np.ndarray:
        """Map physical points ``(n, len(names))`` to the unit cube ``(n, d)``.

        Raises
        ------
        ValueError
            If a value is outside its parameter's range, a discrete value is not
            a level, or a fixed parameter's column differs from its value.
        """
        physical = self._check_columns(physical, len(self.parameters), "physical points")
        out = []
        for p, column in zip(self.parameters, physical.T):
            if p.is_fixed:
                if not np.allclose(column, p.fixed, rtol=1e-9, atol=0.0):
                    raise ValueError(f"{p.name} is fixed at {p.fixed:g} but the design holds "
                                     f"other values")
            else:
                out.append(p.to_unit(column))
        return np.column_stack(out)


def _number(name: str, text: str) -> float:
    try:
        return as_finite(name, text)
    except ValueError:
        raise ValueError(f"{name}: {text!r} is not a finite number") from None


def parse_parameter(spec: str) -> Parameter:
    """Parse a parameter given on the command line.

    Forms: ``name=low:high`` (linear range), ``name=low:high:log`` (log
    scale; ``:linear`` is accepted too), ``name=v1,v2,...`` (discrete levels),
    ``name=value`` (fixed).

    Parameters
    ----------
    spec : str
        The specification.

    Returns
    -------
    Parameter

    Raises
    ------
    ValueError
        For an unknown form or bad numbers; the message names the parameter.

    Examples
    --------
    >>> parse_parameter("modulus_mpa=50:5000:log").scale
    'log'
    >>> parse_parameter("sphere_radius_mm=300,450,600").levels
    (300.0, 450.0, 600.0)
    """
    name, sep, body = spec.partition("=")
    name, body = name.strip(), body.strip()
    if not sep or not name or not body:
        raise ValueError(f"parameter {spec!r}: expected name=low:high[:log], "
                         f"name=v1,v2,... or name=value")
    if ":" in body and "," in body:
        raise ValueError(f"{name}: {body!r} mixes a range (':') and levels (',')")
    if ":" in body:
        parts = body.split(":")
        if len(parts) not in (2, 3):
            raise ValueError(f"{name}: expected low:high or low:high:log, got {body!r}")
        scale = parts[2].strip() if len(parts) == 3 else "linear"
        return Parameter(name, low=_number(name, parts[0]), high=_number(name, parts[1]),
                         scale=scale)
    if "," in body:
        return Parameter(name, levels=tuple(_number(name, v) for v in body.split(",")))
    return Parameter(name, fixed=_number(name, body))
