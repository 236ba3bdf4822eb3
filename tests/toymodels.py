"""Test functions shared by the calibration tests (not physics)."""
from __future__ import annotations

import numpy as np

from filmcal.elastic import oedometric_ratio

STEEL_CONTACT_MODULUS_MPA = 210000.0 / (2.0 * (1.0 - 0.3**2))


class ToyRadiusModel:
    """Test function (not physics): r = a_H + 2.2 mm * (p_H / M)^0.5, exact (std 0).

    Hertz (Johnson, Contact Mechanics, eqs. 4.21-4.22), steel on steel:
    a_H = (3 F R / (4 E*))^(1/3), p_H = 3 F / (2 pi a_H^2).
    """

    def predict(self, modulus_mpa, poisson, sphere_radius_mm, force_n):
        E, nu, R, F = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in
                                            (modulus_mpa, poisson, sphere_radius_mm, force_n)))
        a = np.cbrt(3.0 * F * R / (4.0 * STEEL_CONTACT_MODULUS_MPA))
        p = 3.0 * F / (2.0 * np.pi * a**2)
        mean = a + 2.2 * np.sqrt(p / (E * oedometric_ratio(nu)))
        return mean, np.zeros(mean.shape)


def toy_simulator(params: dict) -> dict:
    """A lab's simulator stand-in (not physics): `ToyRadiusModel`'s radius, and a Hertz-shaped pressure
    profile over it, p(r) = p0 sqrt(1 - (r/a)^2) with p0 = 3F / (2 pi a^2) (Johnson, eq. 4.22)."""
    E, nu = float(params["modulus_mpa"]), float(params["poisson"])
    R, F = float(params["sphere_radius_mm"]), 1e3 * float(params["force_kn"])
    a = float(ToyRadiusModel().predict(E, nu, R, F)[0])
    r = np.linspace(0.0, 1.5 * a, 1501)
    p0 = 3.0 * F / (2.0 * np.pi * a**2)
    pressure = p0 * np.sqrt(np.clip(1.0 - (r / a) ** 2, 0.0, None))
    return {"contact_radius_mm": a, "radius_mm": r.tolist(), "pressure_mpa": pressure.tolist()}


def halfspace_simulator(params: dict) -> dict:
    """A simulator of another law than the calibrated FE: filmcal's half-space film model (the film as a
    layer of springs between two elastic half-spaces, `filmcal.wheelrail.halfspace.sphere_on_flat_contact`),
    sphere on flat, its edge radius sqrt(A / pi). No pressure profile: only the edge model reads it."""
    import math

    from filmcal.contact.laws import FilmLayer
    from filmcal.wheelrail.halfspace import sphere_on_flat_contact

    layer = FilmLayer(float(params["modulus_mpa"]), float(params["poisson"]), float(params["film_thickness_mm"]))
    result = sphere_on_flat_contact(float(params["sphere_radius_mm"]), 1e3 * float(params["force_kn"]), film=layer)
    return {"contact_radius_mm": math.sqrt(float(result.area_mm2) / math.pi)}
