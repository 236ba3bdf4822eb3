"""Experimental data of the calibration: measured imprint radii, and Table 1 of the reference paper.

The paper ("Calibration of a finite element model of Prescale film for
wheel-rail normal contact area measurements", 2021) pressed steel spheres of
radius R = 300, 450 and 600 mm on a steel flat with F = 25, 50, 75 and 100 kN
(R300 only up to 50 kN) and measured the radius of the contact patch printed on
MS, HS and HHS Prescale film. Its Table 1 gives the error of that radius with
respect to Hertz's solution; the measured radius is the Hertz radius plus the
error. The table ships with the package as the dataset ``table1``
(``filmcal/data/table1_radius_errors.csv``), read by
`filmcal.calibration.datasets.load_dataset`, which reads a lab's own CSV files
of the same form too.

Units: mm, N, MPa; forces are given in kN only where the user selects a load
range (``loads="50-100"``), as in the paper and the command line.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from filmcal._validation import FORCE_RANGE
from filmcal.films import FILM_TYPES
from filmcal.hertz import STEEL_MODULUS_MPA, STEEL_POISSON, hertz_radius_mm

__all__ = [
    "FILM_TYPES",
    "STEEL_MODULUS_MPA",
    "STEEL_POISSON",
    "RadiusErrorData",
    "parse_load_range",
]

_LOAD_RANGE = FORCE_RANGE


@dataclass(frozen=True)
class RadiusErrorData:
    """Measured imprint radii of sphere-on-flat tests, one row per imprint.

    The required fields are those of Table 1; the optional ones describe a
    lab's own tests (`filmcal.calibration.datasets`) and default to Table 1's
    conditions: no stated measurement uncertainty, one imprint per case,
    steel bodies, roughness not stated.

    Attributes
    ----------
    film : ndarray of str
        Film type of each row (any film name, e.g. ``"HS"`` or ``"LOT7"``).
    sphere_radius_mm : ndarray
        Radius R of the sphere (mm).
    force_n : ndarray
        Normal force F (N).
    radius_error_mm : ndarray
        Measured contact-patch radius minus the Hertz radius (mm).
    hertz_radius_mm : ndarray
        Hertz contact radius of the row's sphere on its flat (mm).
    measured_radius_mm : ndarray
        Radius printed on the film, ``hertz_radius_mm + radius_error_mm`` (mm).
    measurement_std_mm : ndarray, optional
        Stated standard uncertainty of each measured radius (mm, >= 0;
        default 0). It enters the likelihood as its own variance.
    repeat : ndarray of int, optional
        Number of the imprint within its case (default 1, 2, ... in row order).
    flat_ra_um : ndarray, optional
        Roughness Ra of the flat (um); NaN where not stated.
    sphere_modulus_mpa, sphere_poisson, flat_modulus_mpa, flat_poisson : ndarray, optional
        Elastic constants of the bodies (default the steel of the experiments).
    """

    film: np.ndarray
    sphere_radius_mm: np.ndarray
    force_n: np.ndarray
    radius_error_mm: np.ndarray
    hertz_radius_mm: np.ndarray
    measured_radius_mm: np.ndarray
    measurement_std_mm: np.ndarray | None = None
    repeat: np.ndarray | None = None
    flat_ra_um: np.ndarray | None = None
    sphere_modulus_mpa: np.ndarray | None = None
    sphere_poisson: np.ndarray | None = None
    flat_modulus_mpa: np.ndarray | None = None
    flat_poisson: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.asarray(self.film).size
        object.__setattr__(self, "film", np.asarray(self.film).astype(str).reshape(n))
        for name in ("sphere_radius_mm", "force_n", "radius_error_mm", "hertz_radius_mm", "measured_radius_mm"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (n,):
                raise ValueError(f"{name} must have shape ({n},) like film, got {value.shape}")
            object.__setattr__(self, name, value)
        defaults = {"measurement_std_mm": 0.0, "flat_ra_um": np.nan, "sphere_modulus_mpa": STEEL_MODULUS_MPA,
                    "sphere_poisson": STEEL_POISSON, "flat_modulus_mpa": STEEL_MODULUS_MPA,
                    "flat_poisson": STEEL_POISSON}
        for name, default in defaults.items():
            value = getattr(self, name)
            value = np.full(n, default) if value is None else np.asarray(value, dtype=float)
            if value.shape != (n,):
                raise ValueError(f"{name} must have shape ({n},) like film, got {value.shape}")
            object.__setattr__(self, name, value)
        if np.any(~np.isfinite(self.measurement_std_mm) | (self.measurement_std_mm < 0)):
            raise ValueError("measurement_std_mm must be finite and >= 0")
        cases = _case_index(self)
        if self.repeat is None:
            repeat = np.zeros(n, dtype=int)
            seen: dict[int, int] = {}
            for i, c in enumerate(cases):
                seen[c] = seen.get(c, 0) + 1
                repeat[i] = seen[c]
        else:
            repeat = np.asarray(self.repeat).astype(int)
            if repeat.shape != (n,):
                raise ValueError(f"repeat must have shape ({n},) like film, got {repeat.shape}")
        object.__setattr__(self, "repeat", repeat)
        object.__setattr__(self, "_case", cases)

    def __len__(self) -> int:
        return int(self.film.size)

    @property
    def force_kn(self) -> np.ndarray:
        """Normal force in kN, the unit of the paper's table."""
        return self.force_n / 1000.0

    @property
    def case_index(self) -> np.ndarray:
        """Case of each row, numbered 0, 1, ... in order of first appearance.

        A case is one test condition: film, R, F, body materials and flat
        roughness. Rows of the same case are repeats of one imprint.
        """
        return self._case  # type: ignore[attr-defined]

    @property
    def n_cases(self) -> int:
        """Number of distinct cases."""
        return int(self.case_index.max()) + 1 if len(self) else 0

    @property
    def has_repeats(self) -> bool:
        """Whether some case holds more than one imprint."""
        return len(self) > self.n_cases

    @property
    def steel_hertz_radius_mm(self) -> np.ndarray:
        """Hertz radius of the row's R and F between the steel bodies of the experiments (mm)."""
        return hertz_radius_mm(self.sphere_radius_mm, self.force_n)

    @property
    def target_radius_mm(self) -> np.ndarray:
        """The radius a radius model of steel bodies is compared with (mm).

        The measured radius error added to the steel Hertz radius: equal to
        the measured radius for steel bodies. For other bodies this carries
        the film's enlargement measured there over to steel bodies (the film
        error is assumed not to depend on the bodies' elastic constants, a
        first-order approximation when they are much stiffer than the film).
        """
        return self.steel_hertz_radius_mm + self.radius_error_mm

    def select(self, mask: np.ndarray) -> RadiusErrorData:
        """Return the rows where the boolean `mask` is true."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.film.shape:
            raise ValueError(f"mask must have shape {self.film.shape}, got {mask.shape}")
        return RadiusErrorData(**{name: getattr(self, name)[mask] for name in _FIELDS})


_FIELDS = ("film", "sphere_radius_mm", "force_n", "radius_error_mm", "hertz_radius_mm", "measured_radius_mm",
           "measurement_std_mm", "repeat", "flat_ra_um", "sphere_modulus_mpa", "sphere_poisson",
           "flat_modulus_mpa", "flat_poisson")
_CASE_FIELDS = ("film", "sphere_radius_mm", "force_n", "flat_ra_um", "sphere_modulus_mpa", "sphere_poisson",
                "flat_modulus_mpa", "flat_poisson")


def _case_index(data: RadiusErrorData) -> np.ndarray:
    """Number the distinct test conditions in order of first appearance (NaN roughness equals NaN)."""
    keys: dict[tuple, int] = {}
    out = np.empty(len(data.film), dtype=int)
    columns = [getattr(data, name) for name in _CASE_FIELDS]
    for i in range(out.size):
        key = tuple("nan" if isinstance(c[i], float) and math.isnan(c[i]) else c[i].item() if hasattr(c[i], "item")
                    else c[i] for c in columns)
        out[i] = keys.setdefault(key, len(keys))
    return out


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
