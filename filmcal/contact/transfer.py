"""The transfer term: how far the applied film's imprint lies from the calibrated film's.

The calibration runs the axisymmetric continuum FE film (`filmcal.fem`); every
wheel-rail answer runs the half-space solver with the film as springs ``t/M``
in series (`filmcal.contact.laws`). The springs have no lateral coupling: near
the edge of the contact the continuum film is pulled down by its loaded
neighbours and is less confined, so its edge lies inside the springs' edge
(by 0.005-0.03 mm for a 90 um film), and each imprint model reads a contour that
differs accordingly. A pointwise law cannot reproduce a non-local effect, so
the difference is measured and carried instead:

    d = r_FE - r_application

(radius on sphere-on-flat, both models at equal film parameters, each read by
the same imprint model), fitted in the film's own dimensionless groups

    d / t = b . [1, nu, nu^2, x, x^2, nu x, y, nu y, y^2, c, c x, c y, z, c z, w, c w, x w, y w],
    x = ln(l / a),  l = E* t / M,  y = ln(p_level / p_max),  c = ln(1 - 2 nu),  z = ln(t / a),
    w = ln(t / h)

(t the film thickness, M its oedometric modulus, E* the steel pair's contact
modulus, a the application's equivalent radius of the recorded imprint,
p_max its peak pressure, p_level the film's activation pressure; the edge
model has no y). c is the film's compressibility: the continuum film's edge
zone scales with 1 - 2 nu (`filmcal.contact.reading.film_tip_length_mm`),
and without it soft films near incompressibility (E 450 MPa, nu 0.44) were
missed by 3-4 held-out standard deviations. z is the film's thickness against
the patch: x mixes it with the film's stiffness, and over spheres of 150-1500 mm
the two vary apart (without z the level readings were missed by up to 0.015 mm
held out beyond Table 1's 250-600 mm). c z is the compressibility against
the film's aspect ratio: a nearly incompressible layer is confined the more,
the thinner it is against the patch; without it stiff, nearly incompressible
films on the smallest patches (E 15700-20000 MPa, nu 0.44-0.45, a 2.2-2.4 mm)
were missed by 0.005-0.007 mm on the edge held out, 0.0040 mm with it.
w is the film against the cell h of both models' grids (the application's
0.1 mm cells, `grid_mm`, and the FE's default 0.1 mm elements): d is the
difference of two discretised readings, and their errors scale with the cell
against the film, not with the patch. Fitted on films of 0.09 mm alone, the
term missed films of 0.05 and 0.15 mm by 0.0011-0.0065 mm rms held out (up to
0.018 mm), several times its band; with films of 0.04-0.25 mm in the design
(`filmcal.correction.transfer.THICKNESS_DOMAIN_MM`) and w with its products
the held-out miss over that range is 0.0007-0.0019 mm rms, largest at its ends
(0.0004-0.0010 mm on the 0.09 mm films); the term's std holds it in each
third of the range (`filmcal.correction.transfer.THICKNESS_PARTS_MM`), and a
film off the built-in films' 0.09 mm whose ninth of the range was missed by
more carries that ninth's rms, raised to its 90 % upper bound from the ten or
so points it holds (`TransferFit.std_for`,
`filmcal.correction.transfer.rms_upper_bound`).

The activation and capsule models read a contour near the film's edge zone,
where the polynomial leaves a smooth residual of a few um that it cannot
follow (held-out max 0.008-0.012 mm). For them a Gaussian process over
(nu, x, y, z, w) (`ResidualGP`, fitted by scikit-learn's
`GaussianProcessRegressor` with an anisotropic squared-exponential kernel and
a white-noise term) carries that residual: its mean is added to the
polynomial's, and far from its training points it returns to the polynomial.
The edge model's residual is already at the application grid's own scatter
(0.0011 mm rms between 0.1 and 0.05 mm cells), so it has none. The fit lives
in ``filmcal/data/film_transfer.json``, written by ``scripts/fit-transfer``
(`filmcal.correction.transfer`) with the design, the held-out check and the
versions that made it.

On a wheel-rail patch the same edge offset is applied along the recorded
outline: the area shifts by ``d * P`` with P the outline's perimeter, and the
fit's held-out root-mean-square residual becomes the term's standard
deviation (`TransferFit.std_for`: per range of thickness, and with what the FE
itself misses on stiff films' level readings, `STIFF_LEVEL_STD_MM`).
`FilmModel.transfer_term` is the one place that evaluates it
(docs/film-law.md).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

__all__ = ["TransferTerm", "TransferFit", "ResidualGP", "transfer_features", "load_transfer_fit", "TRANSFER_FILE",
           "THICKNESS_STD_MM", "STIFF_LEVEL_MODULUS_MPA", "STIFF_LEVEL_STD_MM", "outline_perimeter_mm",
           "thickness_range", "on_film_line"]

#: The shipped fit (package data).
TRANSFER_FILE = "film_transfer.json"
#: What the term adds to its standard deviation (mm, in quadrature, per imprint model) for a film beyond the
#: thicknesses the fit was made on (`TransferFit.std_for`), whose answers also warn that the transfer is
#: extrapolated (`filmcal.correction.transfer.outside_fit`): nothing was measured there, and these are the
#: largest root-mean-square misses of a fit made at 0.09 mm alone, held out at other thicknesses (1 Dec 2026):
#: the edge's at 48 points over 0.04-0.25 mm (the held-out hypercubes of seeds 41 and 43 that `scripts/fit-transfer`
#: now holds out), the activation and capsule readings' at 8 points at 0.05 mm (`bench/verification.py
#: --thickness`): the one measured size of a thickness extrapolation.
THICKNESS_STD_MM = {"edge": 0.0028, "activation": 0.0062, "capsule": 0.0065}
#: Above this Young's modulus (MPa) a level reading's band (activation, capsule) carries `STIFF_LEVEL_STD_MM` more.
#: Up to it the FE's level readings at its default mesh lie within 0.0028 mm of the second FE formulation's
#: converged ones (36 readings of six films, E 600-6000 MPa, nu 0.25-0.42; `bench/verification.py`).
STIFF_LEVEL_MODULUS_MPA = 6000.0
#: What a level reading's band adds in quadrature (mm) on a film stiffer than `STIFF_LEVEL_MODULUS_MPA`: the
#: root-mean-square miss of the FE's level readings against the second formulation's there (24 readings of four
#: films, E 8000-20000 MPa, nu 0.30-0.45; mean -0.0014 mm, HHS's levels -0.0047 mm, the largest 0.0068 mm). On
#: such films the edge shape the FE reads its levels from (`filmcal.contact.reading`) no longer holds over the
#: last two elements; the transfer term maps the application onto the FE and cannot know it (docs/verification.md).
STIFF_LEVEL_STD_MM = 0.0031
#: The revision of how `TransferFit.std_for` makes a film's band from the fit's numbers (part of `digest`): raise it
#: whenever that rule changes, so that solves cached under the old rule are made again.
BAND_RULE_REVISION = 3
#: Names of the fitted features (the order of the coefficients).
FEATURES = ("1", "nu", "nu^2", "x", "x^2", "nu x", "y", "nu y", "y^2", "c", "c x", "c y", "z", "c z",
            "w", "c w", "x w", "y w")


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
                      level_mpa=None, *, grid_mm: float) -> np.ndarray:
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
    grid_mm : float
        The cell of the grids the fit was measured on (`TransferFit.grid_mm`).
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
    z = np.log(t / a)
    w = np.log(t / float(grid_mm))
    return np.stack([np.ones_like(x), nu, nu * nu, x, x * x, nu * x, y, nu * y, y * y, c, c * x, c * y, z, c * z,
                     w, c * w, x * w, y * w], axis=-1)


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
class ResidualGP:
    """The mean of a Gaussian process over some of the fit's features, stored as plain numbers.

    ``predict(F) = offset + variance * exp(-0.5 |(z - Z_i) / l|^2) @ weights`` with
    ``z = (F[:, inputs] - center) / scale``: the posterior mean of a process with an anisotropic
    squared-exponential kernel (the white-noise term of its fit has no cross-covariance).

    Attributes
    ----------
    inputs : tuple of int
        Columns of `FEATURES` the process sees.
    center, scale : ndarray
        Standardisation of those columns.
    length_scales : ndarray
        Kernel length scales (standardised units).
    variance : float
        Kernel variance (in the target's units squared, times ``weights``' scale).
    points : ndarray, shape (n, len(inputs))
        Standardised training inputs.
    weights : ndarray, shape (n,)
        ``K^-1 y`` of the fit, in the target's units.
    offset : float
        The process's constant mean.
    """

    inputs: tuple
    center: np.ndarray
    scale: np.ndarray
    length_scales: np.ndarray
    variance: float
    points: np.ndarray
    weights: np.ndarray
    offset: float

    def predict(self, features: np.ndarray) -> np.ndarray:
        """The process's mean at rows of `transfer_features` (broadcast over leading axes)."""
        f = np.asarray(features, dtype=float)
        z = (f[..., list(self.inputs)] - self.center) / self.scale
        d2 = np.sum(((z[..., None, :] - self.points) / self.length_scales) ** 2, axis=-1)
        return self.offset + self.variance * np.exp(-0.5 * d2) @ self.weights

    def to_dict(self) -> dict:
        return {"inputs": list(self.inputs), "center": self.center.tolist(), "scale": self.scale.tolist(),
                "length_scales": self.length_scales.tolist(), "variance": float(self.variance),
                "points": self.points.tolist(), "weights": self.weights.tolist(), "offset": float(self.offset)}

    @classmethod
    def from_dict(cls, data: dict) -> "ResidualGP":
        inputs = tuple(int(i) for i in data["inputs"])
        arrays = {k: np.asarray(data[k], dtype=float) for k in ("center", "scale", "length_scales", "points",
                                                                "weights")}
        m = len(inputs)
        if not (all(0 <= i < len(FEATURES) for i in inputs) and arrays["center"].shape == (m,)
                and arrays["scale"].shape == (m,) and arrays["length_scales"].shape == (m,)
                and arrays["points"].ndim == 2 and arrays["points"].shape[1] == m
                and arrays["weights"].shape == (arrays["points"].shape[0],)
                and np.all(arrays["scale"] > 0) and np.all(arrays["length_scales"] > 0)
                and all(np.all(np.isfinite(v)) for v in arrays.values())):
            raise ValueError("a residual process's arrays do not fit together")
        return cls(inputs, arrays["center"], arrays["scale"], arrays["length_scales"], float(data["variance"]),
                   arrays["points"], arrays["weights"], float(data["offset"]))


