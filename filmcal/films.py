"""Facts about the Prescale film types (from the reference paper, section 1)."""
from __future__ import annotations

__all__ = ["FILM_TYPES", "ACTIVATION_PRESSURE_MPA", "FILM_THICKNESS_MM"]

#: Film types of Table 1, from the softest to the stiffest measurement range.
FILM_TYPES: tuple[str, ...] = ("MS", "HS", "HHS")
#: Lower ends of the measurement ranges (MS 10-50, HS 50-130, HHS 130-300 MPa): the
#: pressure above which a film type colours.
ACTIVATION_PRESSURE_MPA: dict[str, float] = {"MS": 10.0, "HS": 50.0, "HHS": 130.0}
#: Thickness of the films' PET carrier, as modelled in the paper (mm).
FILM_THICKNESS_MM = 0.09
