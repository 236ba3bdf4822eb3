"""Quality metrics of a design in the unit cube.

All functions take a sample of shape ``(n, d)`` in the unit cube. Distances are
Euclidean; the space-filling criterion is that of Morris & Mitchell (1995),
"Exploratory designs for computational experiments", J. Stat. Plan. Inference
43, 381-402: ``phi_p = (sum_{i<j} d_ij^-p)^(1/p)``, which for large ``p``
(here 50) ranks designs like the minimum distance but also counts how many
pairs sit at it.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np
from scipy.spatial.distance import pdist
from scipy.stats import qmc

__all__ = ["min_distance", "phi_p", "centered_l2", "max_abs_correlation", "is_latin",
           "DesignQuality", "design_quality"]

P_DEFAULT = 50.0


def _as_sample(sample: np.ndarray, min_points: int = 2) -> np.ndarray:
    sample = np.asarray(sample, dtype=float)
    if sample.ndim != 2 or sample.shape[1] < 1:
        raise ValueError(f"sample must be an array of shape (n, d), got shape {sample.shape}")
    if sample.shape[0] < min_points:
        raise ValueError(f"sample needs at least {min_points} points, got {sample.shape[0]}")
    if not np.all(np.isfinite(sample)):
        raise ValueError("sample must hold finite values")
    return sample


def min_distance(sample: np.ndarray) -> float:
    """Smallest Euclidean distance between two points of the sample.

    Parameters
    ----------
    sample : array_like, shape (n, d)
        At least two points.

    Returns
    -------
    float
    """
    return float(pdist(_as_sample(sample)).min())


def phi_p(sample: np.ndarray, p: float = P_DEFAULT) -> float:
    """Morris-Mitchell criterion ``(sum_{i<j} d_ij^-p)^(1/p)``; smaller is better.

    Evaluated as ``(1 / d_min) (sum (d_min / d_ij)^p)^(1/p)`` so that large
    ``p`` does not overflow; a repeated point gives ``inf``.

    Parameters
    ----------
    sample : array_like, shape (n, d)
        At least two points.
    p : float
        Positive exponent (default 50).

    Returns
    -------
    float
    """
    if not p > 0:
        raise ValueError(f"p must be > 0, got {p!r}")
    dist = pdist(_as_sample(sample))
    d_min = dist.min()
    if d_min == 0.0:
        return float("inf")
    return float(np.sum((d_min / dist) ** p) ** (1.0 / p) / d_min)


def centered_l2(sample: np.ndarray) -> float:
    """Centred L2 discrepancy of Hickernell (1998), as `scipy.stats.qmc.discrepancy`
    returns it with ``method='CD'`` (the squared discrepancy); smaller is better.

    Parameters
    ----------
    sample : array_like, shape (n, d)
        Points in ``[0, 1]^d``.

    Returns
    -------
    float
    """
    sample = _as_sample(sample, min_points=1)
    if sample.min() < 0.0 or sample.max() > 1.0:
        raise ValueError("sample must lie in the unit cube [0, 1]^d")
    return float(qmc.discrepancy(sample, method="CD"))


def max_abs_correlation(sample: np.ndarray) -> float:
    """Largest absolute Pearson correlation between two columns (0 for ``d = 1``).

    A constant column has no correlation with any other and counts as 0.
    """
    sample = _as_sample(sample)
    if sample.shape[1] == 1:
        return 0.0
    centred = sample - sample.mean(axis=0)
    norms = np.sqrt((centred ** 2).sum(axis=0))
    norms[norms == 0.0] = np.inf
    corr = (centred.T @ centred) / np.outer(norms, norms)
    np.fill_diagonal(corr, 0.0)
    return float(np.abs(corr).max())


def is_latin(sample: np.ndarray) -> bool:
    """True if every column puts exactly one point in each of the ``n`` cells
    ``[k/n, (k+1)/n)`` of ``[0, 1)`` (the Latin hypercube property)."""
    sample = _as_sample(sample, min_points=1)
    n = sample.shape[0]
    if sample.min() < 0.0 or sample.max() >= 1.0:
        return False
    cells = np.floor(sample * n).astype(int)
    return bool(np.all(np.sort(cells, axis=0) == np.arange(n)[:, None]))


@dataclass(frozen=True)
class DesignQuality:
    """Quality of a design in the unit cube (see the functions of the same names)."""

    min_distance: float
    phi_p: float
    centered_l2: float
    max_abs_correlation: float
    latin: bool

    def as_dict(self) -> dict[str, float | bool]:
        """The metrics as a plain dictionary."""
        return asdict(self)


def design_quality(sample: np.ndarray, p: float = P_DEFAULT) -> DesignQuality:
    """All quality metrics of a unit-cube sample.

    Parameters
    ----------
    sample : array_like, shape (n, d)
        At least two points in the unit cube.
    p : float
        Exponent of `phi_p` (default 50).

    Returns
    -------
    DesignQuality
    """
    sample = _as_sample(sample)
    return DesignQuality(min_distance=min_distance(sample), phi_p=phi_p(sample, p),
                         centered_l2=centered_l2(sample),
                         max_abs_correlation=max_abs_correlation(sample),
                         latin=is_latin(sample))
