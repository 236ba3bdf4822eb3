"""Wheel-rail contact: S1002 / 60E1 / 60E2 profiles, wheel placement with lateral
offset, a half-space boundary-element normal-contact solver with the film as a
compliant layer in series (plus roughness laws), and the wheel-rail problem
(`solve_wheel_rail`); areas are where the pressure is positive."""
from __future__ import annotations

from filmcal._lazy import lazy_exports

# imported on first use, so that the command line starts fast
__all__, __getattr__, __dir__ = lazy_exports(__name__, {
    'filmcal.wheelrail.patches': ['patch_ring_areas_mm2'],
    'filmcal.wheelrail.halfspace': ['ContactResult', 'HalfSpaceContactSolver', 'SurfaceGrid', 'rectangle_influence_mm', 'sphere_on_flat_contact'],
    'filmcal.wheelrail.hertz': ['HertzContact', 'hertz_elliptic'],
    'filmcal.contact.laws': ['ExponentialLaw', 'FilmLayer', 'GreenwoodWilliamsonLaw', 'HardLaw', 'InterfaceLaw', 'TabularLaw'],
    'filmcal.wheelrail.placement': ['ContactPoint', 'WheelRailPlacement', 'offset_range_mm', 'place_wheel_on_rail'],
    'filmcal.wheelrail.wheelrail': ['ContactPatch', 'ContactPlane', 'ContactRegion', 'WheelRailCase', 'WheelRailGeometry', 'WheelRailModel', 'WheelRailResult', 'get_wheel_rail_model', 'local_hertz', 'solve_wheel_rail', 'solve_wheel_rail_many'],
    'filmcal.wheelrail.profiles': ['PROFILE_NAMES', 'Profile', 'flange_height_mm', 'flange_thickness_mm', 'get_profile', 'head_width_mm', 'load_profile_csv', 'profile_dimensions'],
}, globals())
