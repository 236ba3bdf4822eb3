"""The transfer term: how far the applied film's imprint lies from the calibrated film's.

The calibration runs the axisymmetric continuum FE film (`filmcal.fem`); every
wheel-rail answer runs the half-space solver with the film as springs ``t/M``
in series (`filmcal.contact.laws`). The springs have no lateral coupling: near
the edge of the contact the continuum film is pulled down by its loaded
neighbours and is less confined, so its edge lies inside the springs' edge
(about 0.03 mm for a 90 um film), and each imprint model reads a contour that
differs accordingly. A pointwise law cannot reproduce a non-local effect, so
the difference is measured and carried instead:

    d = r_FE - r_application

(radius on sphere-on-flat, both models at equal film parameters, each read by
the same imprint model), fitted in the film's own dimensionless groups

    d / t = b . [1, nu, nu^2, x, x^2, nu x, y, nu y, y^2, c, c x, c y],
    x = ln(l / a),  l = E* t / M,  y = ln(p_level / p_max),  c = ln(1 - 2 nu)

(t the film thickness, M its oedometric modulus, E* the steel pair's contact
modulus, a the application's equivalent radius of the recorded imprint,
p_max its peak pressure, p_level the film's activation pressure; the edge
model has no y). c is the film's compressibility: the continuum film's edge
zone scales with 1 - 2 nu (`filmcal.contact.reading.film_tip_length_mm`),
and without it soft films near incompressibility (E 450 MPa, nu 0.44) were
missed by 3-4 held-out standard deviations. The fit lives in ``filmcal/data/film_transfer.json``, written
by ``scripts/fit-transfer`` (`filmcal.correction.transfer`) with the design,
the held-out check and the versions that made it.

On a wheel-rail patch the same edge offset is applied along the recorded
outline: the area shifts by ``d * P`` with P the outline's perimeter, and the
fit's held-out root-mean-square residual becomes the term's standard
deviation. `FilmModel.transfer_term` is the one place that evaluates it
(docs/film-law.md).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

__all__ = ["TransferTerm", "TransferFit", "transfer_features", "load_transfer_fit", "TRANSFER_FILE",
           "outline_perimeter_mm"]

#: The shipped fit (package data).
TRANSFER_FILE = "film_transfer.json"
#: Names of the fitted features (the order of the coefficients).
FEATURES = ("1", "nu", "nu^2", "x", "x^2", "nu x", "y", "nu y", "y^2", "c", "c x", "c y")


@dataclass(frozen=True)
class TransferTerm:
    """The transfer term of one recorded area.

    Attributes
    ----------
    shift_mm, std_mm : float
        Edge offset (calibrated minus applied, along the outward normal) and its standard deviation.
    shift_mm2, std_mm2 : float
        The same as an area: times the recorded outline's perimeter.
    """

    shift_mm: float
    std_mm: float
    shift_mm2: float
    std_mm2: float


def transfer_features(imprint: str, modulus_mpa, poisson, thickness_mm, radius_mm, max_pressure_mpa,
                      level_mpa=None) -> np.ndarray:
    """The fit's features (`FEATURES`), one row per case (broadcast).

    Parameters
    ----------
    imprint : str
        Imprint model; ``edge`` has no pressure-level feature (its ``y`` is 0).
    modulus_mpa, poisson, thickness_mm : array_like
        The film.
    radius_mm : array_like
        Equivalent radius of the recorded imprint in the application (mm).
    max_pressure_mpa : array_like
        Peak contact pressure in the application (MPa).
    level_mpa : array_like, optional
        The film's activation pressure (MPa); needed unless ``imprint == "edge"``.
    """
    from filmcal.elastic import oedometric_ratio
    from filmcal.hertz import contact_modulus_mpa

    e, nu, t, a, pmax = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in
                                              (modulus_mpa, poisson, thickness_mm, radius_mm, max_pressure_mpa)))
    x = np.log(contact_modulus_mpa() * t / (e * oedometric_ratio(nu)) / a)
    if imprint == "edge":
        y = np.zeros_like(x)
    else:
        if level_mpa is None:
            raise ValueError(f"the {imprint} model's transfer needs the film's activation pressure")
        y = np.log(np.asarray(level_mpa, dtype=float) / pmax)
    c = np.log1p(-2.0 * nu)
    return np.stack([np.ones_like(x), nu, nu * nu, x, x * x, nu * x, y, nu * y, y * y, c, c * x, c * y], axis=-1)


def outline_perimeter_mm(rings, smoothing: int = 5) -> float:
    """Total length of an outline's rings (mm).

    A contoured outline zigzags about the true curve by a fraction of a cell,
    which lengthens it by 1-3 %; each ring's vertices are averaged over
    `smoothing` neighbours first (on Hertz circles of 30-70 cells' radius the
    length is then within 0.15 % of 2 pi a).
    """
    total = 0.0
    for ring in rings:
        v = np.asarray(ring, dtype=float)
        if len(v) > 1 and np.allclose(v[0], v[-1]):
            v = v[:-1]
        k = int(smoothing)
        if k > 1 and len(v) >= 2 * k:
            padded = np.concatenate([v[-(k // 2):], v, v[:k - 1 - k // 2]])
            v = np.column_stack([np.convolve(padded[:, j], np.ones(k) / k, "valid") for j in (0, 1)])
        if len(v) > 1:
            total += float(np.linalg.norm(np.diff(np.vstack([v, v[:1]]), axis=0), axis=1).sum())
    return total


@dataclass(frozen=True)
class TransferFit:
    """The fitted transfer of every (imprint model, kinematics).

    Attributes
    ----------
    coefficients : dict
        ``"<imprint>/<kinematics>"`` -> coefficients over `FEATURES` (of d / t).
    std_mm : dict
        The same keys -> the held-out root-mean-square residual (mm): the term's standard deviation.
    domain : dict
        The (E, nu, R, F) ranges that were sampled.
    grid_mm : float
        The application's grid the fit was measured on.
    provenance : dict
        How it was made (design, sizes, held-out figures, versions, date).
    """

    coefficients: dict
    std_mm: dict
    domain: dict
    grid_mm: float
    provenance: dict

    @classmethod
    def from_json(cls, path: str | Path) -> "TransferFit":
        """Read a fit written by `to_json` (plain JSON, no code)."""
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        try:
            coef = {k: [float(c) for c in v] for k, v in data["coefficients"].items()}
            std = {k: float(v) for k, v in data["std_mm"].items()}
            domain = {k: tuple(float(x) for x in v) for k, v in data["domain"].items()}
            out = cls(coef, std, domain, float(data["grid_mm"]), dict(data.get("provenance", {})))
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: not a film-transfer fit ({exc})") from None
        if data.get("features") != list(FEATURES) or any(len(c) != len(FEATURES) for c in coef.values()) \
                or set(coef) != set(std):
            raise ValueError(f"{path}: the fit's features or keys do not match this version of filmcal")
        return out

    def to_json(self, path: str | Path) -> None:
        from filmcal._io import atomic_path

        doc = {"features": list(FEATURES), "coefficients": self.coefficients, "std_mm": self.std_mm,
               "domain": self.domain, "grid_mm": self.grid_mm, "provenance": self.provenance}
        with atomic_path(Path(path)) as tmp:
            Path(tmp).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")

    def shift_mm(self, imprint: str, kinematics: str, features: np.ndarray) -> tuple[np.ndarray, float]:
        """The fitted d / t for rows of `transfer_features`, and the term's standard deviation (mm)."""
        key = f"{imprint}/{kinematics}"
        if key not in self.coefficients:
            raise KeyError(f"no transfer fit for {key} (have {', '.join(sorted(self.coefficients))})")
        return np.asarray(features) @ np.asarray(self.coefficients[key]), self.std_mm[key]


