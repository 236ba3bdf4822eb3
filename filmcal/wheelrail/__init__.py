"""Wheel-rail contact: S1002 / 60E1 / 60E2 profiles, wheel placement with lateral
offset, a half-space boundary-element normal-contact solver with the film as a
compliant layer in series (plus roughness laws), and the wheel-rail problem
(`solve_wheel_rail`) with the FE's edge reading for areas."""
from filmcal.wheelrail.edge import (EdgeReading, EdgeWindow, patch_ring_areas_mm2, read_contact_edge,
                                    read_fitted_outline, read_radial_edge_mm)
from filmcal.wheelrail.halfspace import (ContactResult, HalfSpaceContactSolver, SurfaceGrid, rectangle_influence_mm,
                                         sphere_on_flat_contact)
from filmcal.wheelrail.hertz import HertzContact, hertz_elliptic
from filmcal.wheelrail.interface import (ExponentialLaw, FilmLayer, GreenwoodWilliamsonLaw, HardLaw, InterfaceLaw,
                                         TabularLaw)
from filmcal.wheelrail.placement import ContactPoint, WheelRailPlacement, offset_range_mm, place_wheel_on_rail
from filmcal.wheelrail.wheelrail import (ContactPatch, ContactPlane, ContactRegion, WheelRailCase, WheelRailGeometry,
                                         WheelRailModel, WheelRailResult, get_wheel_rail_model, local_hertz,
                                         solve_wheel_rail, solve_wheel_rail_many)
from filmcal.wheelrail.profiles import (PROFILE_NAMES, Profile, flange_height_mm, flange_thickness_mm, get_profile,
                                        head_width_mm, load_profile_csv, profile_dimensions)

__all__ = [
    "SurfaceGrid", "ContactResult", "HalfSpaceContactSolver", "rectangle_influence_mm", "sphere_on_flat_contact",
    "HertzContact", "hertz_elliptic", "FilmLayer", "InterfaceLaw", "HardLaw", "ExponentialLaw", "TabularLaw",
    "GreenwoodWilliamsonLaw", "ContactPoint", "WheelRailPlacement", "offset_range_mm", "place_wheel_on_rail",
    "PROFILE_NAMES", "Profile", "get_profile", "load_profile_csv", "flange_height_mm", "flange_thickness_mm",
    "head_width_mm", "profile_dimensions", "EdgeWindow", "EdgeReading", "read_radial_edge_mm", "read_fitted_outline",
    "read_contact_edge", "patch_ring_areas_mm2", "ContactPlane", "ContactRegion", "ContactPatch", "WheelRailCase",
    "WheelRailResult", "WheelRailGeometry", "WheelRailModel", "get_wheel_rail_model", "local_hertz",
    "solve_wheel_rail", "solve_wheel_rail_many",
]
