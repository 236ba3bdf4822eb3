"""Growth of an imprint on rough bodies, from pairs of solves.

``g_f``: a film model's rough reading of the solve with the rough laws in series over its smooth reading
(`filmcal.contact.rough_imprint`). A body is given by its Ra (a draw's synthetic surface) or as a measured
`RoughSurface`; Ra = 0 gives 1 exactly. The wheel-rail growths of the corrections and curves, with the
contact without film's, are `filmcal.correction.roughness.solve_growths`.
"""
from __future__ import annotations

from typing import Callable

from filmcal.contact.rough_imprint import RoughnessInputs, rough_recorded_area_mm2

__all__ = ["film_growth", "sphere_growth"]


def film_growth(model, modulus_mpa: float, inputs: RoughnessInputs, solve: Callable, smooth,
                wheel=None, rail=None) -> float:
    """``g_f`` of one draw: ``solve(film, law)`` solves the configuration, ``smooth`` is its smooth solve."""
    bodies = inputs.bodies(wheel, rail)
    if bodies.smooth:
        return 1.0
    film, law, rough_law = model.interface(float(modulus_mpa), bodies)
    rough = solve(film, law)
    base = model.recorded_area_mm2(smooth)
    if base <= 0.0:
        return 1.0
    return rough_recorded_area_mm2(model, rough, rough_law, inputs.reading_level) / base


def sphere_growth(model, modulus_mpa: float, inputs: RoughnessInputs, ra_um: float, *,
                  sphere_radius_mm: float = 450.0, force_n: float = 50e3, smooth=None) -> float:
    """``g_f`` on sphere-on-flat with a roughened flat (the paper's test): the flat is the rough body."""
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    def solve(film, law):
        return sphere_on_flat_contact(sphere_radius_mm, force_n, film=film, law=law)

    if smooth is None:
        film, law, _ = model.interface(float(modulus_mpa))
        smooth = solve(film, law)
    return film_growth(model, modulus_mpa, inputs, solve, smooth, wheel=ra_um)
