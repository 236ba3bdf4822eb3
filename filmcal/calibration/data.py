"""Experimental data of the calibration: Table 1 of the reference paper.

The paper ("Calibration of a finite element model of Prescale film for
wheel-rail normal contact area measurements", 2021) pressed steel spheres of
radius R = 300, 450 and 600 mm on a steel flat with F = 25, 50, 75 and 100 kN
(R300 only up to 50 kN) and measured the radius of the contact patch printed on
MS, HS and HHS Prescale film. Its Table 1 gives the error of that radius with
respect to Hertz's solution; the measured radius is the Hertz radius plus the
error. The table ships with the package as
``filmcal/data/table1_radius_errors.csv`` and is read with `importlib.resources`.

Units: mm, N, MPa; forces are given in kN only where the user selects a load
range (``loads="50-100"``), as in the paper and the command line.
"""
from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass
from importlib import resources

import numpy as np

from filmcal.films import FILM_TYPES
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm

__all__ = [
    "FILM_TYPES",
    "STEEL_MODULUS_MPA",
    "STEEL_POISSON",
    "RadiusErrorData",
    "load_table1",
    "parse_load_range",
]



_TABLE1_RESOURCE = "data/table1_radius_errors.csv"
_LOAD_RANGE = re.compile(r"^\s*(\d+(?:\.\d*)?)\s*(?:-\s*(\d+(?:\.\d*)?)\s*)?$")


@dataclass(frozen=True)
class RadiusErrorData:
    """Sphere-on-flat radius errors measured with Prescale film (Table 1 rows).

    Attributes
    ----------
    film : ndarray of str
        Film type of each row (``"MS"``, ``"HS"`` or ``"HHS"``).
    sphere_radius_mm : ndarray
        Radius R of the steel sphere (mm).
    force_n : ndarray
        Normal force F (N).
    radius_error_mm : ndarray
        Measured contact-patch radius minus the Hertz radius (mm).
    hertz_radius_mm : ndarray
        Hertz contact radius of the steel sphere on the steel flat (mm).
    measured_radius_mm : ndarray
        Radius printed on the film, ``hertz_radius_mm + radius_error_mm`` (mm).
    """

    film: np.ndarray
    sphere_radius_mm: np.ndarray
    force_n: np.ndarray
    radius_error_mm: np.ndarray
    hertz_radius_mm: np.ndarray
    measured_radius_mm: np.ndarray

    def __len__(self) -> int:
        return int(self.film.size)

    @property
    def force_kn(self) -> np.ndarray:
        """Normal force in kN, the unit of the paper's table."""
        return self.force_n / 1000.0

    def select(self, mask: np.ndarray) -> RadiusErrorData:
        """Return the rows where the boolean `mask` is true."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.film.shape:
            raise ValueError(f"mask must have shape {self.film.shape}, got {mask.shape}")
        return RadiusErrorData(**{name: getattr(self, name)[mask] for name in _FIELDS})


_FIELDS = ("film", "sphere_radius_mm", "force_n", "radius_error_mm",
           "hertz_radius_mm", "measured_radius_mm")


def parse_load_range(loads: str | tuple[float, float]) -> tuple[float, float]:
    """Parse a load range in kN, inclusive at both ends.

    Parameters
    ----------
    loads : str or (float, float)
        ``"50-100"`` (from 50 to 100 kN), ``"75"`` (exactly 75 kN) or a pair
        ``(low_kn, high_kn)``.

    Returns
    -------
    (low_kn, high_kn) : tuple of float

    Raises
    ------
    ValueError
        If the text is not of the form ``LOW-HIGH`` or ``VALUE`` with
        non-negative numbers, or if ``LOW > HIGH``.
    """
    if isinstance(loads, str):
        match = _LOAD_RANGE.match(loads)
        if match is None:
            raise ValueError(f"loads must look like '50-100' or '75' (kN), got {loads!r}")
        low = float(match.group(1))
        high = float(match.group(2)) if match.group(2) is not None else low
    else:
        try:
            low, high = (float(v) for v in loads)
        except (TypeError, ValueError):
            raise ValueError(f"loads must be 'LOW-HIGH' in kN or a pair (low, high), got {loads!r}") from None
        if not (np.isfinite(low) and np.isfinite(high)) or low < 0:
            raise ValueError(f"loads must be finite and >= 0 kN, got {loads!r}")
    if low > high:
        raise ValueError(f"loads must have low <= high, got {low:g}-{high:g} kN")
    return low, high


def _read_table1_rows() -> list[dict[str, str]]:
    """Rows of the packaged Table 1 CSV (comment lines starting with '#' skipped)."""
    text = resources.files("filmcal").joinpath(_TABLE1_RESOURCE).read_text(encoding="utf-8")
    lines = [line for line in io.StringIO(text) if not line.lstrip().startswith("#") and line.strip()]
    return list(csv.DictReader(lines))


def load_table1(film: str | None = None, loads: str | tuple[float, float] | None = None) -> RadiusErrorData:
    """Load Table 1 of the reference paper, optionally filtered.

    Parameters
    ----------
    film : str, optional
        Film type, one of ``MS``, ``HS``, ``HHS`` (case-insensitive). All films
        when omitted.
    loads : str or (float, float), optional
        Load range in kN, inclusive, e.g. ``"50-100"``; see `parse_load_range`.
        All loads when omitted.

    Returns
    -------
    RadiusErrorData
        The selected rows with the Hertz and measured radii of each.

    Raises
    ------
    ValueError
        For an unknown film type (the message lists the known ones) or a load
        range that cannot be parsed.
    """
    rows = _read_table1_rows()
    films = np.array([row["film"].strip().upper() for row in rows])
    sphere_radius_mm = np.array([float(row["sphere_radius_mm"]) for row in rows])
    force_n = np.array([float(row["force_kn"]) for row in rows]) * 1000.0
    error_mm = np.array([float(row["radius_error_mm"]) for row in rows])
    hertz_mm = hertz_radius_mm(sphere_radius_mm, force_n)
    data = RadiusErrorData(
        film=films,
        sphere_radius_mm=sphere_radius_mm,
        force_n=force_n,
        radius_error_mm=error_mm,
        hertz_radius_mm=hertz_mm,
        measured_radius_mm=hertz_mm + error_mm,
    )
    mask = np.ones(len(data), dtype=bool)
    if film is not None:
        key = str(film).strip().upper()
        if key not in FILM_TYPES:
            raise ValueError(f"film must be one of {', '.join(FILM_TYPES)} (case-insensitive); got {film!r}")
        mask &= data.film == key
    if loads is not None:
        low_kn, high_kn = parse_load_range(loads)
        mask &= (data.force_kn >= low_kn) & (data.force_kn <= high_kn)
    return data.select(mask)
