"""Figures (matplotlib, Agg backend: no display needed)."""
from __future__ import annotations

import numpy as np


def _figure(**kwargs):
    from matplotlib.figure import Figure
    return Figure(layout="constrained", **kwargs)


def plot_pressure_profile(result, path: str) -> None:
    """Pressure p(r) of an FE result against the Hertz distribution (PNG)."""
    from filmcal.hertz import hertz_pressure_mpa

    fig = _figure(figsize=(6.4, 4.2))
    ax = fig.subplots()
    r = result.r_mm
    rr = np.linspace(0, r[-1], 800)
    ax.plot(rr, hertz_pressure_mpa(rr, result.radius_mm, result.force_n), "k--", lw=1, label="Hertz, no film")
    label = "FE, no film" if result.film_modulus_mpa is None else (
        f"FE, film E = {result.film_modulus_mpa:g} MPa, nu = {result.film_poisson:g}")
    ax.plot(r, result.pressure_mpa, ".-", ms=3, lw=1, label=label)
    ax.axvline(result.contact_radius_mm, color="C0", lw=0.8, ls=":", label=f"a = {result.contact_radius_mm:.3f} mm")
    ax.axvline(result.hertz_radius_mm, color="k", lw=0.8, ls=":", label=f"a Hertz = {result.hertz_radius_mm:.3f} mm")
    ax.set_xlim(0, 1.25 * max(result.contact_radius_mm, result.hertz_radius_mm))
    ax.set_xlabel("r (mm)")
    ax.set_ylabel("contact pressure (MPa)")
    ax.set_title(f"Sphere R{result.radius_mm:g} on flat, F = {result.force_n / 1e3:g} kN")
    ax.legend(fontsize=8)
    ax.grid(lw=0.3)
    fig.savefig(path, dpi=120)
