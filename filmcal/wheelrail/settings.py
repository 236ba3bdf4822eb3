"""The wheel-rail model's defaults, written once (the solvers' signatures and the command line read them).

Light on purpose: the command line builds its options from these without importing the solvers.
"""
from __future__ import annotations

__all__ = ["WHEEL", "RAIL", "RAIL_INCLINATION", "NOMINAL_RADIUS_MM", "GRID_MM", "GRID_MM_RANGE"]

#: Wheel and rail profiles of the paper's wheel-rail cases.
WHEEL = "S1002"
RAIL = "60E2"
#: Rail inclination 1:40 (the paper's track).
RAIL_INCLINATION = 1.0 / 40.0
#: Nominal rolling radius of the wheel at its tape circle (mm).
NOMINAL_RADIUS_MM = 460.0
#: Cell size of the contact grid (mm): the film's resolution.
GRID_MM = 0.1
#: The grid sizes the model accepts (mm, inclusive).
GRID_MM_RANGE = (0.01, 1.0)