@lru_cache(maxsize=None)
def load_transfer_fit() -> TransferFit:
    """The shipped fit (`TRANSFER_FILE` in `filmcal.data`)."""
    with resources.as_file(resources.files("filmcal.data") / TRANSFER_FILE) as path:
        return TransferFit.from_json(path)


def transfer_term(fit: TransferFit, imprint: str, kinematics: str, film, modulus_mpa: float,
                  recorded_area_mm2: float, max_pressure_mpa: float, perimeter_mm: float | None = None) -> TransferTerm:
    """Evaluate the transfer of one recorded area (see the module docstring).

    Parameters
    ----------
    fit : TransferFit
    imprint, kinematics : str
    film : FilmType
        Thickness, nu and activation pressure of the film.
    modulus_mpa : float
    recorded_area_mm2 : float
        The application's reading of the imprint model.
    max_pressure_mpa : float
        Peak pressure of the solved contact.
    perimeter_mm : float, optional
        Length of the recorded outline; a circle of the recorded area when not given.
    """
    area = float(recorded_area_mm2)
    if not (area > 0.0 and max_pressure_mpa > 0.0):  # nothing recorded (e.g. below the activation pressure)
        return TransferTerm(shift_mm=0.0, std_mm=0.0, shift_mm2=0.0, std_mm2=0.0)
    radius = math.sqrt(area / math.pi)
    level = getattr(film, "activation_pressure_mpa", None)
    features = transfer_features(imprint, modulus_mpa, film.poisson, film.thickness_mm, radius, max_pressure_mpa,
                                 level)
    ratio, std = fit.shift_mm(imprint, kinematics, features)
    shift = float(ratio) * film.thickness_mm
    perimeter = 2.0 * math.pi * radius if perimeter_mm is None else float(perimeter_mm)
    return TransferTerm(shift_mm=shift, std_mm=std, shift_mm2=shift * perimeter, std_mm2=std * perimeter)
