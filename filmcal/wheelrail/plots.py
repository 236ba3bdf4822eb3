"""Figures of a wheel-rail solve."""
from __future__ import annotations

from pathlib import Path

__all__ = ["plot_pressure_map"]


def plot_pressure_map(result, path: str | Path) -> None:
    """Pressure map in track coordinates with the fitted and positive-pressure outlines."""
    import numpy as np
    from matplotlib.figure import Figure

    from filmcal._io import atomic_savefig

    grid = result.grid
    x = grid.x_mm
    y = result.grid_track_y_mm
    p = np.ma.masked_less_equal(result.pressure_mpa, 0.0)
    fig = Figure(figsize=(6.4, 5.2), layout="constrained")
    ax = fig.add_subplot()
    mesh = ax.pcolormesh(y, x, p, shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="pressure (MPa)")
    for k, ring in enumerate(result.outline_mm):
        ax.plot(ring[:, 1], ring[:, 0], "-", color="black", lw=1.0,
                label="contact outline (pressure > 0)" if k == 0 else None)
    ax.set_aspect("equal")
    ax.set_xlabel("y (mm), track frame, field side positive")
    ax.set_ylabel("x (mm), along the rail")
    film = "no film" if result.film is None else f"film E = {result.film.modulus_mpa:g} MPa"
    ax.set_title(f"{result.placement.wheel.name} on {result.placement.rail.name}, "
                 f"eta = {result.offset_mm:g} mm, F = {result.force_n / 1e3:g} kN, {film}\n"
                 f"A = {result.area_mm2:.1f} mm2, p_max = {result.max_pressure_mpa:.0f} MPa",
                 fontsize=9)
    ax.legend(loc="upper right", fontsize=7, framealpha=0.6)
    atomic_savefig(fig, path, dpi=150)
