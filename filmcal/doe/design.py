"""Designs in a named design space: build, augment, read and write as CSV.

A design file is plain CSV: a header with the parameter names, then one row
per point, numbers written so that they read back exactly.
"""
from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from os import PathLike

import numpy as np

from filmcal._io import atomic_open
from filmcal.doe.lhs import N_OUTER_DEFAULT, OptimalLatinHypercube, SeedLike, _check_count
from filmcal.doe.metrics import DesignQuality, design_quality
from filmcal.doe.space import DesignSpace

__all__ = ["Design", "latin_design", "augment_design", "read_design_csv", "write_design_csv"]


@dataclass(frozen=True)
class Design:
    """A design in physical values with its quality.

    Attributes
    ----------
    space : DesignSpace
        The parameters, one column each.
    points : ndarray, shape (n, len(space.names))
        Physical values.
    unit : ndarray, shape (n, space.d)
        Unit-cube coordinates of `points` as realised: a discrete value sits
        at the centre of its level's bin, so with discrete parameters the
        design is in general no longer Latin.
    quality : DesignQuality
        Metrics of `unit`.
    elapsed_s : float
        Wall time spent building the design.
    """

    space: DesignSpace
    points: np.ndarray
    unit: np.ndarray
    quality: DesignQuality
    elapsed_s: float


def _realise(space: DesignSpace, unit: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Physical points of unit-cube points, and their unit coordinates as realised."""
    points = space.to_physical(unit)
    return points, space.to_unit(points)


def _engine(space: DesignSpace, n_outer: int, seed: SeedLike) -> OptimalLatinHypercube:
    """The sampler for `space`, aware of its discrete parameters."""
    n_levels = [len(p.levels) if p.is_discrete else None for p in space.free]
    return OptimalLatinHypercube(space.d, n_outer=n_outer, n_levels=n_levels, seed=seed)


def latin_design(space: DesignSpace, samples: int, *, seed: SeedLike = None,
                 n_outer: int = N_OUTER_DEFAULT) -> Design:
    """Optimal Latin hypercube design of `samples` points in `space`.

    Discrete parameters are optimised as realised (see the `n_levels` option
    of `OptimalLatinHypercube`); their columns are not Latin.

    Parameters
    ----------
    space : DesignSpace
        Parameters of the design.
    samples : int
        Number of points, at least 2.
    seed : int or numpy.random.Generator, optional
        Seed; the same seed gives the same design.
    n_outer : int
        Outer iterations of the optimiser (see `OptimalLatinHypercube`).

    Returns
    -------
    Design
    """
    samples = _check_count("samples", samples, 2)
    started = time.perf_counter()
    points, unit = _realise(space, _engine(space, n_outer, seed).random(samples))
    elapsed = time.perf_counter() - started
    return Design(space=space, points=points, unit=unit, quality=design_quality(unit),
                  elapsed_s=elapsed)


def augment_design(space: DesignSpace, existing: np.ndarray, samples: int, *,
                   seed: SeedLike = None, n_outer: int = N_OUTER_DEFAULT) -> Design:
    """Add `samples` space-filling points to an existing design.

    The existing points come first and unchanged; see
    `OptimalLatinHypercube.augment` for how the new points are placed and
    what is guaranteed.

    Parameters
    ----------
    space : DesignSpace
        Parameters of the design.
    existing : array_like, shape (n, len(space.names))
        Existing points in physical values, columns in the order of `space`.
    samples : int
        Number of points to add, at least 1.
    seed : int or numpy.random.Generator, optional
        Seed; the same seed gives the same design.
    n_outer : int
        Outer iterations of the optimiser.

    Returns
    -------
    Design
    """
    samples = _check_count("samples", samples, 1)
    started = time.perf_counter()
    old_unit = space.to_unit(existing)
    new_unit = _engine(space, n_outer, seed).augment(old_unit, samples)[len(old_unit):]
    new_points, new_unit = _realise(space, new_unit)
    points = np.vstack([np.asarray(existing, dtype=float), new_points])
    unit = np.vstack([old_unit, new_unit])
    elapsed = time.perf_counter() - started
    return Design(space=space, points=points, unit=unit, quality=design_quality(unit),
                  elapsed_s=elapsed)


def write_design_csv(path: str | PathLike, names: tuple[str, ...] | list[str],
                     points: np.ndarray) -> None:
    """Write a design as CSV: a header of `names`, one row per point (whole or not at all)."""
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != len(names):
        raise ValueError(f"points must have shape (n, {len(names)}), got {points.shape}")
    with atomic_open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(names)
        writer.writerows([[repr(float(v)) for v in row] for row in points])


def read_design_csv(path: str | PathLike) -> tuple[tuple[str, ...], np.ndarray]:
    """Read a design CSV written by `write_design_csv` (or by hand).

    Returns
    -------
    names : tuple of str
        The header.
    points : ndarray, shape (n, len(names))

    Raises
    ------
    ValueError
        For an empty file, a row of the wrong length or a value that is not a
        finite number.
    """
    # utf-8-sig: a spreadsheet's byte-order mark is not part of the first column's name
    with open(path, newline="", encoding="utf-8-sig") as handle:
        rows = [row for row in csv.reader(handle) if row]
    if not rows:
        raise ValueError(f"design file {path} is empty")
    if len(rows) == 1:
        raise ValueError(f"design file {path} has a header and no points")
    names = tuple(name.strip() for name in rows[0])
    values = []
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(names):
            raise ValueError(f"design file {path}, line {line}: expected {len(names)} values, "
                             f"got {len(row)}")
        try:
            values.append([float(v) for v in row])
        except ValueError:
            raise ValueError(f"design file {path}, line {line}: not a number in {row}") from None
    points = np.array(values, dtype=float).reshape(len(values), len(names))
    if not np.all(np.isfinite(points)):
        raise ValueError(f"design file {path} holds values that are not finite")
    return names, points