def on_film_line(thickness_mm: float) -> bool:
    """Whether a film has the built-in films' own thickness (`filmcal.films.FILM_THICKNESS_MM`), the line along
    which the fit was made and checked densely (750 training and 80 held-out points; elsewhere about 50 and 10
    per range of `TransferFit.thickness_rms_mm`, whose bands are therefore those of the films off it)."""
    from filmcal.films import FILM_THICKNESS_MM

    return math.isclose(float(thickness_mm), FILM_THICKNESS_MM, rel_tol=1e-9)


def thickness_range(edges_mm, thickness_mm):
    """The index of the range of `edges_mm` (increasing bounds) that holds each thickness: ``edges[k] <= t <
    edges[k + 1]``, the last range closed; a thickness beyond the bounds is given the nearest range."""
    k = np.searchsorted(np.asarray(edges_mm, dtype=float), thickness_mm, side="right") - 1
    k = np.clip(k, 0, len(edges_mm) - 2)
    return int(k) if np.ndim(k) == 0 else k


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
        The (E, nu, R, F) ranges that were sampled, and the films' thicknesses (``thickness_mm``, a range).
    grid_mm : float
        The application's grid the fit was measured on.
    provenance : dict
        How it was made (design, sizes, held-out figures, versions, date).
    residual_gp : dict
        The same keys (activation and capsule) -> `ResidualGP` of d / t beyond the polynomial.
    thickness_rms_mm : dict
        The residual measured in ranges of the film's thickness off the built-in films' own (`on_film_line`):
        ``"edges_mm"`` -> the ranges' bounds (mm, increasing), and each key -> one residual (mm) per range, the
        largest upper bound of the training rows' and of each held-out part's root-mean-square residual there
        (0 where a range holds none). `std_for` raises the term's std to it where it is larger, never lowers it,
        for films off that line. Empty: no such ranges (the std is `std_mm` at every thickness).
    """

    coefficients: dict
    std_mm: dict
    domain: dict
    grid_mm: float
    provenance: dict
    residual_gp: dict = field(default_factory=dict)
    thickness_rms_mm: dict = field(default_factory=dict)

    def hertz_radius_range_mm(self) -> tuple[float, float]:
        """The smallest and largest Hertz radius (mm, steel on steel, no film) of the sphere-on-flat contacts of
        `domain`: the contact sizes the fit was made and verified on."""
        from filmcal.hertz import hertz_radius_mm

        (r0, r1), (f0, f1) = self.domain["sphere_radius_mm"], self.domain["force_kn"]
        return float(hertz_radius_mm(r0, 1e3 * f0)), float(hertz_radius_mm(r1, 1e3 * f1))

    @classmethod
    def from_json(cls, path: str | Path) -> "TransferFit":
        """Read a fit written by `to_json` (plain JSON, no code)."""
        data = json.loads(Path(path).read_text(encoding="utf-8"))
        try:
            coef = {k: [float(c) for c in v] for k, v in data["coefficients"].items()}
            std = {k: float(v) for k, v in data["std_mm"].items()}
            domain = {k: tuple(float(x) for x in v) for k, v in data["domain"].items()}
            gp = {k: ResidualGP.from_dict(v) for k, v in data.get("residual_gp", {}).items()}
            by_t = {k: [float(x) for x in v] for k, v in data.get("thickness_rms_mm", {}).items()}
            out = cls(coef, std, domain, float(data["grid_mm"]), dict(data.get("provenance", {})), gp, by_t)
        except (KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"{path}: not a film-transfer fit ({exc})") from None
        if data.get("features") != list(FEATURES) or any(len(c) != len(FEATURES) for c in coef.values()) \
                or set(coef) != set(std) or not set(gp) <= set(coef) or len(domain.get("thickness_mm", ())) != 2:
            raise ValueError(f"{path}: the fit's features or keys do not match this version of filmcal")
        if by_t:
            edges = np.asarray(by_t.get("edges_mm", []))
            if set(by_t) != {"edges_mm", *coef} or len(edges) < 2 or not np.all(np.diff(edges) > 0) \
                    or not np.allclose(edges[[0, -1]], domain["thickness_mm"], rtol=1e-9, atol=0) \
                    or any(len(v) != len(edges) - 1 or not all(math.isfinite(x) and x >= 0 for x in v)
                           for k, v in by_t.items() if k != "edges_mm"):
                raise ValueError(f"{path}: the fit's residual per range of thickness does not fit its keys or "
                                 "its thicknesses")
        return out

    def to_json(self, path: str | Path) -> None:
        from filmcal._io import atomic_path

        doc = {"features": list(FEATURES), "coefficients": self.coefficients, "std_mm": self.std_mm,
               "domain": self.domain, "grid_mm": self.grid_mm,
               "residual_gp": {k: v.to_dict() for k, v in self.residual_gp.items()},
               "thickness_rms_mm": self.thickness_rms_mm, "provenance": self.provenance}
        with atomic_path(Path(path)) as tmp:
            Path(tmp).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")

    def shift_ratio(self, imprint: str, kinematics: str, features: np.ndarray) -> np.ndarray:
        """The fitted d / t for rows of `transfer_features` (its band: `std_for`)."""
        key = f"{imprint}/{kinematics}"
        if key not in self.coefficients:
            raise KeyError(f"no transfer fit for {key} (have {', '.join(sorted(self.coefficients))})")
        ratio = np.asarray(features) @ np.asarray(self.coefficients[key])
        if key in self.residual_gp:
            ratio = ratio + self.residual_gp[key].predict(features)
        return ratio

    def fits_thickness(self, thickness_mm: float) -> bool:
        """Whether films of this thickness (mm) lie within those the fit was made on (``domain["thickness_mm"]``)."""
        t0, t1 = self.domain["thickness_mm"]
        return t0 * (1 - 1e-9) <= thickness_mm <= t1 * (1 + 1e-9)

    def std_for(self, imprint: str, kinematics: str, thickness_mm: float, modulus_mpa: float | None = None) -> float:
        """The term's standard deviation (mm) for a film of this thickness (and modulus).

        The fit's `std_mm` (measured on the built-in films' thickness, `on_film_line`), raised for a film of
        another thickness to the residual measured on films of about its thickness where that is larger
        (`thickness_rms_mm`; beyond the ranges, the nearest one's), with `THICKNESS_STD_MM` in
        quadrature beyond the thicknesses the fit was made on, and for a level reading of a film stiffer than
        `STIFF_LEVEL_MODULUS_MPA` (when `modulus_mpa` is given), `STIFF_LEVEL_STD_MM` in quadrature.
        """
        key = f"{imprint}/{kinematics}"
        std = self.std_mm[key]
        if self.thickness_rms_mm and not on_film_line(thickness_mm):
            k = thickness_range(self.thickness_rms_mm["edges_mm"], thickness_mm)
            std = max(std, self.thickness_rms_mm[key][k])
        if not self.fits_thickness(thickness_mm):
            std = math.hypot(std, THICKNESS_STD_MM[imprint])
        if imprint != "edge" and modulus_mpa is not None and modulus_mpa > STIFF_LEVEL_MODULUS_MPA:
            std = math.hypot(std, STIFF_LEVEL_STD_MM)
        return std

    def digest(self, key: str) -> str:
        """SHA-256 of everything that sets one key's term (for the specs of cached solves): its numbers and the
        revision of the rule that makes its band (`BAND_RULE_REVISION`)."""
        import hashlib

        doc = {"band_rule": BAND_RULE_REVISION, "coefficients": self.coefficients[key], "std_mm": self.std_mm[key], "grid_mm": self.grid_mm,
               "thickness_domain_mm": list(self.domain["thickness_mm"]),
               "thickness_std_mm": THICKNESS_STD_MM[key.split("/")[0]],
               "stiff_level": [STIFF_LEVEL_MODULUS_MPA, STIFF_LEVEL_STD_MM],
               "thickness_rms_mm": [self.thickness_rms_mm.get("edges_mm"), self.thickness_rms_mm.get(key)],
               "residual_gp": self.residual_gp[key].to_dict() if key in self.residual_gp else None}
        return hashlib.sha256(json.dumps(doc, sort_keys=True).encode()).hexdigest()


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
                                 level, grid_mm=fit.grid_mm)
    ratio = fit.shift_ratio(imprint, kinematics, features)
    std = fit.std_for(imprint, kinematics, film.thickness_mm, modulus_mpa)
    shift = float(ratio) * film.thickness_mm
    perimeter = 2.0 * math.pi * radius if perimeter_mm is None else float(perimeter_mm)
    return TransferTerm(shift_mm=shift, std_mm=std, shift_mm2=shift * perimeter, std_mm2=std * perimeter)
