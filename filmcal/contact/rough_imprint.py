"""What a film records on rough bodies, and the uncertain inputs of that answer.

A rough steel body pressed on the film touches it at asperities. On the
contact grid the interface is a closure law in series with the film
(`filmcal.contact.roughness.rough_contact_law`, boundary elements against the
film); it spreads the nominal pressure. What the film records there is not the
nominal pressure but the local one: at a point of nominal pressure ``p`` a
fraction ``c(p)`` of the film is coloured (its *coverage*):

* edge model: the real contact fraction (every touched spot colours);
* activation model: the fraction whose local pressure exceeds the activation
  pressure (`RoughContactLaw.fraction_above`);
* capsule model: the mean stain probability over the local pressures
  (`RoughContactLaw.expected_stain`).

A scanned imprint is the region where the colour is dense enough to be read:
the edge and activation models read the contour where the coverage reaches the
**reading level** ``l`` (a pixel counts as stained where at least that
fraction of it is coloured); the capsule model, whose smooth reading is already
the expected coloured area, integrates the coverage. Two rough faces (wheel and
rail) colour independently: ``c = 1 - (1 - c_wheel)(1 - c_rail)``.

The asperity pressure cannot exceed the hardness ``H`` of what it presses
into. Where ``H`` lies below a film's activation pressure, asperities cannot
stain that film until the nominal pressure itself approaches the activation
pressure: its imprint barely moves (the paper's HHS, section 2). Soft films
are stained by asperities far outside the smooth contour (MS, HS). ``H``,
``l`` and the surface's spectrum are uncertain; `ROUGHNESS_PRIOR` states their
prior ranges and sources, `sample_roughness_prior` draws them, and the
conditioned draws shipped with the package (`load_roughness_inputs`,
``filmcal/data/roughness_inputs.json``, made by ``scripts/condition-roughness``
from the paper's roughened-flat observation) are what every command uses.

The rough imprint enters a correction as a ratio to the smooth reading of the
same imprint model, so that the smooth calibration stays what it is and Ra = 0
(no law) gives the ratio 1 exactly.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, fields
from functools import lru_cache
from importlib import resources

import numpy as np

from filmcal._validation import check_positive, check_range

__all__ = ["RoughnessInputs", "PriorInput", "ROUGHNESS_PRIOR", "DEFAULT_ROUGHNESS_INPUTS", "sample_roughness_prior",
           "representative_roughness_inputs",
           "coverage", "coverage_level_mpa", "rough_recorded_area_mm2", "load_roughness_inputs",
           "ROUGHNESS_INPUTS_FILE", "RoughnessRangeWarning", "MAX_RMS_SLOPE"]

#: The shipped conditioned draws (package data).
ROUGHNESS_INPUTS_FILE = "roughness_inputs.json"

#: Above this rms slope a synthetic surface is outside what the micro law represents (a warning).
MAX_RMS_SLOPE = 1.0


class RoughnessRangeWarning(UserWarning):
    """A rough answer outside the range the roughness law represents."""


#: Side and pixels of the synthetic surfaces (the law is converged in both: `filmcal.contact.roughness`).
SURFACE_SIZE_UM = 200.0
SURFACE_PIXELS = 256


@dataclass(frozen=True)
class RoughnessInputs:
    """One draw of the rough imprint's uncertain inputs.

    Attributes
    ----------
    film_hardness_mpa : float
        Cap on the asperity pressures in the film's coating (MPa).
    reading_level : float
        Coverage at which a scan reads the film as stained (0-1).
    hurst : float
        Hurst exponent of the synthetic steel surface.
    rolloff_wavelength_um, cutoff_wavelength_um : float
        Roll-off (longest self-affine) and short cut-off wavelengths (um).
    seed : int
        The surface realisation (random phases and amplitudes).
    """

    film_hardness_mpa: float
    reading_level: float
    hurst: float
    rolloff_wavelength_um: float
    cutoff_wavelength_um: float
    seed: int = 0

    def __post_init__(self) -> None:
        check_positive("film_hardness_mpa", self.film_hardness_mpa)
        check_range("reading_level", self.reading_level, 0.0, 1.0)
        check_range("hurst", self.hurst, 0.0, 1.0)
        check_range("rolloff_wavelength_um", self.rolloff_wavelength_um, 0.0, SURFACE_SIZE_UM, high_open=False)
        check_range("cutoff_wavelength_um", self.cutoff_wavelength_um, 2.0 * SURFACE_SIZE_UM / SURFACE_PIXELS,
                    self.rolloff_wavelength_um, low_open=False)

    def surface(self, ra_um: float, body: int = 0):
        """The synthetic surface of this draw at ``ra_um`` (`RoughSurface`); ``body`` 0 (wheel, flat) or 1
        (rail, sphere) gives independent realisations of the same spectrum."""
        import warnings

        from filmcal.contact.roughness import RoughSurface

        surface = RoughSurface.synthetic(ra_um=float(ra_um), hurst=self.hurst,
                                         rolloff_wavelength_um=self.rolloff_wavelength_um,
                                         cutoff_wavelength_um=self.cutoff_wavelength_um, size_um=SURFACE_SIZE_UM,
                                         n=SURFACE_PIXELS, seed=2 * int(self.seed) + body)
        if surface.rms_slope > MAX_RMS_SLOPE:
            warnings.warn(RoughnessRangeWarning(
                f"Ra {float(ra_um):g} um: synthetic surfaces of this Ra have rms slopes above {MAX_RMS_SLOPE:g}: at "
                "such roughness waviness longer than the contact grid (a turned wheel's feed "
                "marks) belongs to the macro gap, and a surface given by its Ra alone has none; take the rough "
                "answer as an estimate, or give a measured profile across the lay (its waviness then enters "
                "the gap)"), stacklevel=2)
        return surface

    def bodies(self, wheel=None, rail=None):
        """Both bodies' roughness (`filmcal.contact.roughness.Roughness`) of this draw.

        ``wheel`` and ``rail`` (or flat and sphere) are each None or 0 (smooth), an Ra in um (this draw's
        synthetic surface) or a measured `RoughSurface` (taken as it is: only the hardness and the reading
        level of the draw apply to it).
        """
        from filmcal.contact.roughness import Roughness, RoughSurface

        def body(value, k):
            if isinstance(value, RoughSurface):
                return value
            return self.surface(value, k) if value else None

        return Roughness(body(wheel, 0), body(rail, 1), float(self.film_hardness_mpa))

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "RoughnessInputs":
        names = {f.name for f in fields(cls)}
        unknown = set(data) - names
        if unknown:
            raise ValueError(f"roughness inputs: unknown keys {sorted(unknown)}")
        return cls(**{k: (int(v) if k == "seed" else float(v)) for k, v in data.items()})


@dataclass(frozen=True)
class PriorInput:
    """One uncertain input: uniform in ``low..high`` (``log``: uniform in its logarithm), with its source."""

    name: str
    low: float
    high: float
    log: bool
    source: str

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Map uniform [0, 1) draws to this input."""
        if self.log:
            return np.exp(np.log(self.low) + u * (np.log(self.high) - np.log(self.low)))
        return self.low + u * (self.high - self.low)


