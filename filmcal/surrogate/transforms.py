"""Named input columns and the transforms between physical and GP coordinates.

Inputs arrive as named columns (a mapping such as a dict or a pandas DataFrame,
a numpy structured array, or a plain 2-D array whose columns follow the
surrogate's input names). Each input is optionally log-transformed and then
scaled, to the unit cube (``"unit"``) or to z-scores (``"zscore"``). The output
is optionally log-transformed and then standardised. Both transforms are small
frozen dataclasses with a JSON-able description, so a saved surrogate
reproduces them exactly.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = [
    "INPUT_SCALINGS",
    "OUTPUT_TRANSFORMS",
    "column_names",
    "as_input_matrix",
    "as_output_vector",
    "InputTransform",
    "OutputTransform",
]

INPUT_SCALINGS = ("unit", "zscore")
OUTPUT_TRANSFORMS = ("standardize", "log")


def column_names(X: object) -> list[str] | None:
    """Column names of a mapping, DataFrame or structured array; None for an unnamed array."""
    if isinstance(X, np.ndarray):
        return list(X.dtype.names) if X.dtype.names is not None else None
    if isinstance(X, Mapping) or hasattr(X, "columns"):
        return [str(k) for k in X.keys()]
    return None


def as_input_matrix(X: object, names: Sequence[str]) -> np.ndarray:
    """Return `X` as a finite float array of shape (n, len(names)).

    Parameters
    ----------
    X : mapping, DataFrame, structured array or array_like of shape (n, d)
        Named columns must be exactly `names` (any order); an unnamed array
        must have ``d == len(names)`` columns in the order of `names`.
    names : sequence of str
        The input names.

    Raises
    ------
    ValueError
        For unknown or missing columns, a wrong shape or non-finite values.
    """
    keys = column_names(X)
    if keys is not None:
        unknown = [k for k in keys if k not in names]
        missing = [n for n in names if n not in keys]
        if unknown:
            raise ValueError(f"unknown input column(s) {unknown}; the inputs are {list(names)}")
        if missing:
            raise ValueError(f"missing input column(s) {missing}; the inputs are {list(names)}")
        columns = [np.asarray(X[name], dtype=float).reshape(-1) for name in names]
        lengths = {c.size for c in columns}
        if len(lengths) > 1:
            raise ValueError(f"input columns have different lengths {sorted(lengths)}")
        matrix = np.column_stack(columns) if columns else np.empty((0, 0))
    else:
        try:
            matrix = np.asarray(X, dtype=float)
        except (TypeError, ValueError):
            raise ValueError("X must be numeric: a 2-D array or named columns") from None
        if matrix.ndim != 2:
            raise ValueError(f"X must be 2-D (n_points, {len(names)}), got shape {matrix.shape}")
        if matrix.shape[1] != len(names):
            raise ValueError(f"X has {matrix.shape[1]} columns, the inputs are {list(names)}")
    bad = ~np.isfinite(matrix)
    if bad.any():
        col = names[int(np.nonzero(bad.any(axis=0))[0][0])]
        raise ValueError(f"input {col!r} must be finite, found {int(bad.sum())} NaN/inf value(s)")
    return matrix


def as_output_vector(y: object, name: str, n: int | None = None) -> np.ndarray:
    """Return `y` as a finite float vector.

    Parameters
    ----------
    y : array_like of shape (n,) or (n, 1), or a mapping / DataFrame with column `name`
    name : str
        Output name (selects the column of a mapping).
    n : int, optional
        Required length (the number of input rows).

    Raises
    ------
    ValueError
        For a missing column, a wrong shape or length, or non-finite values.
    """
    keys = column_names(y)
    if keys is not None:
        if name not in keys:
            raise ValueError(f"output column {name!r} not found; got columns {keys}")
        y = y[name]
    try:
        vec = np.asarray(y, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"output {name!r} must be numeric") from None
    if vec.ndim == 2 and vec.shape[1] == 1:
        vec = vec[:, 0]
    if vec.ndim != 1:
        raise ValueError(f"output {name!r} must be 1-D (n_points,), got shape {vec.shape}")
    if n is not None and vec.size != n:
        raise ValueError(f"output {name!r} has {vec.size} values for {n} input rows")
    if not np.all(np.isfinite(vec)):
        raise ValueError(f"output {name!r} must be finite, found {int((~np.isfinite(vec)).sum())} NaN/inf value(s)")
    return vec


@dataclass(frozen=True)
class InputTransform:
    """Map physical inputs x to GP coordinates ``t = (g(x) - offset) / scale``.

    ``g`` is the natural log for the inputs flagged in `log`, else the identity.

    Attributes
    ----------
    names : tuple of str
        Input names, in column order.
    log : tuple of bool
        Whether each input is log-transformed.
    offset, scale : tuple of float
        Affine map applied after ``g``.
    """

    names: tuple[str, ...]
    log: tuple[bool, ...]
    offset: tuple[float, ...]
    scale: tuple[float, ...]

    @classmethod
    def fit(cls, names: Sequence[str], X: np.ndarray, log_inputs: Sequence[str] = (),
            scaling: str = "unit", bounds: Mapping[str, Sequence[float]] | None = None) -> InputTransform:
        """Learn the transform from training inputs.

        Parameters
        ----------
        names : sequence of str
            Input names, the columns of `X`.
        X : ndarray of shape (n, d)
            Training inputs in physical units.
        log_inputs : sequence of str
            Inputs to log-transform (they must be > 0).
        scaling : {"unit", "zscore"}
            ``"unit"`` maps ``[min, max]`` (or the given `bounds`) to [0, 1];
            ``"zscore"`` subtracts the mean and divides by the standard deviation.
        bounds : mapping of name -> (low, high), optional
            Physical domain of some inputs for ``"unit"`` scaling; inputs not
            listed use the range of the training data.
        """
        names = tuple(names)
        unknown = [n for n in log_inputs if n not in names]
        if unknown:
            raise ValueError(f"log_inputs names unknown input(s) {unknown}; the inputs are {list(names)}")
        if scaling not in INPUT_SCALINGS:
            raise ValueError(f"input_scaling must be one of {', '.join(INPUT_SCALINGS)}; got {scaling!r}")
        bounds = dict(bounds or {})
        unknown = [n for n in bounds if n not in names]
        if unknown:
            raise ValueError(f"input_bounds names unknown input(s) {unknown}; the inputs are {list(names)}")
        log = tuple(n in log_inputs for n in names)
        G = _forward_log(X, log, names)
        offset, scale = [], []
        for j, name in enumerate(names):
            col = G[:, j]
            if scaling == "zscore":
                lo, width = float(col.mean()), float(col.std())
            elif name in bounds:
                lo_hi = np.asarray(bounds[name], dtype=float)
                if lo_hi.shape != (2,) or not np.all(np.isfinite(lo_hi)) or lo_hi[0] >= lo_hi[1]:
                    raise ValueError(f"input_bounds[{name!r}] must be (low, high) with low < high, got {bounds[name]!r}")
                if log[j] and lo_hi[0] <= 0:
                    raise ValueError(f"input_bounds[{name!r}] must be > 0 for a log input, got {bounds[name]!r}")
                g = np.log(lo_hi) if log[j] else lo_hi
                lo, width = float(g[0]), float(g[1] - g[0])
            else:
                lo, width = float(col.min()), float(col.max() - col.min())
            offset.append(lo)
            scale.append(width if width > 0 else 1.0)
        return cls(names=names, log=log, offset=tuple(offset), scale=tuple(scale))

    def transform(self, X: np.ndarray) -> np.ndarray:
        """GP coordinates of the physical inputs `X` (shape (n, d))."""
        return (_forward_log(X, self.log, self.names) - np.asarray(self.offset)) / np.asarray(self.scale)

    def derivative(self, X: np.ndarray) -> np.ndarray:
        """``dt_j/dx_j`` for each point and input (the transform is diagonal)."""
        g_prime = np.where(np.asarray(self.log), 1.0 / X, 1.0)
        return g_prime / np.asarray(self.scale)

    def to_dict(self) -> dict:
        """JSON-able description (floats round-trip exactly through JSON)."""
        return {"names": list(self.names), "log": list(self.log),
                "offset": list(self.offset), "scale": list(self.scale)}

    @classmethod
    def from_dict(cls, spec: Mapping) -> InputTransform:
        """Rebuild from `to_dict` output, checking types and lengths."""
        try:
            names = tuple(str(n) for n in spec["names"])
            log = tuple(bool(v) for v in spec["log"])
            offset = tuple(float(v) for v in spec["offset"])
            scale = tuple(float(v) for v in spec["scale"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"invalid input transform description: {exc}") from None
        if not (len(names) == len(log) == len(offset) == len(scale)):
            raise ValueError("invalid input transform description: lengths differ")
        if not all(np.isfinite(offset)) or not all(np.isfinite(s) and s > 0 for s in scale):
            raise ValueError("invalid input transform description: offset/scale must be finite, scale > 0")
        return cls(names=names, log=log, offset=offset, scale=scale)


def _forward_log(X: np.ndarray, log: Sequence[bool], names: Sequence[str]) -> np.ndarray:
    """Apply the log to the flagged columns of `X`, checking they are > 0."""
    X = np.asarray(X, dtype=float)
    G = X.copy()
    for j, flag in enumerate(log):
        if flag:
            if np.any(X[:, j] <= 0):
                raise ValueError(f"input {names[j]!r} is log-transformed and must be > 0")
            G[:, j] = np.log(X[:, j])
    return G


@dataclass(frozen=True)
class OutputTransform:
    """Map the physical output y to GP coordinates ``z = (h(y) - offset) / scale``.

    ``h`` is the natural log (``kind="log"``, y > 0) or the identity
    (``kind="standardize"``). Predictions are returned in physical units: with
    the log, the mean is ``exp(m)`` (the median of the log-normal predictive
    distribution) and the standard deviation is propagated with the Jacobian,
    ``std_y = exp(m) * std_m`` (first-order delta method); intervals map their
    end points exactly, as the transform is monotone.
    """

    kind: str
    offset: float
    scale: float

    @classmethod
    def fit(cls, y: np.ndarray, kind: str = "standardize") -> OutputTransform:
        """Learn offset (mean) and scale (standard deviation) of ``h(y)``."""
        if kind not in OUTPUT_TRANSFORMS:
            raise ValueError(f"output_transform must be one of {', '.join(OUTPUT_TRANSFORMS)}; got {kind!r}")
        h = cls._h(kind, y)
        std = float(h.std())
        return cls(kind=kind, offset=float(h.mean()), scale=std if std > 0 else 1.0)

    @staticmethod
    def _h(kind: str, y: np.ndarray) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        if kind == "log":
            if np.any(y <= 0):
                raise ValueError("output_transform='log' needs an output > 0")
            return np.log(y)
        return y

    def transform(self, y: np.ndarray) -> np.ndarray:
        """GP coordinates of the physical outputs `y`."""
        return (self._h(self.kind, y) - self.offset) / self.scale

    def inverse(self, z: np.ndarray) -> np.ndarray:
        """Physical output of the GP coordinate `z` (exact, monotone)."""
        h = np.asarray(z, dtype=float) * self.scale + self.offset
        return np.exp(h) if self.kind == "log" else h

    def derivative(self, z: np.ndarray) -> np.ndarray:
        """``dy/dz`` at the GP coordinate `z` (the Jacobian used for the std)."""
        if self.kind == "log":
            return self.scale * self.inverse(z)
        return np.full_like(np.asarray(z, dtype=float), self.scale)

    def to_dict(self) -> dict:
        """JSON-able description."""
        return {"kind": self.kind, "offset": self.offset, "scale": self.scale}

    @classmethod
    def from_dict(cls, spec: Mapping) -> OutputTransform:
        """Rebuild from `to_dict` output, checking types."""
        try:
            kind, offset, scale = str(spec["kind"]), float(spec["offset"]), float(spec["scale"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"invalid output transform description: {exc}") from None
        if kind not in OUTPUT_TRANSFORMS or not np.isfinite(offset) or not (np.isfinite(scale) and scale > 0):
            raise ValueError("invalid output transform description")
        return cls(kind=kind, offset=offset, scale=scale)
