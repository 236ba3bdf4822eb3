"""One wheel-rail solve with a film as a user describes it: a film type or its parameters, what it records,
its kinematics and the wheel's roughness; the answer as a JSON-ready summary.

This is what ``filmcal wheelrail`` calls: the film and roughness law come from `FilmModel` (the same law
the corrector and the curves use), the rough surface from `filmcal.contact.roughness`.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from filmcal.wheelrail.settings import GRID_MM, NOMINAL_RADIUS_MM, RAIL, RAIL_INCLINATION, WHEEL
from filmcal._validation import HARDNESS_MPA_BOUNDS, check_positive, check_range, check_ra
from filmcal.contact.names import DEFAULT_IMPRINT_MODEL, DEFAULT_KINEMATICS

__all__ = ["WheelRoughness", "FilmContactCase", "solve_film_contact"]


@dataclass(frozen=True)
class WheelRoughness:
    """The bodies' roughness as a user gives it: the wheel's (a synthetic surface of Ra, a measured height
    map, or a measured film-wheel law) and the rail's (a synthetic surface of Ra).

    Attributes
    ----------
    ra_um : float, optional
        Ra of a synthetic self-affine steel surface of the wheel (um, 0-30; 0: smooth).
    map_file, rail_map_file : str, optional
        The wheel's (rail's) measured surface (`filmcal.contact.surface_files.read_surface_file`): an x3p map
        or profile, a CSV line profile across the lay, a CSV of heights (times `height_scale` gives um) or a
        greyscale PNG/TIFF (black to white spans `height_range_um`), these two with pixels `pixel_um` apart.
    law_file : str, optional
        A measured film-wheel pressure-closure law (CSV closure_um,pressure_mpa).
    seed : int, optional
        Realisation of the synthetic surfaces (default: the representative conditioned draw's).
    hardness_mpa : float, optional
        Cap on asperity pressures in the film (default: the representative conditioned draw's).
    """

    ra_um: float | None = None
    map_file: str | None = None
    law_file: str | None = None
    pixel_um: float | None = None
    height_scale: float = 1.0
    height_range_um: float | None = None
    seed: int | None = None
    hardness_mpa: float | None = None
    rail_ra_um: float | None = None
    rail_map_file: str | None = None

    def __post_init__(self) -> None:
        given = [x is not None for x in (self.ra_um, self.map_file, self.law_file)]
        if sum(given) > 1:
            raise ValueError("give one of a roughness Ra, a roughness map and a roughness law")
        if self.ra_um is not None:
            check_ra("wheel_roughness_ra_um", self.ra_um)
        if self.rail_ra_um is not None and self.rail_map_file is not None:
            raise ValueError("give the rail's roughness as an Ra or as a map, not both")
        if self.rail_map_file is not None and self.law_file is not None:
            raise ValueError("--rail-roughness-map cannot be combined with --roughness-law")
        if self.rail_ra_um is not None:
            check_ra("rail_roughness_ra_um", self.rail_ra_um)
            if self.law_file is not None:
                raise ValueError("--rail-roughness-ra-um cannot be combined with --roughness-law (a measured "
                                 "law is the whole interface as measured)")
        if self.hardness_mpa is not None:
            check_range("hardness_mpa", self.hardness_mpa, *HARDNESS_MPA_BOUNDS, low_open=False, high_open=False)
            if self.law_file is not None:
                raise ValueError("--hardness-mpa cannot be combined with --roughness-law (a measured law is the "
                                 "whole interface as measured)")
        if self.smooth:
            given = [flag for flag, value in (("--hardness-mpa", self.hardness_mpa),
                                              ("--roughness-seed", self.seed)) if value is not None]
            if given:
                raise ValueError(f"{' and '.join(given)} need{'s' if len(given) == 1 else ''} a rough wheel or "
                                 "rail (--wheel-roughness-ra-um, --wheel-roughness-map, --rail-roughness-ra-um or "
                                 "--rail-roughness-map)")

    @property
    def smooth(self) -> bool:
        """No roughness: nothing given, or Ra = 0 (the smooth solve exactly, no law)."""
        return (not self.ra_um and not self.rail_ra_um and self.map_file is None and self.law_file is None
                and self.rail_map_file is None)

    def inputs(self):
        """The roughness law's inputs: the representative conditioned draw
        (`filmcal.contact.rough_imprint.representative_roughness_inputs`), with this seed and hardness when
        given."""
        from dataclasses import replace

        from filmcal.contact.rough_imprint import representative_roughness_inputs

        inputs = representative_roughness_inputs()
        if self.seed is not None:
            inputs = replace(inputs, seed=int(self.seed))
        if self.hardness_mpa is not None:
            inputs = replace(inputs, film_hardness_mpa=float(self.hardness_mpa))
        return inputs

    def bodies(self):
        """The rough bodies (`filmcal.contact.roughness.Roughness`) of the wheel's surface and the rail's Ra."""
        from filmcal.contact.roughness import Roughness, RoughSurface

        inputs = self.inputs()
        wheel = self.surface()
        rail = inputs.surface(self.rail_ra_um, 1) if self.rail_ra_um else None
        if self.rail_map_file is not None:
            from filmcal.contact.surface_files import read_surface_file

            rail = read_surface_file(self.rail_map_file, self.pixel_um, self.height_scale, self.height_range_um)
        if wheel is not None and rail is not None and self.map_file is not None and self.rail_map_file is None:
            # the rail's synthetic surface on the wheel map's grid, so that their heights can add
            n, m = wheel.heights_um.shape
            if n != m:
                raise ValueError(f"--rail-roughness-ra-um with a {n} x {m} --wheel-roughness-map: the rail's "
                                 "surface is drawn on the map's grid, which must be square")
            size = n * wheel.pixel_um
            rail = RoughSurface.synthetic(ra_um=self.rail_ra_um, hurst=inputs.hurst,
                                          rolloff_wavelength_um=min(inputs.rolloff_wavelength_um, size),
                                          size_um=size, n=n, seed=2 * inputs.seed + 1)
        return Roughness(wheel, rail, inputs.film_hardness_mpa)

    def surface(self):
        """The wheel's rough surface (`RoughSurface`), or None for a measured law or a smooth wheel."""
        if self.map_file is not None:
            from filmcal.contact.surface_files import read_surface_file

            return read_surface_file(self.map_file, self.pixel_um, self.height_scale, self.height_range_um)
        if not self.ra_um:  # None or 0: smooth
            return None
        return self.inputs().surface(self.ra_um, 0)


@dataclass(frozen=True)
class FilmContactCase:
    """The film of one solve: a film type (or the default film) with optional overrides.

    Attributes
    ----------
    film_modulus_mpa : float or None
        The film's E (None: no film, steel on steel).
    film : str, optional
        A film type (MS, HS, HHS or one of `films_file`): its thickness and nu are the defaults, and the
        imprint it records is reported.
    """

    film_modulus_mpa: float | None
    film_poisson: float | None = None
    film_thickness_mm: float | None = None
    film: str | None = None
    films_file: str | None = None
    imprint_model: str = DEFAULT_IMPRINT_MODEL
    kinematics: str = DEFAULT_KINEMATICS

    def film_type(self):
        """The `FilmType` named, or a nameless one of the given (or default) thickness and nu."""
        from filmcal.films import FILM_POISSON, FILM_THICKNESS_MM, FilmRegistry, FilmType

        if self.film is None:
            if self.films_file:
                raise ValueError("--films-file needs --film")
            return None, FilmType("film", poisson=self.film_poisson if self.film_poisson is not None
                                  else FILM_POISSON, thickness_mm=self.film_thickness_mm
                                  if self.film_thickness_mm is not None else FILM_THICKNESS_MM)
        named = FilmRegistry.from_file(self.films_file).get(self.film)
        from dataclasses import replace

        overrides = {k: v for k, v in (("poisson", self.film_poisson), ("thickness_mm", self.film_thickness_mm))
                     if v is not None}
        return named, replace(named, **overrides) if overrides else named


def solve_film_contact(offset_mm: float, force_n: float, case: FilmContactCase,
                       roughness: WheelRoughness | None = None, *, wheel=WHEEL, rail=RAIL,
                       rail_inclination: float = RAIL_INCLINATION, nominal_radius_mm: float = NOMINAL_RADIUS_MM,
                       grid_mm: float = GRID_MM, plot_path: str | Path | None = None):
    """Solve a wheel-rail contact with (or without) a film; return ``(result, summary)``.

    The film's law (linear springs t/M or the large-strain law) and the wheel's roughness law in series
    come from `FilmModel.interface`; without a film rough bodies use the steel-on-steel boundary-element law
    (`filmcal.contact.roughness.steel_contact_law`) and report their nominal area (`nominal_rough_area_mm2`).

    plot_path : str or Path, optional
        Also draw the pressure map with the contact outlines into this PNG/PDF/SVG file.

    Returns
    -------
    (WheelRailResult, dict)
        The solve, and its JSON-ready summary (``contact_area_mm2``, ``max_pressure_mpa``, the film, the
        roughness law, and with a film type its ``imprint_area_mm2`` under ``imprint_model``).
    """
    from filmcal.contact.film import FilmModel
    from filmcal.contact.laws import TabularLaw, film_law
    from filmcal.wheelrail.wheelrail import solve_wheel_rail

    check_positive("force_n", force_n)
    roughness = roughness or WheelRoughness()
    named, film_type = case.film_type()
    no_film = case.film_modulus_mpa is None
    if no_film and case.kinematics == "large":
        raise ValueError("--kinematics large needs a film (--film-modulus-mpa)")
    if no_film and roughness.hardness_mpa is not None:
        raise ValueError("--hardness-mpa is the film coating's: without film the steel's hardness caps the "
                         "asperity pressures")
    # a film type's imprint is read from the solve with or without its film (the latter: what it would colour)
    model = FilmModel(film_type, case.imprint_model if named is not None else "edge",
                      "small" if no_film else case.kinematics)
    from filmcal.contact.waviness import WAVINESS_CUTOFF_CELLS

    whole = roughness.bodies()
    # measured surfaces longer than a few cells: their waviness goes into the gap, the rest into the law
    bodies = whole.split(1e3 * WAVINESS_CUTOFF_CELLS * grid_mm)
    if bodies.waviness is not None:  # laid at the draw's phase, as a correction's draw lays it
        from dataclasses import replace

        bodies = replace(bodies, waviness=bodies.waviness.shifted([int(roughness.inputs().seed), 7]))
    wavy = {"waviness_rms_um": bodies.waviness.rms_um} if bodies.waviness is not None else {}
    law = None
    rough_info = None
    if roughness.law_file is not None:
        law = TabularLaw.from_csv(roughness.law_file)
        rough_info = {"model": "measured law", "file": str(roughness.law_file)}
    if no_film:
        if not bodies.smooth:
            law = bodies.steel_law()
            rough_info = {"model": "FFT boundary elements, steel on steel", **(law.describe() if law else {}),
                          **whole.describe(), **wavy}
        solver_film, solver_law = film_law(None, law)
    else:
        if not bodies.smooth:
            law = bodies.film_law(case.film_modulus_mpa, film_type.poisson, film_type.thickness_mm)
            parts = getattr(law, "laws", (law,))
            rough_info = {"model": "FFT boundary elements", **(parts[0].describe() if law else {}),
                          **whole.describe(), **wavy}
        solver_film, solver_law, _ = model.interface(case.film_modulus_mpa, law)
        rough_info = rough_info and {**rough_info, "reading_level": roughness.inputs().reading_level}
        if rough_info and roughness.hardness_mpa is not None:
            rough_info["hardness_source"] = "given (--hardness-mpa)"
    result = solve_wheel_rail(offset_mm, force_n, wheel=_profile(wheel, "wheel"), rail=_profile(rail, "rail"),
                              rail_inclination=rail_inclination, nominal_radius_mm=nominal_radius_mm,
                              film=solver_film, roughness=solver_law, grid_mm=grid_mm, waviness=bodies.waviness)
    if plot_path is not None:
        from filmcal.wheelrail.plots import plot_pressure_map

        plot_pressure_map(result, plot_path)
    out: dict[str, Any] = result.summary()
    if no_film and (law is not None and not law.is_hard or bodies.waviness is not None):
        out["nominal_area_mm2"] = nominal_rough_area_mm2(result, solve_wheel_rail(
            offset_mm, force_n, wheel=_profile(wheel, "wheel"), rail=_profile(rail, "rail"),
            rail_inclination=rail_inclination, nominal_radius_mm=nominal_radius_mm, grid_mm=grid_mm))
    if not no_film:
        from filmcal.contact.laws import FilmLayer, LargeStrainFilm

        film = FilmLayer(case.film_modulus_mpa, film_type.poisson, film_type.thickness_mm)
        strain = (float(LargeStrainFilm.from_film(film).strain(result.max_pressure_mpa)) if case.kinematics == "large"
                  else float(result.max_pressure_mpa / film.oedometric_modulus_mpa))
        out["film"] = {"name": None if named is None else named.name, "modulus_mpa": film.modulus_mpa, "poisson": film.poisson, "thickness_mm": film.thickness_mm,
                       "oedometric_modulus_mpa": film.oedometric_modulus_mpa, "kinematics": case.kinematics,
                       "max_strain": strain}
    out["roughness"] = rough_info
    if roughness.ra_um is not None:
        out["wheel_roughness_ra_um"] = roughness.ra_um
    if roughness.rail_ra_um is not None:
        out["rail_roughness_ra_um"] = roughness.rail_ra_um
    if named is not None:
        if no_film:
            out["film"] = {"name": named.name}
        out["imprint_model"] = model.imprint
        rough_law = None if no_film else law
        level = roughness.inputs().reading_level
        out["imprint_area_mm2"] = model.recorded_area_mm2(result, rough_law, level)
        if not no_film:
            term = model.transfer_term(case.film_modulus_mpa, result)
            out["transfer_shift_mm2"], out["transfer_std_mm2"] = term.shift_mm2, term.std_mm2
            out["calibrated_imprint_area_mm2"] = out["imprint_area_mm2"] + term.shift_mm2
        if film_type.activation_pressure_mpa is not None:
            out["activation_pressure_mpa"] = film_type.activation_pressure_mpa
        if hasattr(law, "expected_stain"):
            out["stained_area_mm2"] = model.stained_area_mm2(result, law)
    from filmcal.hertz import ELASTIC_LIMIT_MPA

    if result.max_pressure_mpa > ELASTIC_LIMIT_MPA:  # as `filmcal fem` and `filmcal correct` say it
        out["warnings"] = [f"the peak pressure {result.max_pressure_mpa:.0f} MPa exceeds the steel's elastic limit "
                           f"({ELASTIC_LIMIT_MPA:.0f} MPa): the bodies would yield, and the elastic model does not "
                           "hold"]
    return result, out


def nominal_rough_area_mm2(rough, smooth) -> float:
    """The nominal contact area of rough bodies without film (mm^2).

    The smooth contact's area times the growth of the area where the nominal pressure exceeds 1 % of its
    maximum (`filmcal.contact.reading.nominal_area_mm2`, read alike on both): a rough contact's pressure
    decays smoothly beyond the smooth edge, and the ratio of one reading of both keeps the smooth limit
    exact.
    """
    from filmcal.contact.reading import nominal_area_mm2

    def level(result) -> float:
        grid = result.contact.grid
        return nominal_area_mm2(grid.x_mm, grid.y_mm, result.contact.pressure_mpa)

    return float(smooth.area_mm2) * level(rough) / level(smooth)


def _profile(name, kind: str):
    """A profile by name (S1002, 60E1, 60E2), from a CSV file, or given as a `Profile`."""
    from filmcal.wheelrail.profiles import get_profile, load_profile_csv

    if not isinstance(name, (str, Path)):
        return name
    name = str(name)
    if name.lower().endswith(".csv") or Path(name).is_file():
        return load_profile_csv(name, kind=kind)
    profile = get_profile(name)
    if profile.kind != kind:
        raise ValueError(f"{kind} must be a {kind} profile, got the {profile.kind} profile {name!r}")
    return profile
