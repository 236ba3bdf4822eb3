"""Wheel-rail contact: S1002 / 60E1 / 60E2 profiles, wheel placement with lateral
offset, and a half-space boundary-element normal-contact solver with the film
as a compliant layer in series (plus roughness laws)."""
from filmcal.wheelrail.halfspace import (ContactResult, HalfSpaceContactSolver, SurfaceGrid, rectangle_influence_mm,
                                         sphere_on_flat_contact)
from filmcal.wheelrail.hertz import HertzContact, hertz_elliptic
from filmcal.wheelrail.interface import (ExponentialLaw, FilmLayer, GreenwoodWilliamsonLaw, HardLaw, InterfaceLaw,
                                         TabularLaw)
from filmcal.wheelrail.placement import ContactPoint, WheelRailPlacement, offset_range_mm, place_wheel_on_rail
from filmcal.wheelrail.profiles import (PROFILE_NAMES, Profile, flange_height_mm, flange_thickness_mm, get_profile,
                                        head_width_mm, load_profile_csv, profile_dimensions)

__all__ = [
    "SurfaceGrid", "ContactResult", "HalfSpaceContactSolver", "rectangle_influence_mm", "sphere_on_flat_contact",
    "HertzContact", "hertz_elliptic", "FilmLayer", "InterfaceLaw", "HardLaw", "ExponentialLaw", "TabularLaw",
    "GreenwoodWilliamsonLaw", "ContactPoint", "WheelRailPlacement", "offset_range_mm", "place_wheel_on_rail",
    "PROFILE_NAMES", "Profile", "get_profile", "load_profile_csv", "flange_height_mm", "flange_thickness_mm",
    "head_width_mm", "profile_dimensions",
]