#: The rough imprint's uncertain inputs and where their ranges come from.
ROUGHNESS_PRIOR: tuple[PriorInput, ...] = (
    PriorInput("film_hardness_mpa", 50.0, 600.0, True,
               "the coating the asperities press into: its microcapsules crush at the films' ranges (10-300 MPa) "
               "and the PET carrier under it has a Tabor hardness 3 Y ~ 300 MPa (Y ~ 100 MPa for biaxially "
               "oriented PET; nanoindentation of PET films 0.2-0.4 GPa); 50-600 MPa spans a crushed capsule "
               "layer to twice the carrier's value"),
    PriorInput("reading_level", 0.02, 0.5, True,
               "a scan reads a pixel as stained from isolated dots (a few % coloured, the halo of dots around a "
               "scanned imprint) to half coverage (a threshold midway between full colour and paper)"),
    PriorInput("hurst", 0.6, 0.9, False,
               "Hurst exponent of machined and worn steel, 0.6-0.9 (Persson et al. 2005, J. Phys.: Condens. "
               "Matter 17:R1; Jacobs, Junge & Pastewka 2017, Surf. Topogr. 5:013001)"),
    PriorInput("rolloff_wavelength_um", 25.0, 100.0, True,
               "roll-off near the mean profile-element spacing RSm of turned and ground steel at Ra 1-2 um "
               "(25-100 um)"),
    PriorInput("cutoff_wavelength_um", 2.0, 8.0, True,
               "short cut-off from the ISO 3274 stylus filter (2.5 um at Ra 0.1-2 um, 8 um above) down to the "
               "scale below which a stylus of 2 um tip radius no longer resolves"),
)

#: The prior's central draw (log-midpoints, midpoints), used where no draws are asked for.
DEFAULT_ROUGHNESS_INPUTS = RoughnessInputs(
    **{p.name: float(p.from_unit(np.array(0.5))) for p in ROUGHNESS_PRIOR}, seed=0)


