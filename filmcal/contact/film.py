"""The film as the contact models see it: how it deforms and what it records.

A calibrated film model is a film type (`filmcal.films.FilmType`), an imprint
model (`filmcal.contact.imprint`: what the film records) and the film's
kinematics (small strain: linear springs ``t/M``; large strain: the
neo-Hookean oedometric law of the FE model's ``large_strain`` film). The same
`FilmModel` is used by the wheel-rail corrector, the correction curves and the
``filmcal wheelrail`` command, so that a film is read identically wherever its
calibration is used.

With a rough surface (`filmcal.contact.roughness`), the film-wheel interface
adds the rough law's closure in series: the nominal pressure spreads.
What the film records there is where the asperities colour it densely enough
for a scan to read it (`filmcal.contact.rough_imprint`): `recorded_area_mm2`
takes the rough law for that.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from filmcal.contact.names import KINEMATICS
from filmcal.films import FilmType

__all__ = ["FilmModel", "KINEMATICS"]



@dataclass(frozen=True)
class FilmModel:
    """One calibrated film model: film type, imprint model and kinematics.

    Parameters
    ----------
    film : FilmType
    imprint : {"edge", "activation", "capsule"}
    kinematics : {"small", "large"}
    """

    film: FilmType
    imprint: str = "edge"
    kinematics: str = "small"

    def __post_init__(self) -> None:
        from filmcal.contact.imprint import get_imprint_model

        if self.kinematics not in KINEMATICS:
            raise ValueError(f"kinematics must be small or large, got {self.kinematics!r}")
        get_imprint_model(self.imprint).check_film(self.film)

    @property
    def label(self) -> str:
        return f"{self.imprint}/{self.kinematics}"

    def interface(self, modulus_mpa: float, roughness: Any = None):
        """The (film, law) pair for the contact solvers, and the rough law used (or None).

        Parameters
        ----------
        modulus_mpa : float
            The film's Young's modulus (MPa).
        roughness : None, Roughness, RoughSurface or InterfaceLaw
            Smooth; the rough bodies (`filmcal.contact.roughness.Roughness`:
            each body's law against this film, in series); one rough surface
            (its law against this film); or a measured pressure-closure law
            taken as it is.

        Returns
        -------
        (FilmLayer or None, InterfaceLaw or None, InterfaceLaw or None)
            Solver film, solver law, and the roughness law.
        """
        from filmcal.contact.laws import FilmLayer, film_law
        from filmcal.contact.rough_imprint import representative_roughness_inputs
        from filmcal.contact.roughness import RoughSurface, Roughness

        layer = FilmLayer(float(modulus_mpa), self.film.poisson, self.film.thickness_mm)
        law = roughness
        if isinstance(roughness, Roughness):
            law = roughness.film_law(layer.modulus_mpa, layer.poisson, layer.thickness_mm)
        elif isinstance(roughness, RoughSurface):
            law = Roughness(roughness, None, representative_roughness_inputs().film_hardness_mpa).film_law(
                layer.modulus_mpa, layer.poisson, layer.thickness_mm)
        solver_film, solver_law = film_law(layer, law, kinematics=self.kinematics)
        return solver_film, solver_law, law

    def recorded_area_mm2(self, result, rough_law=None, reading_level: float | None = None) -> float:
        """The area (mm^2) that the film records of a solved contact with film.

        Parameters
        ----------
        result : WheelRailResult or ContactResult
            A solved contact (``.contact`` of a wheel-rail result, or the
            half-space result itself).
        rough_law : RoughContactLaw or SeriesLaw of them, optional
            The rough bodies' law the contact was solved with (the third value of `interface`): the film
            then records where the asperities colour it (`filmcal.contact.rough_imprint`). A law that does
            not know its local pressures (a measured one) is read like a smooth contact.
        reading_level : float, optional
            Coverage at which a scan reads the film as stained (default: the representative conditioned
            draw's, `filmcal.contact.rough_imprint.representative_roughness_inputs`).
        """
        from filmcal.contact.imprint import get_imprint_model

        if rough_law is not None and all(hasattr(law, "fraction_above") for law in getattr(rough_law, "laws",
                                                                                               (rough_law,))):
            from filmcal.contact.rough_imprint import representative_roughness_inputs, rough_recorded_area_mm2

            level = representative_roughness_inputs().reading_level if reading_level is None else reading_level
            return rough_recorded_area_mm2(self, result, rough_law, level)
        if self.imprint == "edge":
            return float(result.area_mm2)
        contact = getattr(result, "contact", result)
        model = get_imprint_model(self.imprint)
        return float(model.area_mm2(contact.grid.x_mm, contact.grid.y_mm, contact.pressure_mpa, self.film))

    def transfer_term(self, modulus_mpa: float, result):
        """The calibrated film's imprint minus this application's reading of it (`filmcal.contact.transfer`).

        The shipped fit of the edge offset between the continuum FE film (the
        calibration's model) and the film law solved here, evaluated for this
        solved contact and applied along its outline: add ``shift_mm2`` to
        `recorded_area_mm2` for the area the calibrated film would record, and
        carry ``std_mm2`` in the band.

        Parameters
        ----------
        modulus_mpa : float
            The film's Young's modulus (MPa) the contact was solved with.
        result : WheelRailResult or ContactResult

        Returns
        -------
        filmcal.contact.transfer.TransferTerm
        """
        import math

        from filmcal.contact.transfer import load_transfer_fit, outline_perimeter_mm, transfer_term

        area = self.recorded_area_mm2(result)
        support = float(result.area_mm2)
        perimeter = outline_perimeter_mm(result.outline_mm)
        # the recorded outline's length: the support outline's shape at the recorded area
        shape = perimeter / (2.0 * math.sqrt(math.pi * support)) if support > 0 and perimeter > 0 else 1.0
        return transfer_term(load_transfer_fit(), self.imprint, self.kinematics, self.film, modulus_mpa, area,
                             result.max_pressure_mpa, shape * 2.0 * math.sqrt(math.pi * area))

    def stained_area_mm2(self, result, rough_law) -> float:
        """The area (mm^2) of the coloured asperity spots under a rough surface.

        The imprint model's stain probability averaged over the local
        (asperity) pressures at each cell's nominal pressure
        (`RoughContactLaw.expected_stain`), summed over the cells.
        """
        from filmcal.contact.imprint import get_imprint_model

        contact = getattr(result, "contact", result)
        model = get_imprint_model(self.imprint)
        p = contact.pressure_mpa
        loaded = p > 0.0
        fraction = rough_law.expected_stain(lambda q: model.stain_probability(q, self.film), p[loaded],
                                            key=(self.imprint, repr(self.film)))
        return float(fraction.sum() * contact.grid.cell_area_mm2)
