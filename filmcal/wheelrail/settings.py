"""The wheel-rail model's defaults, written once (the solvers' signatures and the command line read them).

Light on purpose: the command line builds its options from these without importing the solvers.
"""
from __future__ import annotations

__all__ = ["WHEEL", "RAIL", "RAIL_INCLINATION", "NOMINAL_RADIUS_MM", "GRID_MM", "GRID_MM_RANGE",
           "FILM_MIN_CELLS_ACROSS", "HARD_SPHERE_MIN_CELLS_ACROSS"]

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
#: A contact through a film (linear or large-strain) is solved on at least this many cells across in each
#: direction (the grid is refined where the patch is narrower, down to an eighth of the cell size). The film's
#: readings and the transfer term resolve edge offsets of a few micrometres; on fewer cells the discrete edge
#: moves with the grid's phase: on sphere-on-flat at 0.1 mm, a 2.4 mm patch (48 cells across) read its
#: capsule radius 0.005-0.007 mm off the converged one, a 3.0 mm patch (61 cells) 0.005 mm, and on 70 cells or
#: more within 0.0013 mm (docs/verification.md). On S1002/60E2 at 0.1 mm, tread patches through a film span
#: 59-97 cells at 20 kN (the stiffer the film, the fewer) and 93 or more at 50 kN: the lighter loads, stiff
#: films, flange patches and small spheres are refined, in the direction that needs it.
FILM_MIN_CELLS_ACROSS = 80
#: A sphere-on-flat contact without film or roughness (`filmcal.wheelrail.halfspace.sphere_on_flat_contact`)
#: is solved on at least this many cells across. Its Hertz radius, read by the hard edge's signed distance, moves
#: with the grid's phase: over the phases, -0.09..+0.06 % at 24-36 cells per radius, -0.05..+0.02 % at 40-48
#: and -0.047..+0.011 % at 48-56 (R 250 mm / 15 kN scanned through a/h; the error depends on a/h alone). The
#: wheel-rail model keeps its tread patches on the given grid: their ellipses read closer at equal cells
#: (docs/verification.md).
HARD_SPHERE_MIN_CELLS_ACROSS = 100