def sample_roughness_prior(n: int, random_state: int | np.random.Generator = 0) -> list[RoughnessInputs]:
    """``n`` draws of the inputs from `ROUGHNESS_PRIOR` (a scrambled Latin hypercube; seeds 0..n-1)."""
    from scipy.stats import qmc

    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
    rng = random_state if isinstance(random_state, np.random.Generator) else np.random.default_rng(random_state)
    unit = qmc.LatinHypercube(d=len(ROUGHNESS_PRIOR), seed=rng).random(int(n))
    cols = {p.name: p.from_unit(unit[:, j]) for j, p in enumerate(ROUGHNESS_PRIOR)}
    return [RoughnessInputs(**{k: float(v[i]) for k, v in cols.items()}, seed=i) for i in range(int(n))]


@lru_cache(maxsize=1)
def _shipped() -> dict:
    text = resources.files("filmcal.data").joinpath(ROUGHNESS_INPUTS_FILE).read_text()
    return json.loads(text)


def load_roughness_inputs(which: str = "conditioned") -> list[RoughnessInputs]:
    """The shipped draws of the inputs: ``conditioned`` (default; on the paper's roughened-flat observation)
    or ``prior``."""
    if which not in ("conditioned", "prior"):
        raise ValueError(f"which must be conditioned or prior, got {which!r}")
    return [RoughnessInputs.from_dict(d) for d in _shipped()[which]]


def representative_roughness_inputs() -> RoughnessInputs:
    """The conditioned draw whose growths lie nearest the conditioned means (what a single rough solve, such
    as ``filmcal wheelrail``'s, uses)."""
    data = _shipped()
    return RoughnessInputs.from_dict(data["conditioned"][int(data["representative"])])


# ---------------------------------------------------------------------------
# the reading
# ---------------------------------------------------------------------------
def _laws(rough_law) -> tuple:
    return tuple(getattr(rough_law, "laws", (rough_law,)))


def coverage(model, rough_law, nominal_pressure_mpa: np.ndarray) -> np.ndarray:
    """Coloured fraction of the film at nominal pressures under the rough law(s), for `FilmModel` ``model``."""
    from filmcal.contact.imprint import get_imprint_model

    p = np.asarray(nominal_pressure_mpa, dtype=float)
    imprint = get_imprint_model(model.imprint)
    blank = np.ones_like(p)
    for law in _laws(rough_law):
        if model.imprint == "edge":
            c = law.contact_fraction(p)
        elif model.imprint == "activation":
            c = law.fraction_above(float(model.film.activation_pressure_mpa), p)
        else:
            c = law.expected_stain(lambda q: imprint.stain_probability(q, model.film), p,
                                   key=(model.imprint, repr(model.film)))
        blank = blank * (1.0 - np.clip(c, 0.0, 1.0))
    return np.where(p > 0.0, 1.0 - blank, 0.0)


def coverage_level_mpa(model, rough_law, reading_level: float, max_pressure_mpa: float) -> float:
    """The nominal pressure at which the coverage first reaches ``reading_level`` (inf when it does not up to
    ``max_pressure_mpa``)."""
    level = check_range("reading_level", reading_level, 0.0, 1.0)
    top = float(max_pressure_mpa)
    if not top > 0.0:
        return math.inf
    p = np.linspace(0.0, top, 2001)[1:]
    c = coverage(model, rough_law, p)
    above = np.flatnonzero(c >= level)
    if above.size == 0:
        return math.inf
    k = int(above[0])
    if k == 0:
        return float(p[0] * level / max(c[0], level))
    return float(np.interp(level, [c[k - 1], c[k]], [p[k - 1], p[k]]))


def rough_recorded_area_mm2(model, result, rough_law, reading_level: float) -> float:
    """The area (mm^2) the film of `FilmModel` ``model`` records of a contact solved with ``rough_law`` in series.

    Edge and activation models: the region where the coverage reaches ``reading_level``, read as the
    nominal pressure's contour there (sub-cell, `GridField.level_area_mm2`); capsule model: the coverage
    integrated over the nominal field.
    """
    from filmcal.contact.reading import FILM_CONTOUR_POWER, GridField

    contact = getattr(result, "contact", result)
    field = GridField(contact.grid.x_mm, contact.grid.y_mm, np.clip(contact.pressure_mpa, 0.0, None),
                      FILM_CONTOUR_POWER)
    if model.imprint == "capsule":  # the coverage tabulated over the field's pressures (smooth in p), then read
        nodes = np.linspace(0.0, float(field.pressure_mpa.max()), 513)
        table = coverage(model, rough_law, nodes)
        return field.integral_mm2(lambda p: np.interp(p, nodes, table) * (p > 0.0))
    level = coverage_level_mpa(model, rough_law, reading_level, float(field.pressure_mpa.max()))
    if not math.isfinite(level):
        return 0.0
    return field.level_area_mm2(level)[0]
